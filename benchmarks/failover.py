"""Failover as participants see it: kill -9, SIGSTOP and a partition, and a loaded survivor.

Part of `python -m benchmarks live_processes` (its `failover` and `survivor`
parts; see that module for running them alone).

Faults (`fault_round`): two `--cluster` processes behind nginx on
PostgreSQL, `FAILOVER_TRIALS` trials started through nginx (each claimed by
the process its token hashes to), every participant's stream read through
nginx as the page reads it (benchmarks/pages.py: watchdog, `?after=`).
Process 0 is the victim:

- kill: SIGKILL.
- stop: SIGSTOP for `FAULT_S` (past the 6-s lease), then SIGCONT.
- partition: process 0 reaches PostgreSQL through a relay (benchmarks/relay.py)
  that holds every byte for `FAULT_S`, then passes them on; the process itself
  runs on.

During a stop or a partition each of the victim's trials gets one keyed click
(an observation) sent to the victim itself, which waits in its socket or on
its database; it must be answered 503 and write nothing, since another
process hosts the trial by then. The lease table is read every 0.2 s: the
takeover is the first reading with another owner. Per taken-over trial:

- takeover: seconds from the fault to the lease held by the other process;
- stepping: seconds from the fault to the first frame through nginx, after the
  takeover, whose step is past the last one the page saw before it;
- longest gap: the longest wall time between two frames the page got;
- skipped: the largest forward jump of the trial clock between two frames
  (0.5 s is one frame's worth): trial time the page never saw;
- rewind: the largest backward jump (the page holds its clock; it shows none).

Afterwards: rows of those trials lost (ids gone), observation rows written for
the queued clicks (0 wanted), decisions/events/request statuses stored twice,
trials handed back to the victim after it woke (its nginx hash asks for
them), and, after a stop or a partition, the next takeover: kill -9 of the
other process, the victim rebuilds every trial, and `rebuild_failed` counts.

Survivor (`survivor_round`): n trials on one process, a second started, kill
-9 of the first, the survivor watched for `SURVIVOR_WATCH_S` after it holds
all: time until it holds all, its leases still valid on PostgreSQL's clock
(sampled every second), "lost the lease" in its log, interruptions and the
longest clock stop (Interruption.outage_s) per trial, `rebuild_failed`.
"""

from __future__ import annotations

import contextlib
import os
import signal
import statistics
import threading
import time
import uuid
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import httpx
from sqlalchemy import Double, cast, func, select
from sqlalchemy.engine import make_url

from benchmarks.live import start_trials
from benchmarks.pages import PageStream, close_pages, open_pages
from benchmarks.relay import CutProxy
from hcss.platform.cli import DEFAULT_THREADS, upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.client import TrialClient
from hcss.platform.models import (
    Command,
    DecisionRow,
    Interruption,
    Observation,
    RequestStatusChange,
    SimEvent,
    TrialLease,
    TrialStatusChange,
)
from hcss.platform.serving.localserver import LocalNginx, LocalServer, as_group, postgres_schema

FAILOVER_TRIALS = 20
FAULTS = ("kill", "stop", "partition")
FAULT_S = 15.0  # a stop or a partition: past the 6-s lease, as the rounds
AFTER_FAULT_S = 20.0  # the pages are read this long after the fault ends
SURVIVOR_COUNTS = (60, 120)
SURVIVOR_WATCH_S = 30.0
BEHIND_NGINX = {"HCSS_PROXY_HOPS": "1"}


def _server(url: str, workdir: Path, name: str) -> LocalServer:
    return LocalServer(
        url,
        workdir / name,
        threads=DEFAULT_THREADS,
        serve_args=["--cluster"],
        extra_env=BEHIND_NGINX,
    )


