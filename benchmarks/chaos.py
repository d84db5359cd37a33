"""A chaos soak in the manner of Jepsen's nemesis: faults at random, then the invariants.

`python -m benchmarks chaos` (or `make chaos`) runs `CHAOS_S` (30 minutes by default;
HCSS_CHAOS_S, HCSS_CHAOS_SEED) and prints a history and a verdict per invariant;
tests/platform/test_chaos.py runs 3 minutes of it in the suite, its seed printed.

The system: two `hcss serve --cluster` processes behind the generated nginx on PostgreSQL
(a schema of its own on the shared server), each reaching PostgreSQL through a relay of
its own (benchmarks/relay.py) and as a role of its own, so a fault touches this run only.
Meanwhile:
- participant bots walk the demo study over HTTP through nginx, as the page does (pages,
  forms, the live JSON API with Idempotency-Keys, probes; hcss.platform.bots.http_load),
  a new one started whenever one finishes;
- an experimenter's console (signed in through nginx) reads the progress table and the
  index, creates participants and opens trials' replays.

The nemesis (one `numpy.random.Generator` from the seed) picks a fault every few seconds,
applies it for a while, heals it, and writes each step to the history:
- kill: kill -9 of a process, started again after the pause;
- stop: SIGSTOP of a process past its 6-s lease, then SIGCONT;
- partition: a process's database link stalls (every byte held), then passes on;
- restart: both links cut at the relay, every connection dropped and refused, as a
  PostgreSQL restart looks to the processes (the shared server itself is never
  restarted; a real restart is not done here);
- read_only: the run's role made read-only and its sessions ended, as a standby;
- flood: slow clients (a header byte every 2 s) hold hundreds of nginx's connections.

The checker (benchmarks/chaos_check.py) then reads the database directly and judges.
The same seed gives the same faults at the same offsets; load makes the rest differ.
"""

from __future__ import annotations

import os
import signal
import socket
import threading
import time
import uuid
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from sqlalchemy import create_engine, text
from sqlalchemy.engine import make_url

from benchmarks.failover import start_ready
from benchmarks.relay import CutProxy
from hcss.platform.bots.http_load import HttpClient, LoadFigures, make_bot_participants
from hcss.platform.bots.participant import ParticipantBot
from hcss.platform.cli import DEFAULT_THREADS, upgrade_database
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.db import Database
from hcss.platform.live.idempotency import KEY_HEADER
from hcss.platform.serving.localserver import LocalNginx, LocalServer, postgres_schema
from hcss.platform.study.studyfile import load_study

CHAOS_S = float(os.environ.get("HCSS_CHAOS_S", "1800"))
SEED = int(os.environ.get("HCSS_CHAOS_SEED", "44"))
FAULTS = ("kill", "stop", "partition", "restart", "read_only", "flood")
STUDY = "demo"
ACCELERATION = "30"
BOTS_AT_ONCE = 6
#: Seconds after the last fault for the bots under way to finish their study.
SETTLE_S = 240.0
USERNAME, PASSWORD = "chaos", "a long chaos password"
LEASE_S = 6.0


@dataclass
class History:
    """What happened, in order: (seconds since the start, who, what)."""

    started: float = field(default_factory=time.monotonic)
    events: list[tuple[float, str, str]] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def add(self, who: str, what: str) -> None:
        with self.lock:
            self.events.append((time.monotonic() - self.started, who, what))


@dataclass
class Answers:
    """Every HTTP answer the bots and the console got (raw, before any retry)."""

    statuses: Counter[str] = field(default_factory=Counter)
    bad: list[str] = field(default_factory=list)  # the processes' 5xx but 503 + Retry-After
    gateway: list[str] = field(default_factory=list)  # nginx's 502/504: a process lost
    acknowledged: dict[str, tuple[str, int, Any]] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def hook(self, response: httpx.Response) -> None:
        request = response.request
        status = response.status_code
        with self.lock:
            self.statuses[str(status)] += 1
            said = f"{status} {request.method} {request.url.path[:80]}"
            if status in (502, 504):
                self.gateway.append(said)
            elif status >= 500 and not (status == 503 and response.headers.get("Retry-After")):
                self.bad.append(said)
        key = request.headers.get(KEY_HEADER)
        if key and request.method == "POST" and status == 200:
            response.read()
            try:
                body = response.json()
            except ValueError:
                body = None
            with self.lock:
                self.acknowledged[key] = (request.url.path, status, body)


