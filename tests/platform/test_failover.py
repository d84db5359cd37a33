"""Two server processes behind nginx on one PostgreSQL database: kill -9 the trial's host.

The processes listen on different loopback addresses (127.0.0.2, 127.0.0.3),
as processes on two hosts would: nothing but the database and nginx joins them.

The real path: `hcss serve --cluster` processes, the nginx configuration
`hcss deploy nginx` writes, HTTP through nginx, SIGKILL. The trial must go
on in the other process within 10 s, with every row it had, and a command
the dead process carried out must not be carried out twice when the
participant's page repeats it there. Before the kill, the experimenter's
console on the other process pauses and resumes the trial through its host.
"""

from __future__ import annotations

import html
import http.cookiejar
import time
import urllib.error
import urllib.parse
import urllib.request
import uuid

import httpx
import pytest
from sqlalchemy import func, select

from hcss.platform.cli import upgrade_database
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.db import Database
from hcss.platform.live.client import TrialClient
from hcss.platform.live.placement import home
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import Interruption, TrialLease
from hcss.platform.serving.localserver import LocalNginx, LocalServer
from tests.support.leases import lease_owner, skip_unless_group, two_cluster_processes
from tests.support.replays import trial_records
from tests.support.trials import STUDY_TRIAL_S, csrf_token_of

ACCELERATION = 20.0
FAILOVER_LIMIT_S = 10.0


def _wait_for(condition, timeout_s: float, what: str):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            value = condition()
        except (httpx.HTTPError, urllib.error.URLError, ConnectionError, TimeoutError):
            value = None  # nobody hosts the trial yet (503), or the answer was cut
        if value:
            return value
        time.sleep(0.1)
    pytest.fail(f"timed out waiting for {what}")


class _Console:
    """An experimenter's browser on one process (the console has no token: any process serves it)."""

    def __init__(self, base_url: str) -> None:
        self.base_url = base_url
        self.opener = urllib.request.build_opener(
            urllib.request.HTTPCookieProcessor(http.cookiejar.CookieJar())
        )

    def page(self, path: str) -> tuple[str, str]:
        with self.opener.open(self.base_url + path, timeout=10) as response:
            html = response.read().decode()
        return html, csrf_token_of(html)

    def post(self, path: str, fields: dict[str, str]) -> str:
        body = urllib.parse.urlencode(fields).encode()
        with self.opener.open(self.base_url + path, data=body, timeout=10) as response:
            return response.read().decode()

    def act(self, code: str, action: str) -> str:
        _, csrf = self.page(f"/console/participants/{code}")
        return html.unescape(
            self.post(f"/console/participants/{code}/{action}", {"csrf_token": csrf})
        )


def _signed_in_console(database: Database, base_url: str) -> _Console:
    with database.session_scope() as session:
        create_experimenter(session, "alice", "correct horse battery")
    console = _Console(base_url)
    _, csrf = console.page("/console/login")
    console.post(
        "/console/login",
        {"csrf_token": csrf, "username": "alice", "password": "correct horse battery"},
    )
    return console


@pytest.fixture
def group_database_url(database_url: str) -> str:
    return skip_unless_group(database_url)


