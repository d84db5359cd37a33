"""A restarted process gets its participants' trials back, so their requests stop taking a detour.

Two `hcss serve --cluster` processes behind the nginx configuration `hcss
deploy nginx` writes, on PostgreSQL. nginx hashes each participant's token to
one process. After a kill -9 the survivor takes the dead process's trials
over; once that process is back on its address, nginx sends those
participants to it again, and while the survivor still holds their trials
every request is answered 503 there and passed on: a detour per request,
seen in nginx's access log as an upstream status "503, 200". The restarted
process asks for each such trial, and the survivor hands it back at a safe
point: within a bound, each participant hashed to the restarted process is
hosted by it again and no request of theirs passes through a 503; no
acknowledged command is lost or stored twice, no rebuild fails, and every
trial's command log replays to its newest snapshot.

The rules that keep a trial from moving to and fro are checked in-process
first (apps on one database standing for processes, on a shared manual clock,
as in test_leases.py): only a participant's request asks, the first asker
keeps the ask, a trial moves at most once per lease, and never while a
participant's command for it is under way.
"""

from __future__ import annotations

import time
import uuid
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field

import httpx
import pytest
from sqlalchemy import func, select

from hcss.platform.bots.participant import ManualClock
from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.client import TrialClient
from hcss.platform.live.leases import HostedElsewhere
from hcss.platform.live.runner import Runner
from hcss.platform.live.trial_log import newest_snapshot
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import Interruption, Observation, TrialLease, TrialStatusChange
from hcss.platform.serving.localserver import LocalNginx
from hcss.simulation import Simulation
from tests.support.leases import (
    LEASE_S,
    lease_owner,
    leased_process,
    skip_unless_group,
    start_trial_on,
    two_cluster_processes,
)
from tests.support.replays import replay_trial
from tests.support.trials import STUDY_TRIAL_S

NAMES = ("127.0.0.1:5001/a", "127.0.0.1:5002/b", "127.0.0.1:5003/c")


@pytest.fixture
def group(database_url: str) -> Iterator[tuple[list[Runner], ManualClock]]:
    """Three processes of a group on one database and one manual clock (no runner threads)."""
    clock = ManualClock(1_000_000.0)
    apps = [leased_process(database_url, name, clock) for name in NAMES]
    apps[0].extensions["hcss_db"].create_all()
    yield [app.extensions["hcss_runner"] for app in apps], clock
    for app in apps:
        app.extensions["hcss_db"].engine.dispose()


def _asks(runner: Runner, trial_id: int) -> None:
    """A participant's request reaching `runner` while another process hosts the trial."""
    with pytest.raises(HostedElsewhere):
        runner.host(trial_id, participant=True)


def _lease(runner: Runner, trial_id: int) -> tuple[str, str | None]:
    with runner.database.session_scope() as session:
        row = session.get(TrialLease, trial_id)
        assert row is not None
        return row.owner, row.wanted_by


def _run(runners: list[Runner], clock: ManualClock, seconds: float) -> None:
    """The processes tick on, one second of the shared clock at a time."""
    for _ in range(int(seconds)):
        clock.now += 1.0
        for runner in runners:
            runner.tick()


def test_the_holder_hands_a_trial_back_to_the_process_its_participant_asks_through(
    group,
) -> None:
    (a, b, _), clock = group
    trial_id = start_trial_on(a)
    held = a.host(trial_id)  # A took the trial (B was down)
    assert held is not None
    _run([a], clock, 3)
    with pytest.raises(HostedElsewhere):
        b.host(trial_id)  # the console or a runner's look: no ask
    assert _lease(a, trial_id) == (NAMES[0], None)
    _asks(b, trial_id)  # the participant's request, hashed to B
    assert _lease(a, trial_id) == (NAMES[0], NAMES[1])
    _run([a], clock, 2)
    assert trial_id in a.loaded_ids()  # held for less than a lease: not yet
    _run([a], clock, 3)
    assert trial_id not in a.loaded_ids() and held.moved  # handed back at a renewal
    assert _lease(a, trial_id) == (NAMES[1], None)
    with pytest.raises(HostedElsewhere):
        a.host(trial_id)  # A writes nothing for it any more
    rebuilt = b.host(trial_id, participant=True)  # the participant's next request, at B
    assert rebuilt is not None
    assert rebuilt.sim.step_count >= held.sim.step_count  # from the hand-back's snapshot
    with b.database.session_scope() as session:
        outages = session.scalars(select(Interruption.outage_s)).all()
    assert len(outages) == 1 and outages[0] <= 1.0  # stood still from the hand-back to the claim

    _asks(a, trial_id)  # a request reaching A (not nginx's choice for it): no move back
    _run([a, b], clock, LEASE_S - 1)
    assert trial_id in b.loaded_ids() and _lease(b, trial_id)[0] == NAMES[1]