@dataclass
class Participants:
    """Each bot participant's code and how its walk ended ("completed" or the error)."""

    outcomes: dict[str, str] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)


def _client(base_url: str, answers: Answers) -> HttpClient:
    client = HttpClient(base_url, LoadFigures(bots=1, concurrency=1))
    client.http.event_hooks["response"] = [answers.hook]
    return client


def walk_bots(
    base_url: str, url: str, until: float, answers: Answers, people: Participants, history: History
) -> None:
    """Bots through the whole study, `BOTS_AT_ONCE` at a time, a new one for each that ends,
    until `until` (monotonic); those under way walk on to their end."""
    study = load_study(STUDY)
    numbers = iter(range(1_000_000))

    def one(number: int) -> None:
        ((token, code),) = make_bot_participants(url, 1)
        client = _client(base_url, answers)
        try:
            ParticipantBot(None, token, seed=number, client=client, code=code).run(study)
            outcome = "completed"
        except Exception as error:  # noqa: BLE001 - a bot that stopped is a finding
            outcome = f"{type(error).__name__}: {str(error)[:160]}"
            history.add("bot", f"{code} stopped: {outcome}")
        finally:
            client.close()
        with people.lock:
            people.outcomes[code] = outcome

    def lane() -> None:
        while time.monotonic() < until:
            one(next(numbers))

    with ThreadPoolExecutor(BOTS_AT_ONCE) as pool:
        list(pool.map(lambda _: lane(), range(BOTS_AT_ONCE)))


def run_console(base_url: str, stop: threading.Event, answers: Answers, history: History) -> None:
    """The experimenter at work: the progress table, the index, new participants, replays."""
    rng = np.random.default_rng(SEED + 1)
    http = httpx.Client(base_url=base_url, timeout=30.0, event_hooks={"response": [answers.hook]})
    signed_in = False
    csrf = ""
    while not stop.wait(float(rng.uniform(0.5, 2.5))):
        try:
            if not signed_in:
                page = http.get("/console/login")
                csrf = _csrf(page.text)
                fields = {"csrf_token": csrf, "username": USERNAME, "password": PASSWORD}
                signed_in = http.post("/console/login", data=fields).status_code == 302
                continue
            choice = int(rng.integers(0, 10))
            if choice < 5:
                http.get("/console/progress.json")
            elif choice < 8:
                index = http.get("/console/")
                if index.status_code == 200:
                    csrf = _csrf(index.text) or csrf
                elif index.status_code == 302:
                    signed_in = False
            elif choice < 9:
                made = http.post(
                    "/console/participants",
                    data={"csrf_token": csrf, "count": "1", "study": STUDY},
                )
                history.add("console", f"create participant: {made.status_code}")
            else:
                trial = int(rng.integers(1, 40))
                http.get(f"/console/trials/{trial}/replay/frames?start=0&count=20")
        except httpx.HTTPError as error:
            history.add("console", f"{type(error).__name__}")
    http.close()


def _csrf(page: str) -> str:
    marker = 'name="csrf-token" content="'
    start = page.find(marker)
    return page[start + len(marker) : page.index('"', start + len(marker))] if start >= 0 else ""


class Flood:
    """Slow clients: each sends a request's headers a byte every 2 s and never ends them."""

    def __init__(self, host: str, port: int, count: int) -> None:
        self.stop = threading.Event()
        self.sockets: list[socket.socket] = []
        for _ in range(count):
            try:
                self.sockets.append(socket.create_connection((host, port), timeout=2))
            except OSError:
                break
        self.thread = threading.Thread(target=self._drip, daemon=True)
        self.thread.start()

    def _drip(self) -> None:
        for end in self.sockets:
            with _quietly():
                end.sendall(b"GET /console/login HTTP/1.1\r\nHost: chaos\r\n")
        while not self.stop.wait(2.0):
            for end in self.sockets:
                with _quietly():
                    end.sendall(b"X")

    def end(self) -> None:
        self.stop.set()
        self.thread.join()
        for end in self.sockets:
            with _quietly():
                end.close()


class _quietly:
    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: Any, *_: Any) -> bool:
        return kind is not None and issubclass(kind, OSError)