def start_ready(*servers: LocalServer, timeout_s: float = 240.0) -> None:
    """Start each and wait for its "simulation ready": a fresh instance compiles the kernels
    in the background (20-40 s under load), and a trial claimed before that waits for it,
    which a failover figure must not include."""
    for server in servers:
        server.start(timeout_s=120)
    deadline = time.monotonic() + timeout_s
    for server in servers:
        while "hcss: simulation ready" not in server.log_path.read_text():
            if "preparing the simulation failed" in server.log_path.read_text():
                raise RuntimeError(f"{server.url}: {server.log_path.read_text()}")
            if time.monotonic() > deadline:
                raise TimeoutError(f"{server.url}: simulation not ready in {timeout_s:.0f} s")
            time.sleep(0.5)


def _prefix(server: LocalServer) -> str:
    """The start of the lease owner's name of a process (`host:port/start`)."""
    return f"{server.host}:{server.port}/"


def _leases(database: Database) -> dict[int, tuple[str, int]]:
    with database.session_scope() as session:
        rows = session.execute(select(TrialLease.trial_id, TrialLease.owner, TrialLease.epoch))
        return {trial_id: (owner, epoch) for trial_id, owner, epoch in rows}


class LeaseWatch(threading.Thread):
    """The lease table every `every_s`: (time, {trial: (owner, epoch)}) readings."""

    def __init__(self, database: Database, every_s: float = 0.2) -> None:
        super().__init__(daemon=True, name="lease-watch")
        self.database, self.every_s = database, every_s
        self.readings: list[tuple[float, dict[int, tuple[str, int]]]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        while not self.stop.is_set():
            with contextlib.suppress(Exception):  # a failed reading is a missing sample
                self.readings.append((time.monotonic(), _leases(self.database)))
            self.stop.wait(self.every_s)

    def first_time(self, trial_id: int, since: float, held: Callable[[str], bool]) -> float | None:
        for at, leases in self.readings:
            if at >= since and trial_id in leases and held(leases[trial_id][0]):
                return at
        return None


def _row_ids(database: Database, trial_ids: list[int]) -> dict[str, set[int]]:
    """The ids of the record's rows of these trials. Not snapshots: older ones are pruned
    by design once a newer one is written (hcss.platform.live.snapshots)."""
    tables = (Command, SimEvent, DecisionRow, RequestStatusChange)
    with database.session_scope() as session:
        return {
            model.__tablename__: set(
                session.scalars(select(model.id).where(model.trial_id.in_(trial_ids)))
            )
            for model in tables
        }


def _doubled(database: Database, trial_ids: list[int]) -> int:
    """Decisions, events and request statuses stored more than once (rows beyond the first)."""
    queries = (
        select(DecisionRow.trial_id, DecisionRow.collective, DecisionRow.decision_index),
        select(SimEvent.trial_id, SimEvent.kind, SimEvent.sim_time, SimEvent.text),
        select(
            RequestStatusChange.trial_id,
            RequestStatusChange.request_id,
            RequestStatusChange.status,
        ),
    )
    doubled = 0
    with database.session_scope() as session:
        for query in queries:
            table = query.selected_columns[0].table
            rows = [tuple(r) for r in session.execute(query.where(table.c.trial_id.in_(trial_ids)))]
            doubled += len(rows) - len(set(rows))
    return doubled


def _count(database: Database, query: Any) -> int:
    with database.session_scope() as session:
        return int(session.scalar(query) or 0)


def _rebuild_failed(database: Database) -> int:
    return _count(
        database,
        select(func.count())
        .select_from(TrialStatusChange)
        .where(TrialStatusChange.reason == "rebuild_failed"),
    )


def _page_figures(page: PageStream, fault_at: float, took_over: float | None) -> dict[str, Any]:
    """What one participant's page saw from just before the fault on."""
    frames = page.frames
    before = [f for f in frames if f.at < fault_at]
    window = ([before[-1]] if before else []) + [f for f in frames if f.at >= fault_at]
    gaps = [b.at - a.at for a, b in zip(window, window[1:], strict=False)]
    jumps = [b.clock_s - a.clock_s for a, b in zip(window, window[1:], strict=False)]
    stepping = None
    if took_over is not None:
        seen = max((f.step for f in frames if f.at < took_over), default=-1)
        stepping = next(
            (f.at - fault_at for f in frames if f.at >= took_over and f.step > seen), None
        )
    return {
        "gap_s": max(gaps, default=float("nan")),
        "skipped_s": max(jumps, default=float("nan")),
        "rewind_s": max([0.0, *(-j for j in jumps)]),
        "stepping_s": stepping,
        "reconnects": sum(at >= fault_at for at, _ in page.attempts),
    }


def fault_round(base: str, workdir: Path, fault: str) -> dict[str, Any]:
    """One fault of process 0 of two behind nginx; the figures of its trials' pages and rows."""
    with postgres_schema(base, "hcss_bench") as url:
        upgrade_database(url)
        database = Database(url)
        relay = None
        victim_url = url
        if fault == "partition":
            parsed = make_url(url)
            relay = CutProxy(parsed.host or "127.0.0.1", parsed.port or 5432)
            victim_url = parsed.set(host="127.0.0.1", port=relay.port).render_as_string(
                hide_password=False
            )
        folder = workdir / f"failover-{fault}"
        victim, other = _server(victim_url, folder, "victim"), _server(url, folder, "other")
        as_group([victim, other])  # placed where nginx sends their pages
        nginx = LocalNginx([f"127.0.0.1:{s.port}" for s in (victim, other)], folder / "nginx")
        watch = LeaseWatch(database)
        pages: list[PageStream] = []
        stop_pages = threading.Event()
        try:
            start_ready(victim, other)
            nginx.start()
            tokens = start_trials(url, FAILOVER_TRIALS)
            clients = []
            for token in tokens:
                client = TrialClient(nginx.url, token)
                client.http.timeout = httpx.Timeout(30.0)  # a first claim on a loaded machine
                client.open_page()  # its process claims it
                _keyed(client, "/requests", {"kind": "decide", "collective": 0, "target": 1})
                clients.append(client)
            pages, stop_pages = open_pages(nginx.url, [(c.token, c.trial_id or 0) for c in clients])
            time.sleep(3.0)  # streams settle; a snapshot of each, as a running study has
            owners = _leases(database)
            moved = [c for c in clients if owners[c.trial_id or 0][0].startswith(_prefix(victim))]
            moved_ids = [c.trial_id or 0 for c in moved]
            victim_name = owners[moved_ids[0]][0] if moved_ids else ""
            watch.start()
            rows = _row_ids(database, moved_ids)
            assert victim.process is not None
            pid = victim.process.pid
            answers: list[int] = []
            clicks: list[threading.Thread] = []
            fault_at = time.monotonic()
            if fault == "kill":
                victim.kill()
            else:
                if fault == "stop":
                    os.kill(pid, signal.SIGSTOP)
                else:
                    assert relay is not None
                    relay.stall()
                clicks = [_queued_click(victim.url, c, answers) for c in moved]
                time.sleep(FAULT_S)
                if fault == "stop":
                    os.kill(pid, signal.SIGCONT)
                else:
                    assert relay is not None
                    relay.heal()
            woke_at = time.monotonic()
            for click in clicks:
                click.join(timeout=60)
            time.sleep(max(0.0, fault_at + FAULT_S + AFTER_FAULT_S - time.monotonic()))
            close_pages(pages, stop_pages)
            watch.stop.set()
            watch.join()
            after = _row_ids(database, moved_ids)
            observations = _count(
                database,
                select(func.count())
                .select_from(Observation)
                .where(Observation.trial_id.in_(moved_ids)),
            )
            doubled = _doubled(database, moved_ids)
            stops: dict[int, float] = {}
            with database.session_scope() as session:
                for trial_id, outage_s in session.execute(
                    select(Interruption.trial_id, Interruption.outage_s).where(
                        Interruption.trial_id.in_(moved_ids)
                    )
                ):
                    stops[trial_id] = max(stops.get(trial_id, 0.0), outage_s)
            final = _leases(database)
            handed_back = sum(
                final[t][0] == victim_name and final[t][1] > owners[t][1] for t in moved_ids
            )
            still_old = sum(final[t] == owners[t] for t in moved_ids)
            victim_lost = victim.log_path.read_text().count("lost the lease")
            figures: dict[str, Any] = {
                "fault": fault,
                "moved": len(moved),
                "trials": FAILOVER_TRIALS,
                "pages": [],
                "others": [],
                "lost": sum(len(ids - after[table]) for table, ids in rows.items()),
                "rows_before": sum(len(ids) for ids in rows.values()),
                "clicks": len(clicks),
                "click_answers": dict(Counter(answers)),
                "observations": observations,
                "doubled": doubled,
                "handed_back": handed_back,
                "unmoved_lease": still_old,
                "victim_lost_the_lease": victim_lost,
                "woke_after_s": woke_at - fault_at,
            }
            for page in pages:
                moved_here = page.trial_id in moved_ids
                took = (
                    watch.first_time(page.trial_id, fault_at, lambda o: o != victim_name)
                    if moved_here
                    else None
                )
                seen = _page_figures(page, fault_at, took)
                seen["takeover_s"] = None if took is None else took - fault_at
                seen["clock_stop_s"] = stops.get(page.trial_id) if moved_here else None
                figures["pages" if moved_here else "others"].append(seen)
            if fault != "kill":
                figures["next_takeover"] = _next_takeover(database, other, victim, moved_ids)
            figures["rebuild_failed"] = _rebuild_failed(database)
            return figures
        finally:
            stop_pages.set()
            watch.stop.set()
            if relay is not None:
                relay.heal()
            if victim.process is not None:
                os.kill(victim.process.pid, signal.SIGCONT)
            nginx.stop()
            for server in (victim, other):
                server.stop()
            if relay is not None:
                relay.close()
            database.engine.dispose()


def _keyed(client: TrialClient, path: str, body: dict[str, Any]) -> int:
    """A keyed command, repeated as the page repeats it (on 502, 503, 504); its last status."""
    headers = {"X-CSRFToken": client.csrf, "Idempotency-Key": str(uuid.uuid4())}
    status = 0
    for _ in range(20):
        try:
            status = client.http.post(client.api + path, json=body, headers=headers).status_code
        except httpx.TimeoutException:
            status = 504
        if status not in (502, 503, 504):
            return status
        time.sleep(1.0)
    return status


def _queued_click(url: str, page: TrialClient, answers: list[int]) -> threading.Thread:
    """A keyed click sent to the faulty process itself; its answer's status into `answers`."""

    def click() -> None:
        client = TrialClient(url, page.token)
        client.trial_id, client.csrf = page.trial_id, page.csrf
        client.http.cookies = page.http.cookies
        client.http.timeout = httpx.Timeout(90.0)
        try:
            status, _ = client.post(
                "/observations",
                {"kind": "collective", "collective": 0, "button": "left"},
                key=str(uuid.uuid4()),
            )
        except httpx.HTTPError as error:
            answers.append(-1)
            print(f"      queued click: {type(error).__name__}", flush=True)
        else:
            answers.append(status)
        finally:
            client.close()

    thread = threading.Thread(target=click, daemon=True)
    thread.start()
    return thread


def _next_takeover(
    database: Database, holder: LocalServer, heir: LocalServer, trial_ids: list[int]
) -> dict[str, Any]:
    """Kill -9 of `holder`; seconds until `heir` holds every trial, and rebuild_failed then."""
    holder.kill()
    killed = time.monotonic()
    deadline = killed + 60.0
    while time.monotonic() < deadline:
        leases = _leases(database)
        if all(leases.get(t, ("", 0))[0].startswith(_prefix(heir)) for t in trial_ids):
            break
        time.sleep(0.2)
    taken_s = time.monotonic() - killed
    time.sleep(3.0)  # the rebuilds that failed have ended their trials by now
    return {"taken_s": taken_s, "rebuild_failed": _rebuild_failed(database)}


def survivor_round(base: str, workdir: Path, n_trials: int) -> dict[str, Any]:
    """n trials on one process, a second started, kill -9 of the first: the survivor's figures."""
    with postgres_schema(base, "hcss_bench") as url:
        upgrade_database(url)
        database = Database(url)
        folder = workdir / f"survivor-{n_trials}"
        first, survivor = _server(url, folder, "first"), _server(url, folder, "survivor")
        try:
            start_ready(first)
            tokens = start_trials(url, n_trials)
            for token in tokens:  # each page reaches the first process, whose look claims it
                page = TrialClient(first.url, token)
                page.open_page()
                page.state()
                page.close()
            start_ready(survivor)
            assert _held(database, first)[0] == n_trials
            time.sleep(3.0)  # a snapshot of each
            first.kill()
            killed = time.monotonic()
            samples: list[tuple[float, int, int]] = []  # (s after the kill, held, valid)
            all_at = None
            while True:
                now = time.monotonic()
                held, valid = _held(database, survivor)
                samples.append((now - killed, held, valid))
                if all_at is None and held == n_trials:
                    all_at = now - killed
                if all_at is not None and now - killed > all_at + SURVIVOR_WATCH_S:
                    break
                if all_at is None and now - killed > 120.0:
                    break
                time.sleep(max(0.0, 1.0 - (time.monotonic() - now)))
            with database.session_scope() as session:
                outages = session.execute(
                    select(Interruption.trial_id, Interruption.outage_s)
                ).all()
            per_trial: dict[int, list[float]] = {}
            for trial_id, outage_s in outages:
                per_trial.setdefault(trial_id, []).append(outage_s)
            counts = [len(v) for v in per_trial.values()] + [0] * (n_trials - len(per_trial))
            longest = [max(v) for v in per_trial.values()]
            after_all = [v for s, _, v in samples if all_at is not None and s >= all_at]
            return {
                "trials": n_trials,
                "all_s": all_at,
                "valid_min_after_all": min(after_all, default=0),
                "valid_max": max((v for _, _, v in samples), default=0),
                "samples": samples,
                "lost_the_lease": survivor.log_path.read_text().count("lost the lease"),
                "interruptions": sum(counts),
                "interruptions_max": max(counts, default=0),
                "untouched": counts.count(0),
                "outage_median_s": statistics.median(longest) if longest else float("nan"),
                "outage_max_s": max(longest, default=float("nan")),
                "rebuild_failed": _rebuild_failed(database),
            }
        finally:
            for server in (first, survivor):
                server.stop()
            database.engine.dispose()


def _held(database: Database, server: LocalServer) -> tuple[int, int]:
    """Leases `server` holds, and how many of them are unexpired on PostgreSQL's clock."""
    now = cast(func.extract("epoch", func.clock_timestamp()), Double)
    with database.session_scope() as session:
        held, valid = session.execute(
            select(
                func.count(),
                func.count().filter(TrialLease.expires_epoch > now),
            ).where(TrialLease.owner.startswith(_prefix(server)))
        ).one()
    return int(held), int(valid)


def _spread(values: list[float | None]) -> str:
    """min / median / max of the values there are (a trial that never came back has None)."""
    got = sorted(v for v in values if v is not None)
    return f"{got[0]:.1f} / {statistics.median(got):.1f} / {got[-1]:.1f}" if got else "-"


FAULT_ROWS = (
    ("lease held by the other process", "takeover_s"),
    ("stepping again through nginx", "stepping_s"),
    ("longest gap between frames", "gap_s"),
    ("largest clock jump between frames", "skipped_s"),
    ("largest clock rewind in frames", "rewind_s"),
    ("trial clock stood still (outage_s)", "clock_stop_s"),
    ("stream requests per page", "reconnects"),
)


def print_faults(rounds: list[dict[str, Any]]) -> None:
    """One column per fault; per taken-over trial min / median / max, then the checks."""
    width = 22
    cells = [f"{r['fault']} ({r['moved']} of {r['trials']})" for r in rounds]
    print(
        f"      {'seconds after the fault, per trial':<36}"
        + "".join(f"{c:>{width}}" for c in cells)
    )
    print(f"      {'(min / median / max)':<36}")
    for label, key in FAULT_ROWS:
        row = [_spread([p[key] for p in r["pages"]]) for r in rounds]
        print(f"      {label:<36}" + "".join(f"{c:>{width}}" for c in row))
    others = [_spread([p["gap_s"] for p in r["others"]]) for r in rounds]
    print(
        f"      {'gap, trials of the other process':<36}" + "".join(f"{c:>{width}}" for c in others)
    )
    checks: list[tuple[str, Callable[[dict[str, Any]], object]]] = [
        ("trials never stepping again", lambda r: sum(p["stepping_s"] is None for p in r["pages"])),
        ("rows lost", lambda r: f"{r['lost']} of {r['rows_before']}"),
        ("decisions/events/statuses twice", lambda r: r["doubled"]),
        ("rebuild_failed", lambda r: r["rebuild_failed"]),
        (
            "clicks queued at process 0: answers",
            lambda r: " ".join(f"{k}x{v}" for k, v in sorted(r["click_answers"].items())) or "-",
        ),
        ("observation rows of those clicks", lambda r: r["observations"] if r["clicks"] else "-"),
        ("'lost the lease' in process 0's log", lambda r: r["victim_lost_the_lease"]),
        ("handed back to process 0 once awake", lambda r: r["handed_back"] if r["clicks"] else "-"),
        ("next kill -9: process 0 holds all", lambda r: _next(r, "taken_s", "{:.1f} s")),
        ("next kill -9: rebuild_failed", lambda r: _next(r, "rebuild_failed", "{}")),
    ]
    for label, value in checks:
        print(f"      {label:<36}" + "".join(f"{str(value(r)):>{width}}" for r in rounds))


def _next(r: dict[str, Any], key: str, form: str) -> str:
    return form.format(r["next_takeover"][key]) if "next_takeover" in r else "-"


SURVIVOR_ROWS: tuple[tuple[str, Callable[[dict[str, Any]], str]], ...] = (
    (
        "survivor holds all (s after kill -9)",
        lambda s: "never" if s["all_s"] is None else f"{s['all_s']:.1f}",
    ),
    ("valid leases, fewest after that", lambda s: f"{s['valid_min_after_all']} of {s['trials']}"),
    ("'lost the lease' in its log", lambda s: str(s["lost_the_lease"])),
    (
        "interruptions (per trial)",
        lambda s: f"{s['interruptions']} ({s['interruptions'] / s['trials']:.2f})",
    ),
    ("interruptions of one trial, most", lambda s: str(s["interruptions_max"])),
    ("trials never interrupted", lambda s: str(s["untouched"])),
    ("longest clock stop, median trial (s)", lambda s: f"{s['outage_median_s']:.1f}"),
    ("longest clock stop, worst trial (s)", lambda s: f"{s['outage_max_s']:.1f}"),
    ("rebuild_failed", lambda s: str(s["rebuild_failed"])),
)


def print_survivors(rounds: list[dict[str, Any]]) -> None:
    width = 14
    print(f"      {'':<38}" + "".join(f"{str(s['trials']) + ' trials':>{width}}" for s in rounds))
    for label, value in SURVIVOR_ROWS:
        print(f"      {label:<38}" + "".join(f"{value(s):>{width}}" for s in rounds))
