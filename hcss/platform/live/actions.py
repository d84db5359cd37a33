"""What the participant does in a trial: requests, clicks and probe answers.

Each action takes the trial's lock, so it lands between two steps. A request
(an `OperatorCommand`, checked by `validation.parse_request`) is applied to
the simulation, and the command, its outcome and the request statuses it
caused are written in one transaction: everything the rows say (support,
decision index, intervention) is the simulation's `RequestOutcome`. Should
that transaction fail, the simulation is put back as it was before the
command, so the log (what a rebuild replays) and the trial in memory never
disagree.

An action sent with an idempotency key gets the key as a value
(`trial_writer.KeyedCommand`, which the live service hands down) and stores it, with the answer
it gives, in the same transaction as what it records: the command and its key
are committed together or not at all, so a retry after a crash or a failed
write can never carry the command out twice.
"""

from __future__ import annotations

import logging
from typing import Any

from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live import trial_writer
from hcss.platform.live.leases import trial_transaction
from hcss.platform.live.recorder import kept_until_written, record_request_statuses
from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.live.trial_log import command_message
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.platform.models import (
    Command,
)
from hcss.simulation import OperatorCommand
from hcss.simulation.requests import RequestOutcome

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
    key: KeyedCommand | None = None,
) -> dict[str, Any]:
    """Apply `command` and log it with its outcome; the answer the participant's page gets."""
    with live.lock:
        _require_running(live)
        sim = live.sim
        step, sim_time = sim.step_count, float(sim.time)
        before = sim.snapshot()
        outcome = sim.apply(command)
        row: Command | None = None
        try:
            with (
                kept_until_written(live, simulation_restored=True),
                trial_transaction(database, live) as session,
            ):
                row = trial_writer.write_command(
                    session,
                    live.trial_id,
                    command,
                    outcome,
                    step=step,
                    sim_time=sim_time,
                    selections=selections,
                )
                record_request_statuses(live, session)
                answer = _answered(session, key, _committed_answer(row, outcome, step))
        except DBAPIError:
            committed = None if row is None else _was_committed(database, row)
            if row is None or not committed:
                live.roll_back_to(before)
                if committed is None and row is not None:
                    # Nobody can say whether the command is logged: the trial in memory is
                    # not trusted any longer; the runner drops it and the next request
                    # rebuilds it from what the database holds.
                    live.move_away()
                raise
            # The commit's answer was lost after the database committed (a dropped line, a
            # failover): the command is in the log, so it stays applied in memory too.
            log.warning("trial %s: command %s committed, its answer lost", live.trial_id, row.id)
            answer = _committed_answer(row, outcome, step)
        except BaseException:
            live.roll_back_to(before)
            raise
        live.command_applied(row.id)
        kind, text = command_message(
            row, outcome.accepted, outcome.request_id, outcome.reason, sim.scenario.n_collectives
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
    key: KeyedCommand | None = None,
) -> dict[str, Any]:
    """A click on the map; the answer is the observation's id (201 Created)."""
    with live.lock:
        _require_running(live)
        display = live.display()
        if kind == "collective":
            if collective is None or not 0 <= collective < display.n_collectives:
                raise ActionError("a collective observation needs a collective on the map")
        elif target is None or display.column(target) is None:
            raise ActionError("a target observation needs a visible target")
        with trial_transaction(database, live) as session:
            observation_id = trial_writer.write_observation(
                session,
                live.trial_id,
                kind=kind,
                collective=collective,
                target=target,
                button=button,
                step=live.sim.step_count,
                sim_time=float(live.sim.time),
            )
            return _answered(session, key, {"observation_id": observation_id}, status=201)