@dataclass
class Cluster:
    """The two processes, their relays, nginx, and the run's PostgreSQL role."""

    servers: list[LocalServer]
    relays: list[CutProxy]
    nginx: LocalNginx
    admin: Any  # an AUTOCOMMIT engine on the shared server
    role: str

    def set_read_only(self, on: bool) -> None:
        with self.admin.connect() as connection:
            value = "SET default_transaction_read_only = on" if on else "RESET ALL"
            connection.execute(text(f'ALTER ROLE "{self.role}" {value}'))
            connection.execute(
                text("SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE usename = :r"),
                {"r": self.role},
            )


def nemesis(
    cluster: Cluster, until: float, rng: np.random.Generator, history: History, faults: Counter
) -> None:
    """Faults at random (kind, process, length from the seed) until `until`, each healed."""
    while True:
        pause = float(rng.uniform(4.0, 12.0))
        kind = str(rng.choice(FAULTS))
        victim = int(rng.integers(0, 2))
        length = float(rng.uniform(LEASE_S + 2.0, LEASE_S + 8.0))
        if time.monotonic() + pause + length > until:
            return
        time.sleep(pause)
        server, relay = cluster.servers[victim], cluster.relays[victim]
        faults[kind] += 1
        history.add("nemesis", f"{kind} process {victim} for {length:.1f} s")
        if kind == "kill":
            server.kill()
            time.sleep(length)
            server.start(timeout_s=180)
        elif kind == "stop":
            assert server.process is not None
            os.kill(server.process.pid, signal.SIGSTOP)
            time.sleep(length)
            os.kill(server.process.pid, signal.SIGCONT)
        elif kind == "partition":
            relay.stall()
            time.sleep(length)
            relay.heal()
        elif kind == "restart":
            for each in cluster.relays:
                each.cut()
            time.sleep(length)
            for each in cluster.relays:
                each.restore()
        elif kind == "read_only":
            cluster.set_read_only(True)
            time.sleep(length)
            cluster.set_read_only(False)
        else:
            port = int(cluster.nginx.url.rsplit(":", 1)[1])
            flood = Flood("127.0.0.1", port, 300)
            time.sleep(length)
            flood.end()
        history.add("nemesis", f"healed {kind}")


def _role(admin: Any, schema_url: str) -> tuple[str, str]:
    """A login role of this run with every right on its schema; the URL that uses it."""
    role = f"hcss_chaos_{uuid.uuid4().hex[:8]}"
    schema = make_url(schema_url).query["options"]
    schema = str(schema).split("search_path=", 1)[1].split()[0]
    with admin.connect() as connection:
        connection.execute(text(f'CREATE ROLE "{role}" LOGIN'))
        for grant in (
            f'GRANT USAGE, CREATE ON SCHEMA "{schema}" TO "{role}"',
            f'GRANT ALL ON ALL TABLES IN SCHEMA "{schema}" TO "{role}"',
            f'GRANT ALL ON ALL SEQUENCES IN SCHEMA "{schema}" TO "{role}"',
        ):
            connection.execute(text(grant))
    return role, make_url(schema_url).set(username=role).render_as_string(hide_password=False)


def _drop_role(admin: Any, role: str) -> None:
    with admin.connect() as connection:
        connection.execute(
            text("SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE usename = :r"),
            {"r": role},
        )
        connection.execute(text(f'DROP OWNED BY "{role}"'))
        connection.execute(text(f'DROP ROLE "{role}"'))


