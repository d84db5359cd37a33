"""Trials never move while their holder is alive; a restarted process gets its trials back once.

Placement (hcss.platform.live.placement): every process computes, from the
participant's token and the group's live members, the member nginx sends the
participant to (the trial's home). Checked in-process first (apps on one
database standing for processes, on a shared manual clock, as in
test_leases.py): a never-opened trial is claimed by its home and no other; a
request for a trial reaching a process that does not hold it never moves it
(the request is forwarded to the holder); a trial taken over while its home
was down goes home once when the home restarts, and stays there.

Then with two `hcss serve --cluster` processes behind the nginx configuration
`hcss deploy nginx` writes, on PostgreSQL. After a kill -9 the survivor takes
the dead process's trials over; once that process is back on its address,
nginx sends those participants to it again, and the survivor's requests are
forwarded to the survivor meanwhile; the survivor hands each trial back once at
a safe point: within a bound, each participant hashed to the restarted
process is hosted by it again, no trial moves again, no acknowledged command
is lost or stored twice, no rebuild fails, and every trial's command log
replays to its newest snapshot.
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
from hcss.platform.live.placement import address_of, home
from hcss.platform.live.runner import Runner
from hcss.platform.live.trial_log import newest_snapshot
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import (
    Interruption,
    Observation,
    Participant,
    Trial,
    TrialLease,
    TrialStatusChange,
)
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
ADDRESSES = tuple(address_of(name) for name in NAMES)


@pytest.fixture
def group(database_url: str) -> Iterator[tuple[list[Runner], ManualClock]]:
    """Three processes of a group on one database and one manual clock (no runner threads),
    each told the group's members as nginx lists them."""
    clock = ManualClock(1_000_000.0)
    apps = [leased_process(database_url, name, clock, ADDRESSES) for name in NAMES]
    apps[0].extensions["hcss_db"].create_all()
    yield [app.extensions["hcss_runner"] for app in apps], clock
    for app in apps:
        app.extensions["hcss_db"].engine.dispose()


def _lease(runner: Runner, trial_id: int) -> tuple[str, int]:
    with runner.database.session_scope() as session:
        row = session.get(TrialLease, trial_id)
        assert row is not None
        return row.owner, row.epoch


def _interruptions(runner: Runner) -> list[float]:
    with runner.database.session_scope() as session:
        return list(session.scalars(select(Interruption.outage_s)))


def _run(runners: list[Runner], clock: ManualClock, seconds: float) -> None:
    """The processes tick on, one second of the shared clock at a time."""
    for _ in range(int(seconds)):
        clock.now += 1.0
        for runner in runners:
            runner.tick()


def _home(runner: Runner, trial_id: int, live: tuple[str, ...] = ADDRESSES) -> str:
    """The member nginx sends the trial's participant to while the `live` ones are up."""
    with runner.database.session_scope() as session:
        trial = session.get(Trial, trial_id)
        assert trial is not None
        token = session.scalars(
            select(Participant.token).where(Participant.id == trial.participant_id)
        ).one()
    there = home(token, ADDRESSES, live)
    assert there is not None
    return there


def _trial_at_home(runner: Runner, address: str, live: tuple[str, ...] = ADDRESSES) -> int:
    """A new trial whose home (among `live`) is `address`."""
    for _ in range(60):
        trial_id = start_trial_on(runner)
        if _home(runner, trial_id, live) == address:
            return trial_id
    raise AssertionError(f"no trial's home was {address} in 60 tries")


def test_a_never_opened_trial_is_claimed_by_its_home_and_no_other(group) -> None:
    runners, clock = group
    _run(runners, clock, 1)  # every member says it is alive
    trials = [start_trial_on(runners[0]) for _ in range(12)]
    _run(runners, clock, 2)  # a sync each: well inside the 30 s left to a first request before
    homes = Counter()
    for trial_id in trials:
        owner, epoch = _lease(runners[0], trial_id)
        assert address_of(owner) == _home(runners[0], trial_id)
        assert epoch == 1  # claimed once, by its home
        holders = [r for r in runners if trial_id in r.loaded_ids()]
        assert [r.leases.owner for r in holders if r.leases] == [owner]
        homes[address_of(owner)] += 1
    assert len(homes) >= 2, homes  # the trials spread over the members
    assert _interruptions(runners[0]) == []


