"""Live trials through nginx: one server process against two on one PostgreSQL database, and failover.

`python -m benchmarks live_processes [capacity] [failover] [survivor]
[supervised] [growth]` runs the parts named (all five, in that order, when
none is). Needs PostgreSQL
(HCSS_BENCH_DATABASE_URL, else HCSS_TEST_DATABASE_URL) and nginx; each group
of processes gets its own schema.

- capacity (11 min on an idle 2-core machine, 28 min under a load average
  of 10): the same clients as benchmarks/live.py (a stream per trial, a refused command every
  2 s, its latency to the stream) reach the processes through the nginx
  configuration `hcss deploy nginx` writes, every process a `--cluster` one
  (leases on), so the figures of 1 and 2 processes differ only in the number
  of processes; each group's capacity is searched by bisection. The processes
  snapshot every 5 s as served ones do (before 2026-12-06: every 1 s). Every
  trial commands on its own 2-s schedule (`paced_drive`; before 2026-12-06 one
  thread sent each round in turn, so at 120+ trials each got fewer commands),
  and each line says the commands sent of those due. The part ends with trials
  held per core of server CPU for 1 and 2 processes and the machine's CPU use,
  which say whether this machine (clients, nginx and PostgreSQL on it too) or
  the processes set the 2/1 ratio.
- failover (about 4 min; 3.6-4.6 min under a load average of 8-12): kill -9,
  SIGSTOP past the lease, and a partition from the database, each of one of
  two processes behind nginx hosting about half of 20 trials: per taken-over
  trial the failover time and what its participant's page, reading the
  stream as live.js does, did not see; rows lost or doubled; after a stop or
  a partition, whether the faulty process wrote anything once it woke, and
  the next takeover (benchmarks/failover.py says what each figure is).
  Each line also says how the trials split between the processes (placement)
  and how many moved (a lease that changed owner or epoch) or were interrupted
  while the pages were driven: 0 and 0 without a fault (issue 41).
- supervised (about 2 min): the baseline a group is weighed against: one
  `hcss serve` process (no group) and its trials, kill -9, started again at
  once as a service manager does (systemd `Restart=always`): seconds until it
  answers, until every trial steps again, and the longest clock stop.
- growth (about 4 min): the database's growth per trial-hour: bot trials
  hosted at 1x by one process, the size of every table of the schema before
  and after, snapshots written and kept.
- survivor (about 4 min; 3.4-3.7 min under a load average of 8-12): 60 and then 120
  trials on one process, a second started, kill -9 of the first: how the
  survivor takes them all and keeps its leases.
"""

from __future__ import annotations

import json
import os
import statistics
import threading
import time
from collections import Counter
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path
from tempfile import TemporaryDirectory

import httpx
from sqlalchemy import func, select, text

from benchmarks.failover import (
    FAILOVER_TRIALS,
    FAULT_S,
    FAULTS,
    SURVIVOR_COUNTS,
    SURVIVOR_WATCH_S,
    fault_round,
    print_faults,
    print_survivors,
    start_ready,
    survivor_round,
)
from benchmarks.live import (
    COMMAND_EVERY_S,
    MEASURE_S,
    TARGET_P95_MS,
    TARGET_RATE_HZ,
    StreamReader,
    _percentile,
    _process_cpu_s,
    participant_address,
    start_trials,
)
from hcss.platform.cli import DEFAULT_THREADS, upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.client import TrialClient
from hcss.platform.live.placement import address_of
from hcss.platform.models import Interruption, Snapshot, TrialLease
from hcss.platform.serving.localserver import LocalNginx, LocalServer, as_group, postgres_schema

