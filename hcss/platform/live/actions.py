"""What the participant does in a trial: requests, clicks and probe answers.

Each action takes the trial's lock, so it lands between two steps. A request
is logged and committed before it reaches the simulation (the log is what a
rebuild replays); its outcome follows as a second row.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from hcss.platform.db import Database
from hcss.platform.live.rebuild import accepted_text, refusal_text
from hcss.platform.live.session import LiveTrial
from hcss.platform.models import (
    Command,
    CommandOutcome,
    Observation,
    ProbeEvent,
    RequestStatusChange,
)
from hcss.platform.models.vocabularies import RequestStatus

INTERVENTION_SUPPORT = 0.10


class ActionError(Exception):
    """A participant action that cannot be taken; becomes a 4xx JSON answer."""

    def __init__(self, message: str, status: int = 400, code: str = "invalid") -> None:
        super().__init__(message)
        self.message = message
        self.status = status
        self.code = code


@dataclass(frozen=True)
class RequestInput:
    kind: str
    collective: int | None = None
    target: int | None = None
    request_id: int | None = None  # for cancel
    selections: tuple[int, ...] = ()


def submit_request(database: Database, live: LiveTrial, request: RequestInput) -> dict[str, Any]:
    with live.lock:
        _require_running(live)
        sim = live.sim
        view = live.view()
        collective, target = request.collective, request.target
        if request.kind == "cancel":
            cancelled = next((r for r in view["requests"] if r["id"] == request.request_id), None)
            if cancelled is not None:
                collective, target = cancelled["collective"], cancelled["target"]
        support = _support(view, collective, target)
        command = Command(
            trial_id=live.trial_id,
            kind=request.kind,
            collective=collective,
            target=target,
            cancel_request_id=request.request_id if request.kind == "cancel" else None,
            step_applied=sim.step_count,
            sim_time=float(sim.time),
            support=support,
            decision_index=_decision_index(live, collective),
            selections=list(request.selections),
        )
        with database.session_scope() as session:
            session.add(command)
        outcome = sim.apply(command.as_sim_command())
        live.last_command_id = command.id
        accepted = bool(outcome.accepted)
        reason = "" if accepted else str(outcome.reason)
        intervention = (
            accepted and request.kind == "abandon" and (support or 0.0) >= INTERVENTION_SUPPORT
        )
        with database.session_scope() as session:
            session.add(
                CommandOutcome(
                    command_id=command.id,
                    accepted=accepted,
                    request_id=outcome.request_id if accepted else None,
                    reason=reason,
                    intervention=intervention,
                )
            )
            if accepted and request.kind != "cancel":
                session.add(
                    RequestStatusChange(
                        trial_id=live.trial_id,
                        request_id=int(outcome.request_id),
                        status=RequestStatus.IN_PROGRESS,
                        step=sim.step_count,
                        sim_time=float(sim.time),
                    )
                )
                live.request_status[int(outcome.request_id)] = RequestStatus.IN_PROGRESS
        if accepted:
            live.add_message(
                sim.time,
                "accepted",
                accepted_text(command, outcome.request_id, sim.scenario.n_collectives),
            )
        else:
            live.add_message(
                sim.time, "refusal", refusal_text(command, reason, sim.scenario.n_collectives)
            )
        live.touch()
        return {
            "command_id": command.id,
            "accepted": accepted,
            "request_id": outcome.request_id if accepted else None,
            "reason": reason,
            "step": command.step_applied,
        }


def record_observation(
    database: Database,
    live: LiveTrial,
    *,
    kind: str,
    collective: int | None,
    target: int | None,
    button: str,
) -> int:
    with live.lock:
        _require_running(live)
        view = live.view()
        if kind == "collective":
            if collective is None or not 0 <= collective < len(view["collectives"]):
                raise ActionError("a collective observation needs a collective on the map")
        elif target is None or all(t["id"] != target for t in view["targets"]):
            raise ActionError("a target observation needs a visible target")
        row = Observation(
            trial_id=live.trial_id,
            kind=kind,
            collective=collective,
            target=target,
            button=button,
            step=live.sim.step_count,
            sim_time=float(live.sim.time),
        )
        with database.session_scope() as session:
            session.add(row)
        return row.id


def probe_ready(
    database: Database, live: LiveTrial, probe_id: int, now: float | None = None
) -> None:
    """The Ready press; `now` (the runner's wall clock) times it from the prompt's delivery."""
    with live.lock:
        probe = _current_probe(live, probe_id)
        if probe.ready:
            raise ActionError("this probe's question is already shown", 409, "already_ready")
        running_s = None if now is None else live.running_wall_s(now)
        event = _probe_event(live, probe_id, "ready")
        event.latency_ms = _latency_ms(probe.delivered_s, running_s)
        with database.session_scope() as session:
            session.add(event)
        probe.ready, probe.ready_s = True, running_s
        live.touch()


def probe_answer(
    database: Database, live: LiveTrial, probe_id: int, answer: str, now: float | None = None
) -> None:
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
        answered = _probe_event(live, probe_id, "answer", answer=answer)
        answered.latency_ms = _latency_ms(asked_s, running_s)
        with database.session_scope() as session:
            session.add(answered)
            if probe.truth is not None:
                event = _probe_event(live, probe_id, "scored", answer=answer)
                event.truth, event.correct = probe.truth, correct
                session.add(event)
        if probe.level == 3:
            live.pending_projection = [
                (pid, shown, answer if pid == probe_id else previous)
                for pid, shown, previous in live.pending_projection
            ]
        live.current_probe = None
        live.touch()


def _probe_event(live: LiveTrial, probe_id: int, kind: str, answer: str | None = None):  # type: ignore[no-untyped-def]
    return ProbeEvent(
        probe_id=probe_id,
        kind=kind,
        answer=answer,
        step=live.sim.step_count,
        sim_time=float(live.sim.time),
    )


def _latency_ms(since_s: float | None, now_s: float | None) -> float | None:
    if since_s is None or now_s is None:
        return None
    return round(max(0.0, now_s - since_s) * 1000.0, 1)


def _current_probe(live: LiveTrial, probe_id: int):  # type: ignore[no-untyped-def]
    _require_running(live)
    probe = live.current_probe
    if probe is None or probe.id != probe_id:
        raise ActionError("this probe is no longer open (answered or timed out)", 409, "closed")
    return probe


def _require_running(live: LiveTrial) -> None:
    if live.ended:
        raise ActionError("the trial has ended", 409, "ended")
    if live.paused_since is not None:
        raise ActionError("the experimenter has paused the trial", 409, "paused")


def _support(view: dict[str, Any], collective: int | None, target: int | None) -> float | None:
    if collective is None or target is None:
        return None
    for candidate in view["targets"]:
        if candidate["id"] == target:
            support = candidate["support"]
            return float(support[collective]) if collective < len(support) else None
    return None


def _decision_index(live: LiveTrial, collective: int | None) -> int | None:
    if collective is None or not 0 <= collective < len(live.sim.view()["collectives"]):
        return None
    return 1 + sum(1 for record in live.sim.decisions if record.collective == collective)
