"""A whole study on two server processes behind nginx, one PostgreSQL database (issue 20, part 5).

The processes listen on different loopback addresses (127.0.0.2, 127.0.0.3),
as processes on two hosts would, and are `hcss serve --cluster` ones behind
the nginx configuration `hcss deploy nginx` writes. Counterbalancing must
stay exact when both assign cells at once, and a study walked by HTTP bots
must survive a kill -9 of the process that hosts most of its live trials.
"""

from __future__ import annotations

import re
import threading
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
from sqlalchemy import func, select

from hcss.platform.bots.http_load import LoadFigures, run_http_bots
from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import (
    Command,
    CommandKey,
    CommandOutcome,
    DecisionRow,
    Interruption,
    Observation,
    Participant,
    Probe,
    ProbeEvent,
    RequestStatusChange,
    SimEvent,
    Snapshot,
    StageEvent,
    TrialLease,
    TrialStatusChange,
)
from hcss.platform.serving.localserver import LocalNginx, LocalServer
from hcss.platform.study.enrolment import cell_counts
from hcss.platform.study.studyfile import load_study
from tests.support.leases import skip_unless_group

#: What a laptop's browser measures and posts with the study link's Start.
LAPTOP = {"width": "1366", "height": "768", "mobile": "0", "missing": ""}
HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')


@pytest.fixture
def group_database_url(database_url: str) -> str:
    return skip_unless_group(database_url)


@contextmanager
def _two_processes(
    database_url: str, workdir: Path, extra_env: dict[str, str] | None = None
) -> Iterator[tuple[list[LocalServer], LocalNginx]]:
    """Two `--cluster` processes on two addresses behind nginx, as docs/operations.md deploys."""
    servers = [
        LocalServer(
            database_url,
            workdir / name,
            snapshot_interval_s=1.0,
            serve_args=["--cluster"],
            host=address,
            extra_env={"HCSS_PROXY_HOPS": "1", **(extra_env or {})},
        )
        for name, address in (("a", "127.0.0.2"), ("b", "127.0.0.3"))
    ]
    nginx = LocalNginx([f"{s.host}:{s.port}" for s in servers], workdir / "nginx")
    try:
        for server in servers:
            server.start(timeout_s=120)  # a first start compiles the simulation
        nginx.start()
        yield servers, nginx
    finally:
        nginx.stop()
        for server in servers:
            server.stop()