#: Where each group's capacity search starts: a count it held and one it did not in the
#: runs of 2026-12-01 (one process held 140, not 160; two held 240, not 280), widened so
#: a faster or slower machine still lands inside.
SEARCH_RANGE = {1: (80, 240), 2: (120, 400)}
#: The search stops when the held and the failed count are this close.
RESOLUTION = 10
#: Issue 20's target: two processes hold at least this many times the trials of one.
TARGET_RATIO = 1.7
#: As docs/operations.md says to run them: every client has nginx's address, so the
#: per-address connection cap would refuse the streams.
BEHIND_NGINX = {"HCSS_PROXY_HOPS": "1"}
PARTS = ("capacity", "failover", "survivor", "supervised", "growth")
#: Trials and wall seconds of the growth part: 3 trial-hours at 1x.
GROWTH_TRIALS, GROWTH_S = 60, 180.0
#: Trials of the supervised restart.
SUPERVISED_TRIALS = 60
#: The capacity runs' snapshot interval: a served process's (HCSS_SNAPSHOT_INTERVAL_S's
#: default). LocalServer's 1 s, for tests, wrote 5x the snapshots and prunes: 0.7-1.0
#: snapshot rows and 0.6-0.9 deletions per trial-second, 20-24 % of each runner's samples
#: at 60 trials per process (py-spy, 2026-12-06), against 9-10 % at 5 s.
SERVED_SNAPSHOT_INTERVAL = {"HCSS_SNAPSHOT_INTERVAL_S": "5.0"}


def database_base_url() -> str | None:
    return os.environ.get("HCSS_BENCH_DATABASE_URL") or os.environ.get("HCSS_TEST_DATABASE_URL")


@contextmanager
def group(
    url: str, processes: int, workdir: Path, extra_env: dict[str, str] | None = None
) -> Iterator[tuple[list[LocalServer], LocalNginx]]:
    """`processes` `--cluster` servers on one database behind one nginx, as operations.md deploys."""
    servers = as_group(  # each told the group: trials are claimed where nginx sends pages
        [
            LocalServer(
                url,
                workdir / f"process-{i}",
                threads=DEFAULT_THREADS,
                serve_args=["--cluster"],
                extra_env={**BEHIND_NGINX, **(extra_env or {})},
            )
            for i in range(processes)
        ]
    )
    nginx = LocalNginx([f"127.0.0.1:{s.port}" for s in servers], workdir / "nginx")
    try:
        start_ready(*servers)  # trials started before "simulation ready" would wait for it
        nginx.start()
        yield servers, nginx
    finally:
        nginx.stop()
        for server in servers:
            server.stop()


def measure(processes: int, n_trials: int, base: str, workdir: Path) -> dict[str, float]:
    with postgres_schema(base, "hcss_bench") as url:
        return capacity_run(url, processes, n_trials, workdir)


def capacity_run(url: str, processes: int, n_trials: int, workdir: Path) -> dict[str, float]:
    """One capacity measurement on the (migrated or empty) database at `url`: `n_trials`
    pages driven through nginx in front of `processes` `--cluster` processes, with the
    trials' moves (a lease that changed owner or epoch) and interruptions counted, which
    are 0 without a fault (issue 41; tests/platform/test_capacity_moves.py). The
    processes snapshot as served ones do (`SERVED_SNAPSHOT_INTERVAL`)."""
    upgrade_database(url)
    workdir = workdir / f"{processes}x{n_trials}"
    with group(url, processes, workdir, SERVED_SNAPSHOT_INTERVAL) as (servers, nginx):
        # Started now, as pages do: each is claimed by the process its token routes to.
        tokens = start_trials(url, n_trials)
        claim(nginx.url, tokens)
        pids = [s.process.pid for s in servers if s.process is not None]
        assert nginx.process is not None
        nginx_pids = [nginx.process.pid, *_children(nginx.process.pid)]
        database = Database(url)
        leases_before = _leases(database)
        result = paced_drive(nginx.url, tokens, pids, nginx_pids)
        leases_after = _leases(database)
        result["leased"] = float(len(leases_before))  # every trial, once its page opened
        result["moves"] = sum(
            1 for t, lease in leases_before.items() if leases_after.get(t) != lease
        )
        split = [
            sum(1 for owner, _ in leases_after.values() if address_of(owner) == address)
            for address in (f"{s.host}:{s.port}" for s in servers)
        ]
        result["split"] = max(split) / max(1, sum(split))
        with database.session_scope() as session:
            result["interruptions"] = float(
                session.scalar(select(func.count()).select_from(Interruption)) or 0
            )
        database.engine.dispose()
        return result