def probe_ready(
    database: Database,
    live: RunningTrial,
    probe_id: int,
    now: float | None = None,
    key: KeyedCommand | None = None,
) -> dict[str, Any]:
    """The Ready press; `now` (the runner's wall clock) times it from the prompt's delivery."""
    with live.lock:
        probe = _current_probe(live, probe_id)
        if probe.ready:
            raise ActionError("this probe's question is already shown", 409, "already_ready")
        running_s = None if now is None else live.running_wall_s(now)
        with trial_transaction(database, live) as session:
            trial_writer.write_probe_event(
                session,
                probe_id,
                "ready",
                latency_ms=_latency_ms(probe.delivered_s, running_s),
                **_when(live),
            )
            answer = _answered(session, key, {"ok": True})
        probe.ready_pressed(running_s)
        live.touch()
        return answer


def probe_answer(
    database: Database,
    live: RunningTrial,
    probe_id: int,
    answer: str,
    now: float | None = None,
    key: KeyedCommand | None = None,
) -> dict[str, Any]:
    """The answer; timed from the question's delivery (or the Ready press, if never sent)."""
    with live.lock:
        probe = _current_probe(live, probe_id)
        if not probe.ready:
            raise ActionError("press ready before answering", 409, "not_ready")
        if answer not in probe.choices:
            raise ActionError(f"{answer!r} is not one of the choices {probe.choices}")
        correct = None if probe.truth is None else answer == probe.truth
        running_s = None if now is None else live.running_wall_s(now)
        asked_s = (
            probe.question_delivered_s if probe.question_delivered_s is not None else probe.ready_s
        )
        with trial_transaction(database, live) as session:
            trial_writer.write_probe_event(
                session,
                probe_id,
                "answer",
                answer=answer,
                latency_ms=_latency_ms(asked_s, running_s),
                **_when(live),
            )
            if probe.truth is not None:
                trial_writer.write_probe_event(
                    session,
                    probe_id,
                    "scored",
                    answer=answer,
                    truth=probe.truth,
                    correct=correct,
                    **_when(live),
                )
            reply = _answered(session, key, {"ok": True})
        live.probe_answered(answer)
        live.touch()
        return reply


def _was_committed(database: Database, row: Command) -> bool | None:
    """Whether the command's row is in the database after its commit failed: asked, not
    guessed. None: the database cannot say (it is still away).

    A row flushed before the failed commit has its id; the database says whether
    the transaction that wrote it committed.
    """
    try:
        with database.session_scope() as session:
            return session.get(Command, row.id) is not None
    except DBAPIError:
        log.warning("trial %s: cannot tell whether command %s committed", row.trial_id, row.id)
        return None


def _committed_answer(row: Command, outcome: RequestOutcome, step: int) -> dict[str, Any]:
    return {
        "command_id": row.id,
        "accepted": outcome.accepted,
        "request_id": outcome.request_id if outcome.accepted else None,
        "reason": outcome.reason,
        "step": step,
    }


def _answered(
    session: Session, key: KeyedCommand | None, answer: dict[str, Any], status: int = 200
) -> dict[str, Any]:
    """`answer`, stored with the command's idempotency key (if sent) in the command's transaction."""
    if key is not None:
        trial_writer.write_command_key(session, key, status, answer)
    return answer


def _when(live: RunningTrial) -> dict[str, Any]:
    """The step and trial time an action lands at (between two steps)."""
    return {"step": live.sim.step_count, "sim_time": float(live.sim.time)}


def _latency_ms(since_s: float | None, now_s: float | None) -> float | None:
    if since_s is None or now_s is None:
        return None
    return round(max(0.0, now_s - since_s) * 1000.0, 1)


def _current_probe(live: RunningTrial, probe_id: int):
    _require_running(live)
    probe = live.current_probe
    if probe is None or probe.id != probe_id:
        raise ActionError("this probe is no longer open (answered or timed out)", 409, "closed")
    return probe


def _require_running(live: RunningTrial) -> None:
    if live.moved:  # its lease was lost under this command: the new host must carry it out
        raise ActionError("the trial moved to another server process; try again", 503, "moved")
    if live.ended:
        raise ActionError("the trial has ended", 409, "ended")
    if live.paused_since is not None:
        raise ActionError("the experimenter has paused the trial", 409, "paused")