def test_the_first_process_to_ask_keeps_the_ask(group) -> None:
    (a, b, c), clock = group
    trial_id = start_trial_on(a)
    assert a.host(trial_id) is not None
    _run([a], clock, 4)
    _asks(b, trial_id)  # nginx's first choice for the participant asks first
    _asks(c, trial_id)  # the next one on the ring, after B's 503: it does not displace B
    assert _lease(a, trial_id)[1] == NAMES[1]
    _run([a], clock, 4)
    assert _lease(a, trial_id) == (NAMES[1], None)


def test_no_hand_back_while_a_participants_command_is_under_way(group) -> None:
    (a, b, _), clock = group
    trial_id = start_trial_on(a)
    assert a.host(trial_id) is not None
    _run([a], clock, 5)
    _asks(b, trial_id)
    with a.commanding(trial_id):
        _run([a], clock, 3)
        assert trial_id in a.loaded_ids()
        assert _lease(a, trial_id) == (NAMES[0], NAMES[1])
    a.tick()  # the command answered: the next tick hands it over
    assert trial_id not in a.loaded_ids()
    assert _lease(a, trial_id)[0] == NAMES[1]


#: Seconds from the restarted process answering to every one of its participants' trials
#: hosted by it again (a renewal period to hear the ask, a tick, the participant's next request).
HAND_BACK_LIMIT_S = 10.0
#: Seconds the participants are driven after the hand-back, counting detours.
QUIET_S = 6.0


@dataclass
class _Participant:
    """One participant's page through nginx: looks at the trial and clicks now and then."""

    client: TrialClient
    trial_id: int
    home: str = ""  # the process ("host:port") nginx's hash sends the participant to
    acknowledged: list[str] = field(default_factory=list)  # keys of clicks answered 201
    rounds: int = 0

    def drive(self) -> None:
        """One look, and every third round a keyed click, repeated until it is answered
        (the page's retry of a 502/503/504: same key, carried out once)."""
        self.rounds += 1
        try:
            self.client.state()
        except httpx.HTTPError:
            return  # nobody hosts the trial this instant (a takeover): the page looks again
        if self.rounds % 3:
            return
        key = str(uuid.uuid4())
        click = {"kind": "collective", "collective": self.rounds % 4, "button": "right"}
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            try:
                status, _ = self.client.post("/observations", click, key=key)
            except (httpx.HTTPError, ValueError):
                status = 0
            if status == 201:
                self.acknowledged.append(key)
                return
            time.sleep(0.2)
        pytest.fail(f"a click on trial {self.trial_id} was never answered")


def _first_look(client: TrialClient) -> None:
    """The participant's first look, which claims the trial on the process it reached (a
    first rebuild on a cold process may outlast the client's timeout: the page looks again)."""
    deadline = time.monotonic() + 60
    while True:
        try:
            client.state()
            return
        except httpx.HTTPError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)


def _detours(log_lines: list[str], since: float, tokens: set[str]) -> tuple[int, int]:
    """(requests, requests answered 503 by a process before another answered) among the
    participants' requests nginx logged after `since` (epoch seconds)."""
    requests = detoured = 0
    for line in log_lines:
        when, uri, _status, _addresses, upstreams = line.split(" ", 4)
        if float(when) < since or uri.split("/")[3 if uri.startswith("/api/") else 2] not in tokens:
            continue
        requests += 1
        detoured += "503" in upstreams
    return requests, detoured