class Refusals:
    """A page's 503s by why the server refused it, read from their JSON bodies as live.js does.

    "busy": the process was at its stream ceiling; "moved": the trial was held by, or
    moving to, another process (`held_by` or `moved`), a refusal 0 moves would not
    have caused; "other": nginx's own 5xx pages, the database away. Recorded by an httpx
    response hook, so the page's stream and commands are sent exactly as before.
    """

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.streams: Counter[str] = Counter()
        self.commands: Counter[str] = Counter()

    def hook(self, response: httpx.Response) -> None:
        if response.status_code < 500:
            return
        response.read()  # a refusal's body is a short JSON (or nginx's HTML) page, not a stream
        try:
            body = json.loads(response.content)
        except ValueError:
            body = {}
        body = body if isinstance(body, dict) else {}
        if body.get("error") == "busy":
            why = "busy"
        elif body.get("error") == "moved" or "held_by" in body:
            why = "moved"
        else:
            why = "other"
        with self.lock:
            kind = self.streams if response.request.url.path.endswith("/stream") else self.commands
            kind[why] += 1


def paced_drive(
    base_url: str, tokens: list[str], server_pids: list[int], nginx_pids: list[int]
) -> dict[str, float]:
    """Every token's page through `base_url`, as benchmarks/live.py's `drive` with its
    streams unchanged, but each trial commanding every `COMMAND_EVERY_S` on a schedule of
    its own, whatever the number of trials.

    `drive` sends one round of commands from one thread, one after another, so a round of
    120+ trials took longer than the 2 s between rounds (5-10 s under load, 240 commands in
    20 s instead of 360): the more trials, the less each one commanded, and 1 and 2
    processes were not given the same load per trial. Here trial i's k-th command is due
    at i/N of the interval plus k intervals (spread as a study's pages are) and is sent
    at its time by a pool as large as the trials, so a slow answer delays no other
    command. The result says how many were due and how many were sent inside the window
    (and how late), so a reader sees the load was equal; CPU (the servers, nginx, these
    clients, the whole machine from /proc/stat) is taken over the same window.
    """
    stop = threading.Event()
    readers = []
    refusals = []
    for index, token in enumerate(tokens):
        client = TrialClient(base_url, token, local_address=participant_address(index))
        seen = Refusals()
        client.http.event_hooks["response"].append(seen.hook)
        client.open_page()
        readers.append(StreamReader(client, stop))
        refusals.append(seen)
    for reader in readers:
        reader.start()
    time.sleep(2.0)  # let every stream settle
    n = len(readers)
    rounds = round(MEASURE_S / COMMAND_EVERY_S)
    schedule = sorted(
        (COMMAND_EVERY_S * (k + i / n), i, k * n + i) for k in range(rounds) for i in range(n)
    )
    lateness: list[float] = []  # seconds after its due time each sent command went
    lateness_lock = threading.Lock()
    started = time.perf_counter()
    ended = started + MEASURE_S

    def send(due: float, reader: StreamReader, number: int) -> None:
        now = time.perf_counter()
        if now - due > COMMAND_EVERY_S:
            return  # the trial's next command is due already: this one counts as not sent
        with lateness_lock:
            lateness.append(now - due)
        reader.command(number)

    cpu = _cpu_now(server_pids, nginx_pids)
    with ThreadPoolExecutor(max_workers=max(1, n)) as pool:
        for offset, index, number in schedule:
            due = started + offset
            time.sleep(max(0.0, due - time.perf_counter()))
            pool.submit(send, due, readers[index], number)
        time.sleep(max(0.0, ended - time.perf_counter()))
        spent = _cpu_now(server_pids, nginx_pids) - cpu
        window = time.perf_counter() - started
        # Leaving the pool waits for the last commands, sent until 2 s after their time.
    time.sleep(1.0)  # the last refusals
    stop.set()
    for reader in readers:
        reader.join(timeout=5.0)
        if not reader.is_alive():
            reader.client.close()
    rates = [sum(started <= t <= ended for t in r.frame_times) / MEASURE_S for r in readers]
    latencies = sorted(ms for r in readers for ms in r.latencies_ms)
    lost = sum(len(r.sent) for r in readers)
    late_ms = sorted(1000.0 * late for late in lateness)
    return {
        "trials": float(n),
        "min_rate_hz": min(rates),
        "median_rate_hz": statistics.median(rates),
        "p50_ms": _percentile(latencies, 50),
        "p95_ms": _percentile(latencies, 95),
        "commands": float(len(latencies) + lost),  # refusals expected: the latency's samples
        "unseen": float(lost),
        "due": float(len(schedule)),
        "sent": float(len(lateness)),
        "p95_late_ms": _percentile(late_ms, 95),
        "server_cpu": spent.servers / window,
        "nginx_cpu": spent.nginx / window,
        # The clients share the machine's two cores with the servers, nginx and PostgreSQL.
        "clients_cpu": spent.clients / window,
        "machine_cpu": spent.machine_busy / max(spent.machine_total, 1e-9),
        "refused": float(sum(r.refused is not None for r in readers)),
        "reopened": float(sum(r.reopened for r in readers)),
        "refused_moved": float(
            sum(1 for seen in refusals if seen.streams["moved"] or seen.commands["moved"])
        ),
        "refused_busy": float(sum(1 for seen in refusals if seen.streams["busy"])),
        "commands_moved": float(sum(seen.commands["moved"] for seen in refusals)),
    }


