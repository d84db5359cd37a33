"""Rows of the trial tables, read from the append-only trial records.

Each function turns one kind of record into rows keyed by the data
dictionary's columns. Only what the dictionary names leaves the database:
participant codes, never tokens; no free text a participant typed.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.export.problems import ProblemLog
from hcss.platform.live.trial_log import observation_actions
from hcss.platform.models import (
    Command,
    CommandOutcome,
    DecisionRow,
    Interruption,
    Probe,
    ProbeEvent,
    Trial,
)
from hcss.platform.models.stored_names import stored_collective_name
from hcss.platform.study.enrolment import current_enrolment
from hcss.platform.study.studyfile import FAST_ANSWER_MS, StudyFileError, load_study
from hcss.simulation.params import Params
from hcss.tablespec.decisions import exported_decision

#: `[probes] fast_answer_ms` of a study file that does not set it.
DEFAULT_FAST_MS = FAST_ANSWER_MS

Row = dict[str, Any]


def iso(moment: datetime | None) -> str | None:
    """ISO 8601 UTC with a Z, as the dictionary's `wall_time` asks."""
    if moment is None:
        return None
    return moment.isoformat(timespec="milliseconds").replace("+00:00", "Z")


def roman(collective: int | None, trial: Trial) -> str | None:
    """The collective's numeral; Uninterpretable for an index the trial does not have."""
    hubs = trial.scenario.get("hubs") if isinstance(trial.scenario, dict) else None
    return stored_collective_name(collective, len(hubs) if isinstance(hubs, list) else None)


def _keys(trial: Trial, code: str, sim_time: float, wall: datetime) -> Row:
    return {
        "participant": code,
        "trial_id": str(trial.id),
        "model": trial.model,
        "sim_time_s": sim_time,
        "wall_time": iso(wall),
    }


def decision_rows(session: Session, trial: Trial, code: str, problems: ProblemLog) -> list[Row]:
    rows = []
    for stored in session.scalars(
        select(DecisionRow).where(DecisionRow.trial_id == trial.id).order_by(DecisionRow.id)
    ):
        with problems.guard(
            "decisions", f"decision {stored.id}", participant=code, trial_id=trial.id
        ):
            rows.append(exported_decision(stored.record, code, str(trial.id)))
    return rows


def request_rows(session: Session, trial: Trial, code: str, problems: ProblemLog) -> list[Row]:
    """Every request, accepted or refused, with the context logged when it was made.

    Read as columns, not ORM objects: a trial holds hundreds of commands, and building an
    object (and its identity-map entry) for each was most of a cold `hcss export`'s time."""
    rows = []
    for stored in session.execute(
        select(
            Command.id,
            Command.sim_time,
            Command.created_at,
            Command.kind,
            Command.collective,
            Command.target,
            Command.support,
            Command.decision_index,
            CommandOutcome.command_id.label("outcome_of"),
            CommandOutcome.request_id,
            CommandOutcome.accepted,
            CommandOutcome.reason,
            CommandOutcome.intervention,
        )
        .outerjoin(CommandOutcome, CommandOutcome.command_id == Command.id)
        .where(Command.trial_id == trial.id)
        .order_by(Command.id)
    ):
        with problems.guard(
            "requests", f"command {stored.id}", participant=code, trial_id=trial.id
        ):
            rows.append(
                _request_row(trial, code, stored, stored if stored.outcome_of is not None else None)
            )
    return rows


def _request_row(trial: Trial, code: str, command: Any, outcome: Any | None) -> Row:
    """One request's row from its command's and its outcome's columns (outcome: None when
    the command has none)."""
    return {
        **_keys(trial, code, command.sim_time, command.created_at),
        "request_id": None if outcome is None else outcome.request_id,
        "kind": command.kind,
        "collective": roman(command.collective, trial),
        "target": command.target,
        "accepted": None if outcome is None else outcome.accepted,
        "reason": None if outcome is None or outcome.accepted else outcome.reason,
        "support": command.support,
        "intervention": None if outcome is None else outcome.intervention,
        "decision_index": command.decision_index,
    }