@pytest.mark.slow
def test_a_restarted_process_gets_its_participants_trials_back_and_the_detour_ends(
    database_url: str, tmp_path
) -> None:
    database_url = skip_unless_group(database_url)
    upgrade_database(database_url)
    database = Database(database_url)
    servers = two_cluster_processes(database_url, tmp_path, extra_env={"HCSS_PROXY_HOPS": "1"})
    addresses = [f"{s.host}:{s.port}" for s in servers]
    nginx = LocalNginx(addresses, tmp_path / "nginx", access_log=True)
    participants: list[_Participant] = []
    try:
        for server in servers:
            server.start(timeout_s=120)
        nginx.start()
        # Participants until each process hosts at least two (the hash decides which).
        while len(participants) < 24:
            with database.session_scope() as session:
                person, trial = start_bot_trial(
                    session, seed=len(participants), duration_s=STUDY_TRIAL_S
                )
                token, trial_id = person.token, trial.id
            page = _Participant(TrialClient(nginx.url, token), trial_id)
            page.client.open_page()
            _first_look(page.client)
            page.home = (lease_owner(database, trial_id) or "").split("/")[0]
            participants.append(page)
            homes = Counter(p.home for p in participants)
            if len(participants) >= 8 and all(homes[a] >= 2 for a in addresses):
                break
        assert all(homes[a] >= 2 for a in addresses), homes
        victim, survivor = servers
        victim_address = f"{victim.host}:{victim.port}"
        theirs = [p for p in participants if p.home == victim_address]
        for _ in range(3):
            for page in participants:
                page.drive()

        victim.kill()
        killed = time.monotonic()
        survivor_address = f"{survivor.host}:{survivor.port}"
        while not all(
            (lease_owner(database, p.trial_id) or "").startswith(survivor_address + "/")
            for p in theirs
        ):
            assert time.monotonic() - killed < 30, "the survivor never took the trials over"
            for page in participants:
                page.drive()
        print(f"takeover: {time.monotonic() - killed:.1f} s after kill -9")

        victim.start(timeout_s=120)  # on the same address: nginx's hash sends them there again
        restarted, restarted_epoch = time.monotonic(), time.time()
        handed_back_s: dict[int, float] = {}
        while len(handed_back_s) < len(theirs):
            elapsed = time.monotonic() - restarted
            assert elapsed < HAND_BACK_LIMIT_S, (
                f"after {elapsed:.1f} s, {len(theirs) - len(handed_back_s)} of {len(theirs)} "
                "trials hashed to the restarted process are still hosted by the survivor"
            )
            for page in participants:
                page.drive()
                owner = lease_owner(database, page.trial_id) or ""
                back = owner.startswith(victim_address + "/")
                if back and page in theirs and page.trial_id not in handed_back_s:
                    handed_back_s[page.trial_id] = time.monotonic() - restarted
        handed = time.time()
        time.sleep(1.0)  # requests begun before the last hand-back are logged by now

        quiet_from = time.time()
        quiet_until = time.monotonic() + QUIET_S
        while time.monotonic() < quiet_until:
            for page in participants:
                page.drive()
        time.sleep(0.5)
        lines = nginx.access_log_path.read_text().splitlines()
        tokens = {p.client.token for p in theirs}
        before = _detours(
            [line for line in lines if float(line.split()[0]) < handed], restarted_epoch, tokens
        )
        after = _detours(lines, quiet_from, {p.client.token for p in participants})

        assert after[0] > 0
        assert after[1] == 0, f"{after[1]} of {after[0]} requests still took a detour"
        for page in theirs:  # hosted by the restarted process and staying there
            assert (lease_owner(database, page.trial_id) or "").startswith(victim_address + "/")
        with database.session_scope() as session:
            failed = session.scalar(
                select(func.count())
                .select_from(TrialStatusChange)
                .where(TrialStatusChange.reason == "rebuild_failed")
            )
            assert failed == 0
            for page in participants:
                stored = Counter(
                    session.scalars(
                        select(Observation.id).where(Observation.trial_id == page.trial_id)
                    )
                )
                assert len(stored) == len(page.acknowledged), page.trial_id  # none lost or doubled
                snapshot = newest_snapshot(session, page.trial_id)
                assert snapshot is not None
                replayed = replay_trial(session, page.trial_id, snapshot.step)
                assert replayed.state_digest() == Simulation.restore(snapshot.blob).state_digest()
        assert "lost the lease" not in survivor.log_path.read_text()
        times = sorted(handed_back_s.values())
        print(
            f"hand-back: {len(theirs)} trials back on the restarted process "
            f"{times[0]:.1f}-{times[-1]:.1f} s after it answered (median "
            f"{times[len(times) // 2]:.1f} s); before: {before[1]} of {before[0]} of their "
            f"requests took a detour; after: {after[1]} of {after[0]}"
        )
    finally:
        for page in participants:
            page.client.close()
        nginx.stop()
        for server in servers:
            server.stop()
        database.engine.dispose()