class _Cpu:
    """CPU seconds used so far: by the servers, nginx, this process (the clients), and the
    whole machine (busy and total, every core, from /proc/stat)."""

    def __init__(
        self, servers: float, nginx: float, clients: float, busy: float, total: float
    ) -> None:
        self.servers, self.nginx, self.clients = servers, nginx, clients
        self.machine_busy, self.machine_total = busy, total

    def __sub__(self, earlier: _Cpu) -> _Cpu:
        return _Cpu(
            self.servers - earlier.servers,
            self.nginx - earlier.nginx,
            self.clients - earlier.clients,
            self.machine_busy - earlier.machine_busy,
            self.machine_total - earlier.machine_total,
        )


def _cpu_now(server_pids: list[int], nginx_pids: list[int]) -> _Cpu:
    busy, total = _machine_cpu_s()
    return _Cpu(
        sum(_process_cpu_s(pid) for pid in server_pids),
        sum(_process_cpu_s(pid) for pid in nginx_pids),
        time.process_time(),
        busy,
        total,
    )


def _machine_cpu_s() -> tuple[float, float]:
    """The machine's busy and total CPU seconds since boot, all cores (/proc/stat's first
    line; idle and iowait are not busy); NaN where /proc is missing."""
    try:
        with open("/proc/stat") as stat:
            ticks = [int(field) for field in stat.readline().split()[1:9]]
    except OSError:
        return float("nan"), float("nan")
    per_s = os.sysconf("SC_CLK_TCK")
    return (sum(ticks) - ticks[3] - ticks[4]) / per_s, sum(ticks) / per_s


def _leases(database: Database) -> dict[int, tuple[str, int]]:
    with database.session_scope() as session:
        rows = session.execute(select(TrialLease.trial_id, TrialLease.owner, TrialLease.epoch))
        return {trial_id: (owner, epoch) for trial_id, owner, epoch in rows}


def claim(base_url: str, tokens: list[str]) -> None:
    """Each trial's first look through `base_url`, which claims it where nginx sends it.

    Before the streams open, as a study's pages open over minutes, not all at once: a
    stream whose first look claims and loads the trial has no frame within nginx's 3-s
    stream read timeout when 80+ open in the same second on a busy machine (504), and
    a refused stream counts against the capacity.
    """

    def look(index: int, token: str) -> None:
        client = TrialClient(base_url, token, local_address=participant_address(index))
        client.http.timeout = httpx.Timeout(30.0)
        try:
            client.open_page()
            for _ in range(30):
                try:
                    client.state()
                    return
                except httpx.HTTPStatusError as error:
                    if error.response.status_code not in (502, 503, 504):
                        raise
                time.sleep(1.0)
        finally:
            client.close()

    with ThreadPoolExecutor(max_workers=8) as pool:
        list(pool.map(look, range(len(tokens)), tokens))