def test_a_request_reaching_a_process_that_does_not_hold_the_trial_never_moves_it(
    group,
) -> None:
    (a, b, c), clock = group
    _run([a, b, c], clock, 1)
    trial_id = _trial_at_home(a, ADDRESSES[0])
    assert a.host(trial_id, participant=True) is not None  # its participant's first request
    _run([a, b, c], clock, 1)
    held = _lease(a, trial_id)
    assert held[0] == NAMES[0] and trial_id in a.loaded_ids()
    for _ in range(3 * int(LEASE_S)):  # requests passed on to b and c (a busy 503, a timeout)
        for other in (b, c):
            with pytest.raises(HostedElsewhere) as elsewhere:
                other.host(trial_id, participant=True)
            assert elsewhere.value.owner == NAMES[0]  # forwarded there, not asked for
        _run([a, b, c], clock, 1)
    assert _lease(a, trial_id) == held  # 0 lease changes
    assert trial_id in a.loaded_ids()
    assert trial_id not in b.loaded_ids() | c.loaded_ids()
    assert _interruptions(a) == []  # 0 interruptions


def test_a_trial_goes_home_once_after_its_home_restarts_and_never_while_both_live(
    group, database_url: str
) -> None:
    (a, b, c), clock = group
    _run([a, c], clock, 1)  # b is down
    trial_id = _trial_at_home(a, ADDRESSES[1])  # b's participant
    taker_address = _home(a, trial_id, (ADDRESSES[0], ADDRESSES[2]))
    taker = a if taker_address == ADDRESSES[0] else c
    assert taker.host(trial_id, participant=True) is not None  # nginx's next member for it
    _run([a, c], clock, 1)
    assert trial_id in taker.loaded_ids() and address_of(_lease(a, trial_id)[0]) == taker_address
    _run([a, b, c], clock, int(LEASE_S) + 2)  # b back: started after the takeover
    assert trial_id in b.loaded_ids() and trial_id not in taker.loaded_ids()
    owner, epoch = _lease(a, trial_id)
    assert owner == NAMES[1]
    outages = _interruptions(a)
    assert len(outages) == 1 and outages[0] <= 1.0  # stood still from the hand-back to the claim
    _run([a, b, c], clock, 3 * int(LEASE_S))
    assert _lease(a, trial_id) == (owner, epoch)  # once: nothing moves while both are alive

    # A trial claimed elsewhere while its home was alive (here: by the console's hand):
    # its home did not restart since, so it stays where it is.
    kept = _trial_at_home(a, ADDRESSES[2])
    assert a.leases is not None and a.leases.claim(kept, clock()) is not None
    assert a.host(kept) is not None
    _run([a, b, c], clock, 3 * int(LEASE_S))
    assert kept in a.loaded_ids() and address_of(_lease(a, kept)[0]) == ADDRESSES[0]

    # c restarts (a new process on its address): the trial goes home to it, once.
    c2 = leased_process(database_url, "127.0.0.1:5003/c2", clock, ADDRESSES).extensions[
        "hcss_runner"
    ]
    try:
        _run([a, b, c2], clock, int(LEASE_S) + 2)
        assert kept in c2.loaded_ids() and kept not in a.loaded_ids()
        moved = _lease(a, kept)
        _run([a, b, c2], clock, 3 * int(LEASE_S))
        assert _lease(a, kept) == moved
    finally:
        c2.database.engine.dispose()


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


def _lease_row(database: Database, trial_id: int) -> tuple[str, int] | None:
    with database.session_scope() as session:
        row = session.get(TrialLease, trial_id)
        return None if row is None else (row.owner, row.epoch)


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
        settled = {p.trial_id: _lease_row(database, p.trial_id) for p in participants}

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
        # Handed back once: no lease changed hands (or epoch) after the hand-backs.
        assert {p.trial_id: _lease_row(database, p.trial_id) for p in participants} == settled
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
