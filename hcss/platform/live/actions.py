"""What the participant does in a trial: requests, clicks and probe answers, applied and written.

The live service's door (hcss.platform.live.door) finds the trial, takes its
lock and checks that the command may apply now (the trial runs, the probe is
open); these functions are its apply-and-write step. Each says what happened
as a typed fact (`live.facts`: `CommandApplied`, `ObservationMade`,
`ProbeReadyPressed`, `ProbeAnswered`), which the trial log's writer turns
into rows in one fenced unit of work (`trial_writer.write_fact`), with the
command's idempotency key and its answer when one was sent: the command and
its key are committed together or not at all, so a retry after a crash or a
failed write can never carry the command out twice.

A request (an `OperatorCommand`, checked by `validation.parse_request`) is
applied to the simulation before it is written: everything the rows say
(support, decision index, intervention) is the simulation's `RequestOutcome`.
The rest moves the trial in memory only once its rows are committed.

A commit that fails may have landed, its answer lost (a dropped line, a
failover): the database is asked whether the command's row is stored
(`trial_writer.stored`), not guessed at. Stored: the trial in memory moves
on as the log says (a request stays applied; a probe's press or answer is
taken) and the command's answer is given. Not stored: nothing moved (a
request's simulation is put back). Nobody can say (the database is still
away): the trial in memory is not trusted any longer; it is marked moved,
the runner drops it, and the next request rebuilds it from what the database
holds.
"""

from __future__ import annotations

import logging
from typing import Any

from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live import trial_writer
from hcss.platform.live.facts import (
    CommandApplied,
    Fact,
    ObservationMade,
    ProbeAnswered,
    ProbeReadyPressed,
)
from hcss.platform.live.leases import trial_transaction
from hcss.platform.live.progress import CurrentProbe
from hcss.platform.live.recorder import kept_until_written, record_request_statuses
from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.live.trial_log import command_message
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.simulation import OperatorCommand

log = logging.getLogger(__name__)


class ActionError(Exception):
    """A participant action that cannot be taken; becomes a 4xx JSON answer."""

    def __init__(self, message: str, status: int = 400, code: str = "invalid") -> None:
        super().__init__(message)
        self.message = message
        self.status = status
        self.code = code


def submit_request(
    database: Database,
    live: RunningTrial,
    command: OperatorCommand,
    selections: tuple[int, ...] = (),
    *,
    key: KeyedCommand,
) -> dict[str, Any]:
    """Apply `command` and log it with its outcome; the answer the participant's page gets."""
    with live.lock:
        sim = live.sim
        before = sim.snapshot()
        step, sim_time = sim.step_count, float(sim.time)
        applied = CommandApplied(command, sim.apply(command), step, sim_time, selections)
        row_id: int | None = None
        committing = False
        try:
            with (
                kept_until_written(live, simulation_restored=True),
                trial_transaction(database, live) as session,
            ):
                row_id = trial_writer.write_fact(session, live.trial_id, applied)
                record_request_statuses(live, session)
                answer = _answered(session, key, _request_answer(row_id, applied))
                committing = True  # what fails from here on is the commit: it may have landed
        except DBAPIError:
            if not committing or not was_stored(database, live, applied, row_id):
                live.roll_back_to(before)
                raise
            answer = _request_answer(row_id, applied)  # the command is in the log: it stays
        except BaseException:
            live.roll_back_to(before)
            raise
        assert row_id is not None  # stored
        live.command_applied(row_id)
        outcome = applied.outcome
        kind, text = command_message(
            applied,
            outcome.accepted,
            outcome.request_id,
            outcome.reason,
            sim.scenario.n_collectives,
        )
        live.add_message(sim_time, kind, text)
        live.touch()
        return answer


def record_observation(
    database: Database,
    live: RunningTrial,
    *,
    kind: str,
    collective: int | None,
    target: int | None,
    button: str,
    key: KeyedCommand,
) -> dict[str, Any]:
    """A click on the map; the answer is the observation's id (201 Created)."""
    with live.lock:
        made = ObservationMade(kind, collective, target, button, **_when(live))
        row_id = _written(database, live, made, key, lambda i: {"observation_id": i}, status=201)
        return {"observation_id": row_id}