@pytest.mark.slow
def test_kill_9_of_the_host_moves_the_trial_to_the_other_process(
    group_database_url: str, tmp_path
) -> None:
    database_url = group_database_url
    upgrade_database(database_url)
    database = Database(database_url)
    # Two addresses, as two hosts would have: the processes know each other only by the database.
    servers = {
        name: LocalServer(
            database_url,
            tmp_path / name,
            snapshot_interval_s=1.0,
            serve_args=["--cluster"],
            host=address,
            extra_env={"HCSS_PROXY_HOPS": "1"},  # behind nginx, as deployed
        )
        for name, address in (("a", "127.0.0.2"), ("b", "127.0.0.3"))
    }
    nginx = LocalNginx([f"{s.host}:{s.port}" for s in servers.values()], tmp_path / "nginx")
    try:
        for server in servers.values():
            server.start(timeout_s=120)  # a first start compiles the simulation
        nginx.start()
        with database.session_scope() as session:
            participant, trial = start_bot_trial(
                session, seed=2, duration_s=STUDY_TRIAL_S, time_acceleration=ACCELERATION
            )
            token, trial_id, code = participant.token, trial.id, participant.code
        client = TrialClient(nginx.url, token)
        client.open_page()
        view = _wait_for(lambda: client.state()["view"]["targets"], 30, "a visible target")
        owner = lease_owner(database, trial_id)
        host = next(s for s in servers.values() if (owner or "").startswith(f"{s.host}:{s.port}/"))
        other = next(s for s in servers.values() if s is not host)

        key = str(uuid.uuid4())
        command = {"kind": "investigate", "collective": 0, "target": view[0]["id"]}
        first = client.post("/requests", command, key=key)
        assert first[0] == 200
        client.post("/observations", {"kind": "collective", "collective": 1, "button": "right"})
        _wait_for(lambda: client.state()["trial"]["step"] > 40, 30, "the trial to run on")

        # The experimenter's console, served by the other process, pauses and resumes it.
        console = _signed_in_console(database, other.url)
        for action, status in (("pause", "paused"), ("resume", "running")):
            issued = time.monotonic()
            assert f"{code}: {action} done" in console.act(code, action)
            _wait_for(lambda s=status: client.state()["trial"]["status"] == s, 2.0, action)
            print(f"console {action} on the other process: {time.monotonic() - issued:.2f} s")
        before = trial_records(database, trial_id)
        step_at_kill = client.state()["trial"]["step"]

        host.kill()
        killed = time.monotonic()
        _wait_for(
            lambda: client.state()["trial"]["step"] > step_at_kill, 20, "the trial on the other"
        )
        failover_s = time.monotonic() - killed
        assert (lease_owner(database, trial_id) or "").startswith(f"{other.host}:{other.port}/")
        assert failover_s < FAILOVER_LIMIT_S, failover_s

        # The page repeats the command whose answer it lost: the first answer, not a second command.
        assert client.post("/requests", command, key=key) == first
        after = trial_records(database, trial_id)
        assert after["commands"] == before["commands"]  # none lost, none invented
        for kind in ("outcomes", "probes", "probe_events", "decisions"):
            assert after[kind][: len(before[kind])] == before[kind], kind
        with database.session_scope() as session:
            interruption = session.scalars(
                select(Interruption).where(Interruption.trial_id == trial_id)
            ).one()
        assert interruption.outage_s > 0
        print(f"failover: {failover_s:.1f} s from kill -9 to the first step on the other process")
    finally:
        nginx.stop()
        for server in servers.values():
            server.stop()
        database.engine.dispose()


@pytest.mark.slow
def test_a_host_stopped_past_its_lease_writes_nothing_it_held_when_it_resumes(
    database_url: str, tmp_path
) -> None:
    """SIGSTOP of the trial's host for longer than a lease: the other process takes the trial
    over; a click that waited in the stopped host's socket is answered 503 when it resumes
    (the page retries it where the trial is now), and no row is written by the stopped
    host after the takeover: every observation, decision and event is stored once."""
    import os
    import signal
    import threading

    from hcss.platform.models import DecisionRow, Observation, SimEvent

    if not database_url.startswith("postgresql"):
        pytest.skip("several server processes share PostgreSQL; SQLite serves one process")
    upgrade_database(database_url)
    database = Database(database_url)
    servers = two_cluster_processes(database_url, tmp_path)
    try:
        for server in servers:
            server.start(timeout_s=120)
        with database.session_scope() as session:
            participant, trial = start_bot_trial(
                session, seed=2, duration_s=STUDY_TRIAL_S, time_acceleration=ACCELERATION
            )
            token, trial_id = participant.token, trial.id
        addresses = [f"{s.host}:{s.port}" for s in servers]
        if home(token, addresses, addresses) != addresses[0]:
            servers.reverse()  # A is the trial's home: the one nginx would send its page to
        client = TrialClient(servers[0].url, token)
        client.open_page()  # A's page: A claims the trial
        _wait_for(lambda: client.state()["trial"]["step"] > 20, 30, "the trial to run")
        host, other = servers
        assert (lease_owner(database, trial_id) or "").startswith(f"{host.host}:{host.port}/")
        assert host.process is not None
        client.http.timeout = httpx.Timeout(60.0)
        answers: list[tuple[int, dict]] = []

        def click() -> None:
            answers.append(
                client.post(
                    "/observations",
                    {"kind": "collective", "collective": 0, "button": "left"},
                    key=str(uuid.uuid4()),
                )
            )

        os.kill(host.process.pid, signal.SIGSTOP)
        stopped = time.monotonic()
        clicking = threading.Thread(target=click)
        try:
            clicking.start()
            elsewhere = TrialClient(other.url, token)
            elsewhere.open_page()  # the participant's page reaches the other process
            _wait_for(
                lambda: (
                    (lease_owner(database, trial_id) or "").startswith(
                        f"{other.host}:{other.port}/"
                    )
                    and elsewhere.state()["trial"]["step"] > 0
                ),
                20,
                "the other process to take the trial over",
            )
            takeover_s = time.monotonic() - stopped
            time.sleep(2.0)
        finally:
            os.kill(host.process.pid, signal.SIGCONT)
        clicking.join(timeout=60)
        (answer,) = answers
        assert answer[0] == 503, answer
        time.sleep(3.0)  # the resumed host's runner had its chance to write
        with database.session_scope() as session:
            observations = session.scalar(
                select(func.count())
                .select_from(Observation)
                .where(Observation.trial_id == trial_id)
            )
            decisions = session.execute(
                select(DecisionRow.collective, DecisionRow.decision_index).where(
                    DecisionRow.trial_id == trial_id
                )
            ).all()
            events = session.execute(
                select(SimEvent.kind, SimEvent.sim_time, SimEvent.text).where(
                    SimEvent.trial_id == trial_id
                )
            ).all()
        assert observations == 0
        assert len(decisions) == len(set(decisions))
        assert len(events) == len(set(events))
        print(f"SIGSTOP: the other process hosted the trial {takeover_s:.1f} s after the stop")
    finally:
        for server in servers:
            if server.process is not None:
                os.kill(server.process.pid, signal.SIGCONT)
            server.stop()
        database.engine.dispose()