def _children(pid: int) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as children:
            return [int(child) for child in children.read().split()]
    except OSError:
        return []


def held(r: dict[str, float]) -> bool:
    """Every trial streamed at 2 Hz (5% slack), p95 command-to-stream under target, none lost,
    and the load was given in full: every command due was sent (`paced_drive`).

    A page whose stream was refused opens it again after the Retry-After, as live.js does,
    and its rate counts the frames it missed meanwhile; one refused for good has rate 0.
    """
    return (
        r["min_rate_hz"] >= TARGET_RATE_HZ * 0.95
        and r["p95_ms"] < TARGET_P95_MS
        and r["unseen"] == 0
        and r["sent"] == r["due"]
    )


#: One capacity search's outcome: the most trials held, the fewest not held (None: the
#: top of the range held), and the measurement at the most held (None: none held).
Capacity = tuple[int, int | None, dict[str, float] | None]


def capacity(processes: int, base: str, workdir: Path) -> Capacity:
    """The most trials the group held and the fewest it did not, to `RESOLUTION`, by bisection.

    A search, not fixed counts: the 1.7x target needs both capacities, and fixed
    counts only bracketed them (140-160 and 240-280 left 1.5x-2.0x open). Each
    count is one 20-s measurement on fresh processes; a count that fails below
    one that held is printed as measured and bounds the search from above.
    """
    low, high = SEARCH_RANGE[processes]
    at_low = _measured(processes, low, base, workdir)
    if at_low is None or not held(at_low):
        return 0, low, None
    at_high = _measured(processes, high, base, workdir)
    if at_high is not None and held(at_high):
        return high, None, at_high  # held even the top of the range
    while high - low > RESOLUTION:
        n = (low + high) // 2 // 5 * 5
        at_n = _measured(processes, n, base, workdir)
        if at_n is not None and held(at_n):
            low, at_low = n, at_n
        else:
            high = n
    return low, high, at_low


def _measured(processes: int, n: int, base: str, workdir: Path) -> dict[str, float] | None:
    """One count measured and printed; None when a connection failed."""
    try:
        r = measure(processes, n, base, workdir)
    except OSError as error:
        print(f"    {n:>3} trials, {processes} process(es): failed ({error})")
        return None
    print(
        f"    {n:>3} trials, {processes} process(es) via nginx: commands sent "
        f"{r['sent']:.0f} of {r['due']:.0f} due (p95 {r['p95_late_ms']:.0f} ms after "
        f"their time); stream {r['min_rate_hz']:.2f} Hz min / {r['median_rate_hz']:.2f} Hz "
        f"median; command -> stream p50 {r['p50_ms']:.0f} ms, p95 {r['p95_ms']:.0f} ms "
        f"({r['unseen']:.0f} of {r['commands']:.0f} unseen); "
        f"{r['refused']:.0f} pages refused or dropped ({r['refused_busy']:.0f} busy, "
        f"{r['refused_moved']:.0f} because a trial moved), {r['reopened']:.0f} reopens; "
        f"servers {r['server_cpu']:.0%} of a core ({n / max(r['server_cpu'], 1e-9):.0f} trials per "
        f"core), nginx {r['nginx_cpu']:.0%}, clients {r['clients_cpu']:.0%}, machine "
        f"{r['machine_cpu']:.0%} of its {os.cpu_count()} cores; largest share "
        f"{r['split']:.0%}, {r['moves']:.0f} moved, {r['interruptions']:.0f} interrupted  "
        f"{'held' if held(r) else 'not held'}",
        flush=True,
    )
    return r


def run(parts: list[str] | None = None) -> None:
    chosen = parts or list(PARTS)
    for part in chosen:
        if part not in PARTS:
            raise SystemExit(f"unknown part {part!r} of live_processes; choose from {PARTS}")
    base = database_base_url()
    if base is None or not LocalNginx.available():
        print("    skipped: needs HCSS_BENCH_DATABASE_URL (PostgreSQL) and nginx (make nginx)")
        return
    with TemporaryDirectory() as tmp:
        for part in chosen:
            started = time.perf_counter()
            {
                "capacity": _capacities,
                "failover": _failovers,
                "survivor": _survivors,
                "supervised": _supervised,
                "growth": _growth,
            }[part](base, Path(tmp))
            print(f"    ({part}: {time.perf_counter() - started:.0f} s)", flush=True)