def probe_ready(
    database: Database,
    live: RunningTrial,
    probe: CurrentProbe,
    now: float | None = None,
    *,
    key: KeyedCommand,
) -> dict[str, Any]:
    """The Ready press on the open `probe`; `now` (the runner's wall clock) times it from the
    prompt's delivery."""
    with live.lock:
        running_s = None if now is None else live.running_wall_s(now)
        pressed = ProbeReadyPressed(
            probe.id, _latency_ms(probe.delivered_s, running_s), **_when(live)
        )
        _written(database, live, pressed, key, lambda _i: {"ok": True})
        probe.ready_pressed(running_s)
        live.touch()
        return {"ok": True}


def probe_answer(
    database: Database,
    live: RunningTrial,
    probe: CurrentProbe,
    answer: str,
    now: float | None = None,
    *,
    key: KeyedCommand,
) -> dict[str, Any]:
    """The answer to the open `probe`; timed from the question's delivery (or the Ready press,
    if never sent)."""
    with live.lock:
        running_s = None if now is None else live.running_wall_s(now)
        asked_s = (
            probe.question_delivered_s if probe.question_delivered_s is not None else probe.ready_s
        )
        answered = ProbeAnswered(
            probe.id, answer, probe.truth, _latency_ms(asked_s, running_s), **_when(live)
        )
        _written(database, live, answered, key, lambda _i: {"ok": True})
        live.probe_answered(answer)
        live.touch()
        return {"ok": True}


def _written(
    database: Database,
    live: RunningTrial,
    fact: Fact,
    key: KeyedCommand,
    answer_of: Any,
    status: int = 200,
) -> int | None:
    """Write `fact` (and `key` with the answer `answer_of(row id)`) in one fenced unit of work;
    the row's id. A failed commit is settled by asking the database (`was_stored`): raised
    again unless the row is stored. A failure before the commit was sent (the database away
    at the first statement) wrote nothing, and nothing is asked."""
    row_id: int | None = None
    committing = False
    try:
        with trial_transaction(database, live) as session:
            row_id = trial_writer.write_fact(session, live.trial_id, fact)
            _answered(session, key, answer_of(row_id), status)
            committing = True  # what fails from here on is the commit: it may have landed
    except DBAPIError:
        if not committing or not was_stored(database, live, fact, row_id):
            raise
    return row_id


def was_stored(database: Database, live: RunningTrial, fact: Fact, row_id: int | None) -> bool:
    """Whether the row of `fact`, whose transaction's commit failed, is in the database: asked,
    not guessed. When the database cannot say (it is still away), the trial in memory is not
    trusted any longer: it is marked moved (the runner drops it, the next request rebuilds it
    from the log) and the answer is False, so the caller raises (503, and the page retries)."""
    try:
        with database.session_scope() as session:
            found = trial_writer.stored(session, fact, row_id)
    except DBAPIError:
        log.warning("trial %s: cannot tell whether %s was stored", live.trial_id, fact)
        live.move_away()
        return False
    if found:
        log.warning("trial %s: %s committed, its answer lost", live.trial_id, type(fact).__name__)
    return found


def _request_answer(row_id: int | None, applied: CommandApplied) -> dict[str, Any]:
    outcome = applied.outcome
    return {
        "command_id": row_id,
        "accepted": outcome.accepted,
        "request_id": outcome.request_id if outcome.accepted else None,
        "reason": outcome.reason,
        "step": applied.step,
    }


def _answered(
    session: Session, key: KeyedCommand, answer: dict[str, Any], status: int = 200
) -> dict[str, Any]:
    """`answer`, stored with the command's idempotency key in the command's transaction."""
    trial_writer.write_command_key(session, key, status, answer)
    return answer


def _when(live: RunningTrial) -> dict[str, Any]:
    """The step and trial time an action lands at (between two steps)."""
    return {"step": live.sim.step_count, "sim_time": float(live.sim.time)}


def _latency_ms(since_s: float | None, now_s: float | None) -> float | None:
    if since_s is None or now_s is None:
        return None
    return round(max(0.0, now_s - since_s) * 1000.0, 1)
