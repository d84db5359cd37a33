"""The chaos soak's invariants (benchmarks/chaos.py), judged from the database after the run.

Each verdict is (held, what was counted), so a failing one says where to look:
- acknowledged: every keyed command the clients saw answered 200 is stored exactly once
  (its `command_key` row) with the status and JSON body the client saw;
- replay: every trial's log (commands from its start) replays to its newest snapshot (a
  live trial) or its end's snapshot (an ended one): equal state digests;
- once: no decision, simulation event, request status, probe or probe event twice;
- answers: no 5xx but a 503 with Retry-After, raw answers before any retry, the
  processes' own and nginx's 502/504 (a process killed mid-request) counted apart;
- participants: every bot participant reached the debrief or a stated outcome (its study
  ended as withdrawn, timed out, screened out); a bot that stopped with a participant
  still under way is a failure;
- counterbalancing: per study and pool, the cells' counts differ by at most one, and no
  participant is enrolled twice.
"""

from __future__ import annotations

from collections import Counter
from typing import TYPE_CHECKING, Any

from sqlalchemy import func, select

from benchmarks.failover import _doubled
from hcss.platform.db import Database
from hcss.platform.models import (
    CommandKey,
    Participant,
    Probe,
    ProbeEvent,
    StudyEnrolment,
    Trial,
)
from hcss.platform.models.participant_state import participant_state
from hcss.platform.replay.frames import ReplayRun, recording_of

if TYPE_CHECKING:
    from benchmarks.chaos import Answers, Participants

Verdict = tuple[bool, str]


def check(database: Database, answers: Answers, people: Participants) -> dict[str, Verdict]:
    return {
        "acknowledged commands stored once, as answered": _acknowledged(database, answers),
        "every trial's log replays to its snapshot": _replays(database),
        "no decision, event or probe twice": _once(database),
        "no 5xx but 503 with Retry-After": _answers(answers),
        "every participant at the debrief or a stated outcome": _participants(database, people),
        "counterbalancing exact": _counterbalancing(database),
    }


def _acknowledged(database: Database, answers: Answers) -> Verdict:
    keys = dict(answers.acknowledged)
    with database.session_scope() as session:
        rows: dict[str, list[CommandKey]] = {}
        for row in session.scalars(select(CommandKey).where(CommandKey.key.in_(list(keys)))):
            rows.setdefault(row.key, []).append(row)
    missing = [k for k in keys if k not in rows]
    twice = [k for k, found in rows.items() if len(found) > 1]
    differ = [
        k
        for k, found in rows.items()
        if len(found) == 1 and (found[0].status, found[0].response) != keys[k][1:]
    ]
    by_route = Counter(keys[k][0].rsplit("/", 1)[-1] for k in missing)
    held = not (missing or twice or differ)
    return held, (
        f"{len(keys)} acknowledged; {len(missing)} not stored {dict(by_route)}, "
        f"{len(twice)} stored twice, {len(differ)} stored with another answer"
    )


def _replays(database: Database) -> Verdict:
    compared = equal = unsnapshotted = 0
    unequal: list[int] = []
    with database.session_scope() as session:
        for trial in session.scalars(select(Trial).order_by(Trial.id)):
            recording = recording_of(session, trial)
            if recording.recorded_digest is None:
                unsnapshotted += 1
                continue
            run = ReplayRun(trial_id=trial.id)
            run.extend(session, trial, recording.last_command_id, recording.horizon)
            compared += 1
            if run.sim is not None and run.sim.state_digest() == recording.recorded_digest:
                equal += 1
            else:
                unequal.append(trial.id)
    detail = f"{equal} of {compared} trials equal ({unsnapshotted} without a snapshot to compare)"
    if unequal:
        detail += f"; unequal: {unequal[:10]}"
    return not unequal, detail


def _once(database: Database) -> Verdict:
    with database.session_scope() as session:
        trial_ids = list(session.scalars(select(Trial.id)))
        probes = session.execute(select(Probe.trial_id, Probe.probe_index)).all()
        events = session.execute(select(ProbeEvent.probe_id, ProbeEvent.kind)).all()
    doubled = _doubled(database, trial_ids) if trial_ids else 0
    probes_twice = len(probes) - len(set(map(tuple, probes)))
    events_twice = len(events) - len(set(map(tuple, events)))
    held = doubled == probes_twice == events_twice == 0
    return held, (
        f"{len(trial_ids)} trials: decisions/events/request statuses twice {doubled}, "
        f"probes twice {probes_twice}, probe events twice {events_twice}"
    )


def _answers(answers: Answers) -> Verdict:
    total = sum(answers.statuses.values())
    served = answers.statuses.get("503", 0)
    detail = (
        f"{total} answers, {served} x 503 with Retry-After; other 5xx from the processes: "
        f"{len(answers.bad)}, from nginx (502/504, a process lost mid-request): "
        f"{len(answers.gateway)}"
    )
    for kind in (answers.bad, answers.gateway):
        if kind:
            detail += f" {[k.split('/')[0] + '/' + k.rsplit('/', 1)[-1] for k in kind[:6]]}"
    return not (answers.bad or answers.gateway), detail


def _participants(database: Database, people: Participants) -> Verdict:
    outcomes = dict(people.outcomes)
    with database.session_scope() as session:
        states: Counter[str] = Counter()
        stuck: list[str] = []
        for participant in session.scalars(
            select(Participant).where(Participant.code.in_(list(outcomes)))
        ):
            state = participant_state(session, participant.id)
            states[state] += 1
            if outcomes[participant.code] != "completed":
                stuck.append(f"{participant.code} ({state}): {outcomes[participant.code]}")
    completed = sum(o == "completed" for o in outcomes.values())
    detail = f"{len(outcomes)} bots, {completed} completed; states {dict(states)}"
    if stuck:
        detail += f"; stopped: {stuck[:5]}"
    return not stuck and len(outcomes) > 0, detail


def _counterbalancing(database: Database) -> Verdict:
    with database.session_scope() as session:
        rows = session.execute(
            select(StudyEnrolment.study, StudyEnrolment.pool, StudyEnrolment.cell)
        ).all()
        twice = int(
            session.scalar(
                select(func.count()).select_from(
                    select(StudyEnrolment.participant_id)
                    .group_by(StudyEnrolment.participant_id)
                    .having(func.count() > 1)
                    .subquery()
                )
            )
            or 0
        )
    per_group: dict[tuple[Any, Any], Counter[Any]] = {}
    for study, pool, cell in rows:
        per_group.setdefault((study, pool), Counter())[cell] += 1
    spreads = {
        f"{study}/{pool}": (min(cells.values()), max(cells.values()), len(cells))
        for (study, pool), cells in per_group.items()
    }
    uneven = {g: s for g, s in spreads.items() if s[1] - s[0] > 1}
    detail = (
        f"{len(rows)} enrolments; (fewest, most, cells) per study/pool {spreads}; twice {twice}"
    )
    return not uneven and twice == 0, detail