def _capacities(base: str, workdir: Path) -> None:
    print_capacities({processes: capacity(processes, base, workdir) for processes in (1, 2)})


def print_capacities(found: dict[int, Capacity]) -> None:
    """Each group's capacity, the 2/1 ratio, and beside it what says whether the machine
    was the limit: trials held per core of server CPU at each group's largest held count
    (within 10% of one process's where the processes, not the machine, set the ratio:
    issue 41), the machine's CPU use in those runs, and the pages refused because a
    trial moved."""
    for processes, (most, fewest, _) in found.items():
        above = f", not {fewest}" if fewest is not None else "+ (the top of the search)"
        print(f"    capacity, {processes} process(es): {most} trials held{above}")
    one, two = found[1][0], found[2][0]
    ratio = f"{two / one:.2f}x" if one else "n/a"
    print(
        f"(4b) trials 2 processes hold / trials 1 holds: {ratio}   [target: "
        f"{TARGET_RATIO}x, issue 20; 1.8x, issue 41; each capacity to {RESOLUTION} trials]"
    )
    per_core = {}
    for processes, (most, _, r) in found.items():
        if r is None:
            print(f"    {processes} process(es): no count held, no CPU figures")
            continue
        per_core[processes] = most / r["server_cpu"]
        cores = os.cpu_count() or 1
        rest = r["machine_cpu"] * cores - r["server_cpu"] - r["nginx_cpu"] - r["clients_cpu"]
        print(
            f"    at {most} trials, {processes} process(es): servers {r['server_cpu']:.2f} "
            f"cores, {per_core[processes]:.0f} trials per core of server CPU; machine "
            f"{r['machine_cpu']:.0%} busy of {cores} cores (servers "
            f"{r['server_cpu']:.2f}, nginx {r['nginx_cpu']:.2f}, clients "
            f"{r['clients_cpu']:.2f}, the rest, PostgreSQL and other work, {rest:.2f}); "
            f"commands sent {r['sent']:.0f} of {r['due']:.0f} due; "
            f"{r['refused_moved']:.0f} pages refused because a trial moved, "
            f"{r['moves']:.0f} moved",
            flush=True,
        )
    if 1 in per_core and 2 in per_core:
        print(
            f"(4c) trials per core of server CPU, 2 processes / 1: "
            f"{per_core[2] / per_core[1]:.2f}   [within 10% (>= 0.90) where the machine "
            f"is the limit, issue 41]   (2/1 trials held: {ratio})"
        )


def _failovers(base: str, workdir: Path) -> None:
    print(
        f"    failover: 2 --cluster processes behind nginx, {FAILOVER_TRIALS} trials; process 0 "
        f"is killed, stopped or cut off from the database (the last two for {FAULT_S:.0f} s); "
        "each page reads its stream as live.js does"
    )
    print_faults([fault_round(base, workdir, fault) for fault in FAULTS])


def _survivors(base: str, workdir: Path) -> None:
    print(
        "    survivor: n trials on one process, a second started, kill -9 of the first; "
        f"watched {SURVIVOR_WATCH_S:.0f} s after the survivor holds all (leases every 1 s)"
    )
    print_survivors([survivor_round(base, workdir, n) for n in SURVIVOR_COUNTS])


