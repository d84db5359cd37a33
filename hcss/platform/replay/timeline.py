"""What happened in a recorded trial, in trial time: the marks on the replay's timeline.

The participant's requests (accepted or refused, with the reason), their
probe answers (with the truth and whether they were right, or the time-out)
and the System Messages they saw, all read from the rows the live trial
wrote. The map itself is rebuilt by `frames`; these are the recorded facts
the experimenter watches it against.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.live.probes import probe_subject
from hcss.platform.live.trial_log import shown_messages
from hcss.platform.models import Command, CommandOutcome, Probe, ProbeEvent, Trial
from hcss.simulation.messages import collective_name


def command_marks(session: Session, trial_id: int) -> list[dict[str, Any]]:
    rows = session.execute(
        select(Command, CommandOutcome)
        .outerjoin(CommandOutcome, CommandOutcome.command_id == Command.id)
        .where(Command.trial_id == trial_id)
        .order_by(Command.id)
    )
    marks = []
    for command, outcome in rows:
        if command.kind == "cancel":
            label = f"cancel assignment {command.cancel_request_id}"
        else:
            collective = "?" if command.collective is None else collective_name(command.collective)
            label = f"{command.kind} {collective} → target {command.target}"
        marks.append(
            {
                "time": command.sim_time,
                "step": command.step_applied,
                "kind": command.kind,
                "label": label,
                "accepted": None if outcome is None else outcome.accepted,
                "reason": "" if outcome is None else outcome.reason,
            }
        )
    return marks


def probe_marks(session: Session, trial_id: int) -> list[dict[str, Any]]:
    probes = list(
        session.scalars(select(Probe).where(Probe.trial_id == trial_id).order_by(Probe.id))
    )
    events: dict[int, dict[str, ProbeEvent]] = {p.id: {} for p in probes}
    for event in session.scalars(
        select(ProbeEvent).where(ProbeEvent.probe_id.in_(list(events))).order_by(ProbeEvent.id)
    ):
        events[event.probe_id][event.kind] = event
    marks = []
    for probe in probes:
        kinds = events[probe.id]
        answer, scored = kinds.get("answer"), kinds.get("scored")
        closed = answer or kinds.get("timeout")
        marks.append(
            {
                "index": probe.probe_index,
                "level": probe.level,
                "question": probe.question,
                "choices": list(probe.choices),
                "subject": probe_subject(probe.level, probe.question),
                "shown": probe.shown_sim_time,
                "timeout": probe.timeout_sim_time,
                "ready": kinds["ready"].sim_time if "ready" in kinds else None,
                "closed": closed.sim_time if closed else probe.timeout_sim_time,
                "answer": answer.answer if answer else None,
                "truth": scored.truth if scored else probe.truth,
                "correct": scored.correct if scored else (answer.correct if answer else None),
                "timed_out": answer is None,
            }
        )
    return marks


def system_messages(session: Session, trial_id: int) -> list[dict[str, Any]]:
    """The System Messages as the participant saw them: events, accepted and refused requests."""
    return [
        {"seq": seq, "time": round(float(time), 1), "kind": kind, "text": text}
        for seq, (time, kind, text) in enumerate(shown_messages(session, trial_id), start=1)
    ]


def timeline(session: Session, trial: Trial, dt: float) -> dict[str, Any]:
    return {
        "trial": {
            "id": trial.id,
            "kind": trial.kind,
            "model": trial.model,
            "seed": trial.seed,
            "scenario_id": trial.scenario_id,
            "duration_s": trial.duration_s,
            "dt": dt,
        },
        "commands": command_marks(session, trial.id),
        "probes": probe_marks(session, trial.id),
        "messages": system_messages(session, trial.id),
    }
