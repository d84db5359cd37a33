"""The live table: every participant's stage, time in stage and trial clock.

Read straight from the database on each poll (a few hundred participants at
most), so the table is right whichever server process runs the trials. The
trial clock is computed the way the runner computes it: running wall time,
pauses excluded, times the trial's acceleration.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from hcss.platform.console.pauses import paused_intervals
from hcss.platform.console.sessions import session_state
from hcss.platform.models import Participant, StageEvent, Trial, TrialStatusChange
from hcss.platform.pilots import is_pilot
from hcss.platform.study.flow import Position, current_position


@dataclass(frozen=True)
class ProgressRow:
    code: str
    state: str  # active, paused, aborted
    stage: str
    time_in_stage_s: float
    trial_clock_s: float | None  # None outside a running trial
    trial_duration_s: float | None
    is_pilot: bool
    is_bot: bool
    is_demo: bool


def trial_clock_s(session: Session, trial: Trial, now: float) -> float:
    paused, open_since = paused_intervals(session, trial.id)
    stopped = now if open_since is None else min(now, open_since)
    running = max(0.0, stopped - trial.started_at.timestamp() - paused)
    return min(trial.duration_s, running * trial.time_acceleration)


def _latest_trials(session: Session) -> dict[int, Trial]:
    newest = select(func.max(Trial.id)).group_by(Trial.participant_id)
    return {t.participant_id: t for t in session.scalars(select(Trial).where(Trial.id.in_(newest)))}


def _trial_status(session: Session, trial_id: int) -> TrialStatusChange | None:
    return session.scalars(
        select(TrialStatusChange)
        .where(TrialStatusChange.trial_id == trial_id)
        .order_by(TrialStatusChange.id.desc())
        .limit(1)
    ).first()


def _latest_stage_events(session: Session) -> dict[int, StageEvent]:
    newest = select(func.max(StageEvent.id)).group_by(StageEvent.participant_id)
    return {
        e.participant_id: e
        for e in session.scalars(select(StageEvent).where(StageEvent.id.in_(newest)))
    }


def _entered_at(session: Session, participant_id: int, position: Position) -> StageEvent | None:
    assert position.slot is not None
    return session.scalars(
        select(StageEvent).where(
            StageEvent.participant_id == participant_id,
            StageEvent.stage_index == position.slot.index,
            StageEvent.step == position.step,
            StageEvent.kind == "entered",
        )
    ).first()


def _stage_label(position: Position) -> str:
    """``mental_rotation part_1``, ``post_trial M2``; the status once the study is over."""
    if position.slot is None:
        return "not started" if position.status == "not_enrolled" else position.status
    parts = (position.slot.name, position.slot.model, position.step)
    return " ".join(part for part in parts if part and part != "form")


def progress_rows(session: Session, now: float) -> list[ProgressRow]:
    """One row per participant, newest first.

    The stage is the study engine's own answer to "which stage now?"
    (`current_position`), so the console never disagrees with what the
    participant sees; a running trial adds its clock. Time in stage counts
    from the step's entry, or from the last thing that happened when the
    participant has not opened the next step yet.
    """
    trials = _latest_trials(session)
    last_events = _latest_stage_events(session)
    rows = []
    for participant in session.scalars(select(Participant).order_by(Participant.id.desc())):
        state = session_state(session, participant.id)
        trial = trials.get(participant.id)
        status = None if trial is None else _trial_status(session, trial.id)
        position = current_position(session, participant)
        last = last_events.get(participant.id)
        clock = duration = None
        since = participant.created_at.timestamp() if last is None else last.at.timestamp()
        if trial is not None and status is not None and status.status == "running":
            stage, since = f"{trial.kind} {trial.model}", trial.started_at.timestamp()
            clock, duration = trial_clock_s(session, trial, now), trial.duration_s
        elif position.status == "not_enrolled" and trial is not None:
            # A participant outside the study flow (`hcss demo-trial`).
            reason = "" if status is None else f" ({status.reason})"
            stage = f"{trial.kind} {trial.model} ended{reason}"
            since = (trial.started_at if status is None else status.created_at).timestamp()
        else:
            stage = _stage_label(position)
            entered = (
                None if position.slot is None else _entered_at(session, participant.id, position)
            )
            if entered is not None:
                since = entered.at.timestamp()
        rows.append(
            ProgressRow(
                code=participant.code,
                state=state,
                stage=stage,
                time_in_stage_s=max(0.0, now - since),
                trial_clock_s=clock,
                trial_duration_s=duration,
                is_pilot=is_pilot(session, participant),
                is_bot=participant.is_bot,
                is_demo=participant.is_demo,
            )
        )
    return rows


def progress_json(session: Session, now: float) -> list[dict[str, Any]]:
    return [asdict(row) for row in progress_rows(session, now)]