@pytest.mark.slow
def test_a_host_cut_off_from_the_database_writes_nothing_after_the_takeover(
    database_url: str, tmp_path
) -> None:
    """A partition: the host's link to PostgreSQL goes silent (a relay that holds every
    byte) for longer than a lease, the server itself untouched. The other process takes
    the trial over; a click queued at the cut-off host, answered after the heal, is 503,
    and nothing the cut-off host held is written after the heal: no decision, event or
    request status stored twice."""
    import threading

    from sqlalchemy.engine import make_url

    from benchmarks.relay import CutProxy
    from hcss.platform.models import DecisionRow, Observation, RequestStatusChange, SimEvent

    if not database_url.startswith("postgresql"):
        pytest.skip("several server processes share PostgreSQL; SQLite serves one process")
    upgrade_database(database_url)
    database = Database(database_url)
    url = make_url(database_url)
    relay = CutProxy(url.host or "127.0.0.1", url.port or 5432)
    relayed = url.set(host="127.0.0.1", port=relay.port).render_as_string(hide_password=False)
    host, other = (
        LocalServer(
            db_url,
            tmp_path / name,
            snapshot_interval_s=1.0,
            serve_args=["--cluster"],
            host=address,
        )
        for name, address, db_url in (
            ("a", "127.0.0.2", relayed),
            ("b", "127.0.0.3", database_url),
        )
    )
    try:
        host.start(timeout_s=120)
        other.start(timeout_s=120)
        with database.session_scope() as session:
            participant, trial = start_bot_trial(
                session, seed=2, duration_s=STUDY_TRIAL_S, time_acceleration=ACCELERATION
            )
            token, trial_id = participant.token, trial.id
        client = TrialClient(host.url, token)
        client.open_page()  # the host claims the trial
        view = _wait_for(lambda: client.state()["view"]["targets"], 30, "a visible target")
        assert (
            client.post(
                "/requests", {"kind": "investigate", "collective": 0, "target": view[0]["id"]}
            )[0]
            == 200
        )
        _wait_for(lambda: client.state()["trial"]["step"] > 40, 30, "the trial to run on")
        client.http.timeout = httpx.Timeout(90.0)
        answers: list[tuple[int, dict]] = []

        def click() -> None:
            answers.append(
                client.post(
                    "/observations",
                    {"kind": "collective", "collective": 0, "button": "left"},
                    key=str(uuid.uuid4()),
                )
            )

        relay.stall()
        cut = time.monotonic()
        clicking = threading.Thread(target=click)
        clicking.start()
        elsewhere = TrialClient(other.url, token)
        elsewhere.open_page()
        _wait_for(
            lambda: (
                (lease_owner(database, trial_id) or "").startswith(f"{other.host}:{other.port}/")
                and elsewhere.state()["trial"]["step"] > 0
            ),
            20,
            "the other process to take the trial over",
        )
        takeover_s = time.monotonic() - cut
        time.sleep(max(0.0, 15.0 - takeover_s))  # the cut lasts 15 s in all
        relay.heal()
        clicking.join(timeout=60)
        (answer,) = answers
        time.sleep(3.0)  # the healed host had its chance to write what it held
        with database.session_scope() as session:

            def rows(*columns):
                query = select(*columns).where(columns[0].table.c.trial_id == trial_id)
                return [tuple(r) for r in session.execute(query)]

            decisions = rows(
                DecisionRow.trial_id, DecisionRow.collective, DecisionRow.decision_index
            )
            events = rows(SimEvent.trial_id, SimEvent.kind, SimEvent.sim_time, SimEvent.text)
            statuses = rows(
                RequestStatusChange.trial_id,
                RequestStatusChange.request_id,
                RequestStatusChange.status,
            )
            observations = session.scalar(
                select(func.count())
                .select_from(Observation)
                .where(Observation.trial_id == trial_id)
            )
        assert answer[0] == 503, answer
        assert observations == 0
        for stored in (decisions, events, statuses):
            assert len(stored) == len(set(stored)), stored
        print(f"partition: the other process hosted the trial {takeover_s:.1f} s after the cut")
    finally:
        relay.heal()
        for server in (host, other):
            server.stop()
        relay.close()
        database.engine.dispose()