def _supervised(base: str, workdir: Path) -> None:
    """One process, kill -9, started again at once: how long its trials stand still."""
    with postgres_schema(base, "hcss_bench") as url:
        upgrade_database(url)
        server = LocalServer(url, workdir / "supervised", threads=DEFAULT_THREADS)
        database = Database(url)
        try:
            start_ready(server)
            tokens = start_trials(url, SUPERVISED_TRIALS)
            claim(server.url, tokens)
            clients = [TrialClient(server.url, token) for token in tokens]
            for client in clients:
                client.open_page()
            time.sleep(6.0)  # a snapshot of each (every 5 s)
            steps = [client.state()["trial"]["step"] for client in clients]
            server.kill()
            killed = time.monotonic()
            server.start(timeout_s=120)  # Restart=always: at once (RestartSec 100 ms)
            answering = time.monotonic() - killed
            stepping: list[float | None] = [None] * len(clients)
            while any(s is None for s in stepping) and time.monotonic() - killed < 120:
                for index, client in enumerate(clients):
                    if stepping[index] is not None:
                        continue
                    try:
                        if client.state()["trial"]["step"] > steps[index]:
                            stepping[index] = time.monotonic() - killed
                    except httpx.HTTPError:
                        pass
                time.sleep(0.2)
            with database.session_scope() as session:
                outages = list(session.scalars(select(Interruption.outage_s)))
            done = sorted(s for s in stepping if s is not None)
            print(
                f"    supervised: 1 process, {len(tokens)} trials, kill -9 and started again "
                f"at once: answering {answering:.1f} s after the kill; {len(done)} of "
                f"{len(tokens)} trials stepping again, the last {done[-1]:.1f} s after "
                f"(median {done[len(done) // 2]:.1f} s); {len(outages)} interruptions, "
                f"longest clock stop {max(outages, default=0.0):.1f} s",
                flush=True,
            )
            for client in clients:
                client.close()
        finally:
            server.stop()
            database.engine.dispose()


def _growth(base: str, workdir: Path) -> None:
    """The database's growth per trial-hour, with snapshots written and kept."""
    with postgres_schema(base, "hcss_bench") as url:
        upgrade_database(url)
        # A snapshot every 5 s, the platform's default (LocalServer's is 1 s).
        server = LocalServer(
            url, workdir / "growth", threads=DEFAULT_THREADS, snapshot_interval_s=5.0
        )
        database = Database(url)
        try:
            start_ready(server)
            before = _schema_bytes(database)
            tokens = start_trials(url, GROWTH_TRIALS)
            claim(server.url, tokens)
            time.sleep(GROWTH_S)
            with database.session_scope() as session:
                kept, last, first = session.execute(
                    select(func.count(), func.max(Snapshot.id), func.min(Snapshot.id))
                ).one()
            server.stop()  # its last writes in, then measured
            trial_hours = GROWTH_TRIALS * GROWTH_S / 3600
            raw = _schema_bytes(database)
            # Deleted snapshots are dead rows until (auto)vacuum marks their space for
            # reuse; VACUUM FULL leaves what the trials keep: the growth that stays.
            with database.engine.connect() as connection:
                connection.execution_options(isolation_level="AUTOCOMMIT").execute(
                    text("VACUUM FULL")
                )
            after = _schema_bytes(database)
            for label, sizes in (("written", raw), ("kept", after)):
                grown = {t: sizes.get(t, 0) - before.get(t, 0) for t in sizes}
                total = sum(grown.values())
                top = sorted(grown.items(), key=lambda item: -item[1])[:4]
                print(
                    f"    growth ({label}): {GROWTH_TRIALS} bot trials hosted {GROWTH_S:.0f} s "
                    f"at 1x ({trial_hours:.1f} trial-hours): {total / 1e6:.1f} MB, "
                    f"{total / trial_hours / 1e6:.2f} MB per trial-hour ("
                    + ", ".join(f"{t} {b / 1e6:.2f} MB" for t, b in top)
                    + ")",
                    flush=True,
                )
            print(
                f"    snapshots: {last - first + 1 if kept else 0} written at most, "
                f"{kept} kept ({kept / GROWTH_TRIALS:.1f} per trial)",
                flush=True,
            )
        finally:
            server.stop()
            database.engine.dispose()


def _schema_bytes(database: Database) -> dict[str, int]:
    """Each table's size in the schema (heap, indexes and TOAST), in bytes."""
    with database.session_scope() as session:
        rows = session.execute(
            text(
                "SELECT c.relname, pg_total_relation_size(c.oid) FROM pg_class c "
                "JOIN pg_namespace n ON n.oid = c.relnamespace "
                "WHERE n.nspname = current_schema() AND c.relkind = 'r'"
            )
        )
        return {name: int(size) for name, size in rows}