def observation_rows(session: Session, trial: Trial, code: str, problems: ProblemLog) -> list[Row]:
    """Observation actions only: clicks that filled a committed request are part of it."""
    rows = []
    for click in observation_actions(session, trial.id):
        with problems.guard(
            "observations", f"observation {click.id}", participant=code, trial_id=trial.id
        ):
            rows.append(
                {
                    **_keys(trial, code, click.sim_time, click.created_at),
                    "kind": click.kind,
                    "collective": roman(click.collective, trial),
                    "target": click.target,
                    "button": click.button,
                }
            )
    return rows


def probe_rows(session: Session, trial: Trial, code: str, problems: ProblemLog) -> list[Row]:
    probes = list(
        session.scalars(select(Probe).where(Probe.trial_id == trial.id).order_by(Probe.id))
    )
    events: dict[int, list[ProbeEvent]] = defaultdict(list)
    for event in session.scalars(
        select(ProbeEvent)
        .where(ProbeEvent.probe_id.in_([p.id for p in probes]))
        .order_by(ProbeEvent.id)
    ):
        events[event.probe_id].append(event)
    fast_ms = fast_answer_ms(session, trial.participant_id)
    return [_probe_row(trial, code, probe, events[probe.id], fast_ms) for probe in probes]


def fast_answer_ms(session: Session, participant_id: int) -> int:
    """The participant's study's `[probes] fast_answer_ms` (the default without a study);
    asked once per participant and database session (`session.info`: an export), not per trial."""
    known: dict[int, int] = session.info.setdefault("hcss_fast_answer_ms", {})
    if participant_id not in known:
        known[participant_id] = _fast_answer_ms(session, participant_id)
    return known[participant_id]


def _fast_answer_ms(session: Session, participant_id: int) -> int:
    enrolment = current_enrolment(session, participant_id)
    try:
        return load_study(enrolment.study).probes.fast_answer_ms if enrolment else DEFAULT_FAST_MS
    except StudyFileError:  # a study file since removed: its data still export
        return DEFAULT_FAST_MS


def _probe_row(
    trial: Trial, code: str, probe: Probe, events: Iterable[ProbeEvent], fast_ms: int
) -> Row:
    first: dict[str, ProbeEvent] = {}
    for event in events:  # the first of each kind counts; later ones are never expected
        first.setdefault(event.kind, event)
    ready, answer, scored = first.get("ready"), first.get("answer"), first.get("scored")
    return {
        **_keys(trial, code, probe.shown_sim_time, probe.created_at),
        "probe_index": probe.probe_index,
        "level": probe.level,
        "question": probe.question,
        "ready_latency_ms": None if ready is None else ready.latency_ms,
        "answer_latency_ms": None if answer is None else answer.latency_ms,
        "answer": None if answer is None else answer.answer,
        "truth": scored.truth if scored is not None and scored.truth else probe.truth,
        "correct": None if scored is None else scored.correct,
        "timed_out": answer is None and "timeout" in first,
        "fast_answer": None
        if answer is None or answer.latency_ms is None
        else answer.latency_ms < fast_ms,
    }


def interruption_rows(session: Session, trial: Trial, code: str, problems: ProblemLog) -> list[Row]:
    """Server restarts that found the trial live (training and main trials alike)."""
    rows = []
    for stopped in session.scalars(
        select(Interruption).where(Interruption.trial_id == trial.id).order_by(Interruption.id)
    ):
        with problems.guard(
            "interruptions", f"interruption {stopped.id}", participant=code, trial_id=trial.id
        ):
            rows.append(
                {
                    "participant": code,
                    "trial_id": str(trial.id),
                    "trial_kind": trial.kind,
                    "model": trial.model,
                    "last_seen_at": iso(stopped.last_seen_at),
                    "resumed_at": iso(stopped.created_at),
                    "outage_s": float(stopped.outage_s),
                    "resumed_step": stopped.resumed_step,
                    "resumed_sim_time_s": stopped.resumed_step * _dt(trial),
                    "replayed_commands": stopped.replayed_commands,
                }
            )
    return rows


def _dt(trial: Trial) -> float:
    return float((trial.params or {}).get("dt_s", Params().dt_s))


TRIAL_ROW_BUILDERS = {
    "decisions": decision_rows,
    "requests": request_rows,
    "observations": observation_rows,
    "probes": probe_rows,
}