LOADED_TRIALS = 60


@pytest.mark.slow
def test_a_survivor_takes_over_sixty_trials_without_losing_its_own_leases(
    database_url: str, tmp_path
) -> None:
    """60 trials on one process, a second started, kill -9 of the first: the survivor takes
    all 60 over (rebuilds in batches, renewals on their own thread) and never loses a lease
    it took: no "lost the lease", one interruption per trial, no rebuild_failed."""
    from hcss.platform.models import TrialStatusChange

    if not database_url.startswith("postgresql"):
        pytest.skip("several server processes share PostgreSQL; SQLite serves one process")
    upgrade_database(database_url)
    database = Database(database_url)
    first, survivor = (
        LocalServer(
            database_url,
            tmp_path / name,
            snapshot_interval_s=2.0,
            serve_args=["--cluster"],
            host=address,
        )
        for name, address in (("a", "127.0.0.2"), ("b", "127.0.0.3"))
    )
    try:
        first.start(timeout_s=120)
        tokens = []
        with database.session_scope() as session:
            for seed in range(LOADED_TRIALS):
                participant, _ = start_bot_trial(session, seed=seed, duration_s=STUDY_TRIAL_S)
                tokens.append(participant.token)
        for token in tokens:  # each participant's page reaches the first process
            page = TrialClient(first.url, token)
            page.open_page()
            page.state()  # its first look claims the trial
            page.close()
        survivor.start(timeout_s=120)

        def held_by(server: LocalServer) -> int:
            with database.session_scope() as session:
                return session.scalar(
                    select(func.count())
                    .select_from(TrialLease)
                    .where(TrialLease.owner.startswith(f"{server.host}:{server.port}/"))
                )

        assert held_by(first) == LOADED_TRIALS
        first.kill()
        killed = time.monotonic()
        _wait_for(lambda: held_by(survivor) == LOADED_TRIALS, 60, "the survivor to take all")
        all_taken_s = time.monotonic() - killed
        time.sleep(10.0)  # the survivor keeps them: renewals on time while it steps 60 trials
        assert held_by(survivor) == LOADED_TRIALS
        log = survivor.log_path.read_text()
        with database.session_scope() as session:
            interruptions = session.execute(
                select(Interruption.trial_id, Interruption.outage_s)
            ).all()
            failed = session.scalar(
                select(func.count())
                .select_from(TrialStatusChange)
                .where(TrialStatusChange.reason == "rebuild_failed")
            )
        assert "lost the lease" not in log
        assert failed == 0
        assert sorted(t for t, _ in interruptions) == sorted(set(t for t, _ in interruptions))
        assert len(interruptions) == LOADED_TRIALS
        longest = max(outage for _, outage in interruptions)
        print(
            f"loaded failover: {LOADED_TRIALS} trials on the survivor {all_taken_s:.1f} s "
            f"after kill -9; longest clock stop {longest:.1f} s; lost leases 0"
        )
    finally:
        for server in (first, survivor):
            server.stop()
        database.engine.dispose()