def run_chaos(base_url: str, workdir: Path, seconds: float, seed: int) -> dict[str, Any]:
    """One seeded soak; its history, its figures and the checker's verdicts."""
    from benchmarks.chaos_check import check

    history, answers, people, faults = History(), Answers(), Participants(), Counter()
    rng = np.random.default_rng(seed)
    admin = create_engine(base_url, isolation_level="AUTOCOMMIT")
    with postgres_schema(base_url, "hcss_chaos") as url:
        upgrade_database(url)
        database = Database(url)
        with database.session_scope() as session:
            create_experimenter(session, USERNAME, PASSWORD)
        role, role_url = _role(admin, url)
        parsed = make_url(role_url)
        relays = [CutProxy(parsed.host or "127.0.0.1", parsed.port or 5432) for _ in range(2)]
        env = {"HCSS_PROXY_HOPS": "1", "HCSS_STUDY": STUDY, "HCSS_TIME_ACCELERATION": ACCELERATION}
        servers = [
            LocalServer(
                parsed.set(host="127.0.0.1", port=relay.port).render_as_string(hide_password=False),
                workdir / f"process-{number}",
                threads=DEFAULT_THREADS,
                serve_args=["--cluster"],
                extra_env=env,
            )
            for number, relay in enumerate(relays)
        ]
        nginx = LocalNginx([f"127.0.0.1:{s.port}" for s in servers], workdir / "nginx")
        cluster = Cluster(servers, relays, nginx, admin, role)
        stop_console = threading.Event()
        try:
            start_ready(*servers)
            nginx.start()
            history.add("run", f"seed {seed}, {seconds:.0f} s, {nginx.url}")
            until = time.monotonic() + seconds
            console = threading.Thread(
                target=run_console, args=(nginx.url, stop_console, answers, history), daemon=True
            )
            bots = threading.Thread(
                target=walk_bots,
                args=(nginx.url, url, until, answers, people, history),
                daemon=True,
            )
            console.start()
            bots.start()
            nemesis(cluster, until, rng, history, faults)
            history.add("run", "faults over; the bots under way finish")
            bots.join(timeout=max(0.0, until - time.monotonic()) + SETTLE_S)
            if bots.is_alive():
                history.add("run", "bots still walking after the settle time")
            stop_console.set()
            console.join(timeout=60)
            verdicts = check(database, answers, people)
            proxy_errors = _proxy_errors(workdir / "nginx" / "error.log")
        finally:
            stop_console.set()
            for server in servers:
                if server.process is not None:
                    with _quietly():
                        os.kill(server.process.pid, signal.SIGCONT)
            cluster.set_read_only(False)
            for relay in relays:
                relay.heal()
                relay.restore()
            nginx.stop()
            for server in servers:
                server.stop()
            for relay in relays:
                relay.close()
            database.engine.dispose()
            _drop_role(admin, role)
    admin.dispose()
    return {
        "seed": seed,
        "seconds": seconds,
        "history": history.events,
        "faults": dict(faults),
        "answers": dict(answers.statuses),
        "acknowledged": len(answers.acknowledged),
        "process_5xx": list(answers.bad),
        "stopped": {c: o for c, o in people.outcomes.items() if o != "completed"},
        "participants": dict(Counter(o == "completed" for o in people.outcomes.values())),
        "verdicts": verdicts,
        "proxy_errors": proxy_errors,
    }


def _proxy_errors(log: Path) -> dict[str, int]:
    """nginx's complaints about the processes, by kind (why a 502 or 504 was answered)."""
    kinds: Counter[str] = Counter()
    if log.exists():
        for line in log.read_text(errors="replace").splitlines():
            if "upstream" in line:
                kinds[
                    line.split("] ", 1)[-1].split(" while ", 1)[0].split(", client")[0][-90:]
                ] += 1
    return dict(kinds.most_common(8))


def print_run(result: dict[str, Any]) -> None:
    print(f"== chaos: seed {result['seed']}, {result['seconds']:.0f} s")
    for at, who, what in result["history"]:
        print(f"  {at:7.1f} s  {who:8s} {what}")
    print(f"faults: {result['faults']}")
    print(f"answers by status: {dict(sorted(result['answers'].items()))}")
    print(f"commands acknowledged (keyed, 200): {result['acknowledged']}")
    print(f"nginx on the processes: {result['proxy_errors']}")
    done = result["participants"]
    print(f"participants: {done.get(True, 0)} completed, {done.get(False, 0)} stopped")
    for name, (ok, detail) in result["verdicts"].items():
        print(f"  {'PASS' if ok else 'FAIL'}  {name}: {detail}")
    print(
        f"reproduce: HCSS_CHAOS_SEED={result['seed']} HCSS_CHAOS_S={result['seconds']:.0f} make chaos"
    )


def run(parts: list[str] | None = None) -> None:
    base = os.environ.get("HCSS_BENCH_DATABASE_URL") or os.environ.get("HCSS_TEST_DATABASE_URL")
    if not base or not LocalNginx.available():
        print("== chaos: needs PostgreSQL (HCSS_TEST_DATABASE_URL) and nginx")
        return
    import tempfile

    with tempfile.TemporaryDirectory(prefix="hcss-chaos-") as folder:
        result = run_chaos(base, Path(folder), CHAOS_S, SEED)
    print_run(result)
    if not all(ok for ok, _ in result["verdicts"].values()):
        raise SystemExit(1)