@pytest.mark.slow
def test_participants_arriving_at_once_on_two_processes_fill_the_cells_exactly(
    group_database_url: str, tmp_path
) -> None:
    """Six waves of 8 first visits at once, half by the study link, half by created links.

    The single-process tests (test_study_counterbalancing.py,
    test_online_recruitment.py) show the assignment lock orders the threads
    of one process; a lock that only one process's threads shared would not
    order two. Through nginx the study link's Start (no token) goes
    round-robin to both processes and a personal link to the process its
    token hashes to, so both read the cell counts and enrol at the same
    moments. The counts are checked after every wave: a wave fills each of
    the 8 cells once, and a collision between the processes shows at once,
    where after all 48 a later arrival could have evened it out.
    """
    database_url = group_database_url
    upgrade_database(database_url)
    database = Database(database_url)
    study = load_study("demo")
    waves, cells = 6, len(study.cells)
    with database.session_scope() as session:
        created = [Participant(study="demo") for _ in range(waves * cells // 2)]
        session.add_all(created)
        session.flush()
        tokens = [p.token for p in created]
    answers: list[int] = []
    errors: list[BaseException] = []
    after_each_wave = []
    # Each visitor from an address of its own, as real ones come: nginx passes it on
    # (HCSS_PROXY_HOPS), and the study link's per-client limit stays as it ships.
    with _two_processes(database_url, tmp_path) as (_, nginx):

        def join(client: httpx.Client, barrier: threading.Barrier, number: int) -> httpx.Response:
            """The study link's first page (its form, its session cookie), then Start at once."""
            query = {"PROLIFIC_PID": f"cluster-{number:03d}", "STUDY_ID": "S1", "SESSION_ID": "X"}
            page = client.get("/join/demo", params=query)
            assert page.status_code == 200, page.text
            barrier.wait(timeout=60)
            return client.post("/join/demo", data=dict(HIDDEN.findall(page.text)) | LAPTOP)

        def enter(client: httpx.Client, barrier: threading.Barrier, token: str) -> httpx.Response:
            """A created participant's personal link, opened for the first time."""
            barrier.wait(timeout=60)
            return client.get(f"/p/{token}")

        def arrive(send, barrier, argument, visitor: int) -> None:
            address = f"127.0.{2 + visitor // 250}.{1 + visitor % 250}"
            transport = httpx.HTTPTransport(local_address=address)
            with httpx.Client(base_url=nginx.url, timeout=60, transport=transport) as client:
                try:
                    answers.append(send(client, barrier, argument).status_code)
                except BaseException as error:  # noqa: BLE001 - reported below
                    errors.append(error)

        for wave in range(waves):
            barrier = threading.Barrier(cells)
            half = cells // 2
            visits = [(join, barrier, wave * half + n) for n in range(half)]
            visits += [(enter, barrier, t) for t in tokens[wave * half : (wave + 1) * half]]
            threads = [
                threading.Thread(target=arrive, args=(*visit, wave * cells + n))
                for n, visit in enumerate(visits)
            ]
            for thread in threads:
                thread.start()
            for thread in threads:
                thread.join(timeout=120)
            with database.session_scope() as session:
                after_each_wave.append(dict(sorted(cell_counts(session, study, "real").items())))
    database.engine.dispose()
    assert not errors, errors
    assert answers == [302] * waves * cells, answers  # each enrolled, led on to its link
    print(f"cells after each wave of {cells} on two processes: {after_each_wave}")
    assert after_each_wave == [
        {cell.number: wave for cell in study.cells} for wave in range(1, waves + 1)
    ]


@pytest.mark.slow
def test_one_client_s_starts_are_limited_once_across_both_processes(
    group_database_url: str, tmp_path
) -> None:
    """One visitor's Starts, in turn on each process: the study link's window (3 per 10
    minutes here) is one count for the group, not one per process (before: each process
    kept its own windows, so the two let 6 of 8 Starts enrol)."""
    database_url = group_database_url
    upgrade_database(database_url)
    statuses: list[int] = []
    env = {"HCSS_JOIN_PER_CLIENT": "3/600"}
    with _two_processes(database_url, tmp_path, env) as (servers, _):
        transport = httpx.HTTPTransport(local_address="127.0.9.9")
        with httpx.Client(timeout=60, transport=transport) as client:
            for number in range(8):
                server = servers[number % 2].url
                query = {"PROLIFIC_PID": f"limit-{number}", "STUDY_ID": "S1", "SESSION_ID": "X"}
                page = client.get(f"{server}/join/demo", params=query)
                assert page.status_code == 200, page.text
                form = dict(HIDDEN.findall(page.text)) | LAPTOP
                statuses.append(client.post(f"{server}/join/demo", data=form).status_code)
    database = Database(database_url)
    with database.session_scope() as session:
        enrolled = session.scalar(select(func.count()).select_from(Participant))
    database.engine.dispose()
    assert statuses == [302] * 3 + [429] * 5, statuses
    assert enrolled == 3


def test_a_trial_hosted_by_another_process_answers_503_with_retry_after(database_url) -> None:
    """Nginx passes the last 503 on when every process said "hosted elsewhere" (the owner is
    dead, its lease not yet run out); a bot or script then asks again after Retry-After.

    The answer lost the header on its way through the JSON and HTML error handlers, so
    the HTTP bots gave up mid-trial on a kill -9 (KeyError 'trial' on the 503's JSON).
    """
    from hcss.platform.bots.participant import ManualClock
    from hcss.platform.live.trials import start_bot_trial
    from tests.support.leases import leased_process

    clock = ManualClock(1_000_000.0)
    owner = leased_process(database_url, "127.0.0.1:5001", clock)
    owner.extensions["hcss_db"].create_all()
    other = leased_process(database_url, "127.0.0.1:5002", clock)
    try:
        with owner.extensions["hcss_db"].session_scope() as session:
            participant, trial = start_bot_trial(session, seed=2, duration_s=600.0)
            token, trial_id = participant.token, trial.id
        assert owner.extensions["hcss_runner"].host(trial_id) is not None  # the owner claims it
        client = other.test_client()
        answer = client.get(f"/api/live/{token}/trials/{trial_id}/state")
        assert answer.status_code == 503 and answer.get_json()["held_by"] == "server"
        assert answer.headers.get("Retry-After") == "1", dict(answer.headers)
    finally:
        for app in (owner, other):
            app.extensions["hcss_db"].engine.dispose()


def test_a_host_killed_before_its_first_snapshot_still_leaves_an_honest_clock(database_url) -> None:
    """A claims a trial and dies before writing its first snapshot; B takes it over.

    The bots' kill -9 found this: the kill came right after a trial's lease was
    taken, and B rebuilt the trial from its scenario as if it were new: no
    interruption, and the trial clock ran on through the outage (a 60 s
    training at 30x was over before the participant saw it again).
    """
    from hcss.platform.bots.participant import ManualClock
    from hcss.platform.live.trials import start_bot_trial
    from tests.support.leases import LEASE_S, leased_process

    clock = ManualClock(time.time())  # the trial's start is the database's now
    a = leased_process(database_url, "127.0.0.1:5001", clock)
    a.extensions["hcss_db"].create_all()
    b = leased_process(database_url, "127.0.0.1:5002", clock)
    database = a.extensions["hcss_db"]
    try:
        with database.session_scope() as session:
            _, trial = start_bot_trial(session, seed=2, duration_s=600.0)
            trial_id = trial.id
        assert a.extensions["hcss_runner"].leases.claim(trial_id, clock.now)  # then A dies
        clock.now += LEASE_S + 2.0
        live = b.extensions["hcss_runner"].host(trial_id)
        assert live is not None
        with database.session_scope() as session:
            interruptions = session.scalars(select(Interruption)).all()
        assert [(i.trial_id, i.snapshot_step) for i in interruptions] == [(trial_id, -1)]
        assert interruptions[0].outage_s > LEASE_S
        assert (
            live.trial_clock.running_wall_s(clock.now) < 1.0
        )  # the clock stood still for the outage
    finally:
        for app in (a, b):
            app.extensions["hcss_db"].engine.dispose()


#: Trial seconds per wall second: the demo study's six live trials take 18 s of a bot's walk.
ACCELERATION = 30.0
BOTS = 4
#: The tables a walk writes to, compared by id before and after the kill.
WRITTEN = (
    Command,
    CommandOutcome,
    CommandKey,
    SimEvent,
    DecisionRow,
    RequestStatusChange,
    Observation,
    Probe,
    ProbeEvent,
    Snapshot,
    TrialStatusChange,
    StageEvent,
)


def _row_ids(database: Database) -> tuple[dict[str, set[int]], dict[int, tuple[int, int]]]:
    """Every written table's row ids, and each snapshot's (trial, step) from the same read
    as the snapshot ids."""
    with database.session_scope() as session:
        ids = {model.__tablename__: set(session.scalars(select(model.id))) for model in WRITTEN}
        snapshots = session.execute(select(Snapshot.id, Snapshot.trial_id, Snapshot.step)).all()
    ids[Snapshot.__tablename__] = {row.id for row in snapshots}
    return ids, {row.id: (row.trial_id, row.step) for row in snapshots}


def _live_trials(database: Database) -> dict[int, str]:
    """Trial id -> the process hosting it, for every trial that has not ended."""
    with database.session_scope() as session:
        ended = select(TrialStatusChange.trial_id).where(TrialStatusChange.status == "ended")
        rows = session.execute(
            select(TrialLease.trial_id, TrialLease.owner).where(TrialLease.trial_id.not_in(ended))
        )
        return {trial_id: owner for trial_id, owner in rows}


@pytest.mark.slow
def test_bots_walk_the_whole_study_through_a_kill_9_of_the_busiest_process(
    group_database_url: str, tmp_path
) -> None:
    """HTTP bots walk the demo study through nginx; the process hosting most live trials dies.

    The bots do what a browser does after a kill: ask again while nginx
    answers 503 (nobody hosts the trial until its lease runs out) or the
    connection drops, a command with its Idempotency-Key. Every bot must
    still reach the debrief, every row written before the kill must still be
    there, each command carried out once (one key per command row; a repeat
    answered from its key), and each trial that was live on the dead
    process must have its interruption recorded.
    """
    database_url = group_database_url
    upgrade_database(database_url)
    database = Database(database_url)
    env = {"HCSS_STUDY": "demo", "HCSS_TIME_ACCELERATION": str(ACCELERATION)}
    walked: list[LoadFigures] = []
    with _two_processes(database_url, tmp_path, env) as (servers, nginx):
        walk = threading.Thread(
            target=lambda: walked.append(
                run_http_bots(nginx.url, database_url, "demo", BOTS, concurrency=BOTS)
            )
        )
        walk.start()
        # Mid-run: the bots are in their live trials, at least two at once.
        deadline = time.monotonic() + 90
        while len(live := _live_trials(database)) < 2:
            assert walk.is_alive() and time.monotonic() < deadline, "no two live trials at once"
            time.sleep(0.05)
        # An owner is the process's address and its start ("host:port/<start>").
        hosted = Counter((owner or "").split("/")[0] for owner in live.values())
        victim = max(servers, key=lambda s: hosted[f"{s.host}:{s.port}"])
        victim.kill()
        # Read once it is dead: the trials it still hosted, and every row it had written.
        moved = sorted(
            t
            for t, owner in _live_trials(database).items()
            if (owner or "").startswith(f"{victim.host}:{victim.port}/")
        )
        before, snapshots_before = _row_ids(database)
        killed = time.monotonic()
        walk.join(timeout=240)
        walked_s = time.monotonic() - killed
        assert not walk.is_alive(), "the bots did not finish within 240 s of the kill"
    figures = walked[0]
    after, snapshots_after = _row_ids(database)
    with database.session_scope() as session:
        interrupted = {
            i.trial_id: i.outage_s
            for i in session.scalars(select(Interruption).where(Interruption.trial_id.in_(moved)))
        }
        command_ids = list(session.scalars(select(Command.id)))
        answers = session.scalars(select(CommandKey.response))
        keyed = Counter(a["command_id"] for a in answers if "command_id" in a)
        ended = Counter(
            session.scalars(
                select(TrialStatusChange.reason).where(TrialStatusChange.status == "ended")
            )
        )
    database.engine.dispose()
    print(
        f"kill -9 of the process hosting {len(moved)} of {len(live)} live trials; "
        f"bots done {walked_s:.1f} s later: {figures.summary()}; outages {interrupted}"
    )
    assert not figures.errors, (figures.errors, figures.statuses)
    assert len(figures.reports) == BOTS
    assert ended == {"time_limit": BOTS * 6}  # 3 models x (training, trial), each to its end
    # A snapshot is thinned by design once a newer one of its trial commits with the
    # deletion (hcss.platform.live.snapshots; the table's trigger allows nothing else): such
    # a snapshot was superseded, not lost. Every other row must still be there.
    superseded = {
        snapshot
        for snapshot, (trial, step) in snapshots_before.items()
        if any(t == trial and s > step for t, s in snapshots_after.values())
    }
    gone = {table: ids - after[table] for table, ids in before.items()}
    gone[Snapshot.__tablename__] -= superseded
    lost = {table: sorted(ids) for table, ids in gone.items() if ids}
    assert not lost, lost
    # Every command row was carried out for exactly one key (the bots send one with each),
    # so none was carried out again when its answer was lost in the kill.
    assert keyed == Counter(command_ids), (keyed, command_ids)
    assert moved, "the killed process hosted no trial that had not ended"
    assert set(interrupted) == set(moved) and all(s > 0 for s in interrupted.values()), (
        interrupted,
        moved,
    )
