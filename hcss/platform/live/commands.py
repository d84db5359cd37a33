"""The participant's commands, one declaration each: the table the live service's door
dispatches by, and the API's routes are made from.

A command is a small frozen value (`SubmitRequest`, `Observe`, `ProbeReady`,
`ProbeAnswer`) made from the route's values and the POST body, unparsed. Its
`Declaration` says everything the rest of the wing needs of it, in one place:

- `route`, `endpoint` and `status`: where the API takes it and what a success
  answers (the endpoint names the command in its idempotency key's fingerprint);
- `parse`: the body read and every field checked against the trial's real
  ranges (the checks below), a 400 otherwise; run with the trial found, so an
  ended or moved trial answers as such whatever the body;
- `check`: the trial's state, under its lock, beyond "it runs here, unpaused"
  (which the door checks for every command): the click on the map, the probe
  still open and its question shown or not;
- `fact`: what happened, as a typed fact (`live.facts`), which declares its
  own rows; a request applies itself to the simulation here (`changes_simulation`:
  put back if its unit of work does not commit);
- `answer`: the JSON body its client gets, given the fact's row id;
- `taken`: the trial in memory moves on once the fact is committed (a
  probe's Ready press shows its question, an answer takes it off screen, a
  request's System Message is added).

Why every field is checked before anything is written: a command is logged
and committed before it reaches the simulation, and the log is what a rebuild
replays and the export reads. So a field that names something the trial
cannot have (collective 16 of four, target 2**63, a request id never issued,
a selection that is not this trial's click) is refused by `parse` with a 400
and a message the client can show, and is never stored. What is within range
but not possible *now* (an undiscovered target, a collective executing a
move) stays a refusal from the simulation, logged and shown in System
Messages. `ActionError` is a command refused: a 4xx JSON answer, nothing
written.

`COMMANDS` is the table. The door (hcss.platform.live.door) finds the trial,
takes its lock and the key, and carries a command out by its declaration in
one trial unit of work (hcss.platform.live.unit_of_work); the API
(hcss.platform.live.api) makes one route per declaration. Adding a command
is a value and its declaration here, and its fact in hcss.platform.live.facts
(plus, as ever, its model, migration and page).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live.facts import (
    CommandApplied,
    Fact,
    ObservationMade,
    ProbeAnswered,
    ProbeReadyPressed,
)
from hcss.platform.live.trial_log import command_message
from hcss.platform.models import COMMAND_KINDS, Observation
from hcss.simulation import OperatorCommand

if TYPE_CHECKING:
    from hcss.platform.live.progress import CurrentProbe
    from hcss.platform.live.running_trial import RunningTrial
    from hcss.platform.live.unit_of_work import TrialUnit

# --- the checks: every field against the trial's real ranges, before anything is written ---


class ActionError(Exception):
    """A participant action that cannot be taken; becomes a 4xx JSON answer."""

    def __init__(self, message: str, status: int = 400, code: str = "invalid") -> None:
        super().__init__(message)
        self.message = message
        self.status = status
        self.code = code


#: Ids are 32-bit on PostgreSQL (INTEGER); nothing larger can name a row.
MAX_ID = 2**31 - 1
#: The request form is filled by a handful of clicks; more is not a person's form.
MAX_SELECTIONS = 32


def json_object(body: Any) -> dict[str, Any]:
    """The parsed POST body if it is a JSON object, else an ActionError that says to send one."""
    if not isinstance(body, dict):
        raise ActionError("send a JSON object (Content-Type: application/json)")
    return body


def bounded_int(value: Any, name: str, low: int, high: int) -> int:
    """`value` as an int within [low, high], else an ActionError that says the range."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ActionError(f"'{name}' must be a whole number from {low} to {high}")
    if not low <= value <= high:
        raise ActionError(f"'{name}' must be from {low} to {high} in this trial, not {value}")
    return value


def trial_ranges(live: RunningTrial) -> tuple[int, int, int]:
    """(collectives, target ids, request ids issued so far) of this trial.

    The first two are fixed for the trial's life; the third only grows, so
    reading it without the trial's lock can only be too strict by the request
    accepted a moment ago, never too lax.
    """
    sim = live.sim
    world = sim.world
    return int(world.n_collectives), int(world.active.size), int(sim.next_request_id) - 1


def parse_selections(ids: Any, session: Session, trial_id: int) -> tuple[int, ...]:
    """Observation ids of the clicks that filled the form; each must be this trial's."""
    if not isinstance(ids, list) or len(ids) > MAX_SELECTIONS:
        raise ActionError(
            f"'selections' must be a list of at most {MAX_SELECTIONS} observation ids"
        )
    checked = [bounded_int(i, "selections", 1, MAX_ID) for i in ids]
    if checked:
        found = set(
            session.scalars(
                select(Observation.id).where(
                    Observation.id.in_(checked), Observation.trial_id == trial_id
                )
            )
        )
        if found != set(checked):
            raise ActionError("'selections' names observations of another trial")
    return tuple(checked)


# --- the commands --------------------------------------------------------------------------


@dataclass(frozen=True)
class SubmitRequest:
    """The participant's request (the POST body, unparsed: its declaration checks it)."""

    trial_id: int
    body: Any


@dataclass(frozen=True)
class Observe:
    """The participant's click on the map (the POST body, unparsed)."""

    trial_id: int
    body: Any


@dataclass(frozen=True)
class ProbeReady:
    """The participant's Ready press on the open probe."""

    trial_id: int
    probe_id: int
    body: Any = None


@dataclass(frozen=True)
class ProbeAnswer:
    """The participant's answer to the open probe (the POST body, unparsed)."""

    trial_id: int
    probe_id: int
    body: Any


ParticipantCommand = SubmitRequest | Observe | ProbeReady | ProbeAnswer
C = TypeVar("C")
P = TypeVar("P")  # what `parse` makes of the command, handed to the later steps


def _nothing_more(_live: RunningTrial, _parsed: Any) -> None:
    """No check beyond the door's (the trial runs here, unpaused)."""


def _nothing_taken(
    _live: RunningTrial, _parsed: Any, _fact: Any, _row_id: int | None, _now: float
) -> None:
    """The trial in memory does not move on (the fact's row is all there is to it)."""


def _nothing_written(_unit: TrialUnit) -> None:
    """Nothing beyond the command's own fact in its unit of work."""


@dataclass(frozen=True)
class Declaration(Generic[C, P]):
    """One participant command: how it is taken, checked, applied, written and answered."""

    #: The API's URL rule under the trial, its endpoint name and a success's HTTP status.
    route: str
    endpoint: str
    status: int
    #: The command from the trial's id, the route's values and the POST body.
    make: Callable[[int, Mapping[str, Any], Any], C]
    #: The body read and checked (ActionError, 400), before the trial's lock is taken.
    parse: Callable[[C, RunningTrial, Database], P]
    #: The trial's state checked under its lock (ActionError, 409).
    check: Callable[[RunningTrial, P], None]
    #: What happened (`now`: the runner's wall clock), with the trial's lock held.
    fact: Callable[[RunningTrial, P, float], Fact]
    #: The client's answer, given the fact's row id.
    answer: Callable[[Fact, int | None], dict[str, Any]]
    #: The trial in memory moves on, once the fact is committed (its row's id; `now` as
    #: for `fact`).
    taken: Callable[[RunningTrial, P, Any, int | None, float], None] = _nothing_taken
    #: What else its unit of work writes (a request: the statuses it changed).
    also_written: Callable[[TrialUnit], None] = _nothing_written
    #: `fact` changes the simulation: put back when the unit does not commit.
    changes_simulation: bool = False


# --- a request ----------------------------------------------------------------------------


@dataclass(frozen=True)
class CheckedRequest:
    command: OperatorCommand
    selections: tuple[int, ...]


def parse_request(command: SubmitRequest, live: RunningTrial, database: Database) -> CheckedRequest:
    """The command in a POST body and the clicks that filled its form, every field checked.

    ActionError (400) otherwise. The `OperatorCommand` made here is the one
    applied, stored and (rebuilt from its row) replayed.
    """
    body = json_object(command.body)
    kind = body.get("kind")
    if not isinstance(kind, str) or kind not in COMMAND_KINDS:
        raise ActionError(f"'kind' must be one of {', '.join(COMMAND_KINDS)}")
    collectives, targets, issued = trial_ranges(live)
    if kind == "cancel":
        if issued < 1:
            raise ActionError("'request_id' names no assignment: none has been made in this trial")
        request_id = bounded_int(body.get("request_id"), "request_id", 1, issued)
        return CheckedRequest(OperatorCommand.cancel(request_id), ())
    operator_command = OperatorCommand(
        kind,
        collective=bounded_int(body.get("collective"), "collective", 0, collectives - 1),
        target=bounded_int(body.get("target"), "target", 1, targets),
    )
    with database.session_scope() as session:  # read-only: back in the pool before the lock
        selections = parse_selections(body.get("selections", []), session, command.trial_id)
    return CheckedRequest(operator_command, selections)


def _request_applied(live: RunningTrial, request: CheckedRequest, _now: float) -> CommandApplied:
    """Applied to the simulation first: everything its rows say is the simulation's outcome."""
    sim = live.sim
    step, sim_time = sim.step_count, float(sim.time)
    outcome = sim.apply(request.command)
    return CommandApplied(request.command, outcome, step, sim_time, request.selections)


def _request_answer(applied: Fact, row_id: int | None) -> dict[str, Any]:
    assert isinstance(applied, CommandApplied)
    outcome = applied.outcome
    return {
        "command_id": row_id,
        "accepted": outcome.accepted,
        "request_id": outcome.request_id if outcome.accepted else None,
        "reason": outcome.reason,
        "step": applied.step,
    }


def _request_taken(
    live: RunningTrial,
    _request: CheckedRequest,
    applied: CommandApplied,
    row_id: int | None,
    _now: float,
) -> None:
    """The simulation holds the logged command; System Messages say what became of it."""
    assert row_id is not None  # stored
    live.command_applied(row_id)
    outcome = applied.outcome
    kind, text = command_message(
        applied,
        outcome.accepted,
        outcome.request_id,
        outcome.reason,
        live.sim.scenario.n_collectives,
    )
    live.add_message(applied.sim_time, kind, text)


def _statuses_written(unit: TrialUnit) -> None:
    """The request statuses the request changed, in its unit of work."""
    live = unit.live
    unit.write(*live.log_queue.status_changes_to_write(live.sim.drain_status_changes()))


# --- a click on the map -------------------------------------------------------------------


@dataclass(frozen=True)
class Click:
    kind: str
    collective: int | None
    target: int | None
    button: str


def parse_observation(command: Observe, live: RunningTrial, _database: Database) -> Click:
    """(kind, collective, target, button) of a click on the map, every field checked.

    Whether the clicked collective or target is on the map now is checked
    under the trial's lock (`_on_the_map`).
    """
    body = json_object(command.body)
    kind, button = body.get("kind"), body.get("button")
    collectives, targets, _ = trial_ranges(live)
    if kind not in ("collective", "target"):
        raise ActionError("'kind' must be 'collective' or 'target'")
    if button not in ("left", "right"):
        raise ActionError("'button' must be 'left' or 'right'")
    collective = _clicked(body, "collective", kind, collectives - 1, low=0)
    return Click(kind, collective, _clicked(body, "target", kind, targets, low=1), button)


def _clicked(body: dict[str, Any], name: str, kind: str, high: int, *, low: int) -> int | None:
    """The clicked collective or target: required for its own kind, optional otherwise."""
    value = body.get(name)
    if value is None and kind != name:
        return None
    return bounded_int(value, name, low, high)


def _on_the_map(live: RunningTrial, click: Click) -> None:
    """A click names a collective on the map, or a target the participant sees now."""
    display = live.display()
    if click.kind == "collective":
        if click.collective is None or not 0 <= click.collective < display.n_collectives:
            raise ActionError("a collective observation needs a collective on the map")
    elif click.target is None or display.column(click.target) is None:
        raise ActionError("a target observation needs a visible target")


def _observation_made(live: RunningTrial, click: Click, _now: float) -> ObservationMade:
    return ObservationMade(click.kind, click.collective, click.target, click.button, **_when(live))


# --- a probe's Ready press and answer -------------------------------------------------------


def _open_probe(live: RunningTrial, probe_id: int, *, ready: bool) -> CurrentProbe:
    """The probe on screen, if it is `probe_id` and its question is shown (`ready`) or not."""
    probe = live.probes.current
    if probe is None or probe.id != probe_id:
        raise ActionError("this probe is no longer open (answered or timed out)", 409, "closed")
    if probe.ready and not ready:
        raise ActionError("this probe's question is already shown", 409, "already_ready")
    if ready and not probe.ready:
        raise ActionError("press ready before answering", 409, "not_ready")
    return probe


def _ready_checked(live: RunningTrial, press: ProbeReady) -> None:
    _open_probe(live, press.probe_id, ready=False)


def _ready_pressed(live: RunningTrial, press: ProbeReady, now: float) -> ProbeReadyPressed:
    """Timed from the prompt's delivery."""
    probe = _open_probe(live, press.probe_id, ready=False)
    return ProbeReadyPressed(
        probe.id,
        _latency_ms(probe.delivered_s, live.trial_clock.running_wall_s(now)),
        **_when(live),
    )


def _ready_taken(
    live: RunningTrial,
    press: ProbeReady,
    _pressed: ProbeReadyPressed,
    _row_id: int | None,
    now: float,
) -> None:
    """The question is shown from the next frame on."""
    _open_probe(live, press.probe_id, ready=False).ready_pressed(
        live.trial_clock.running_wall_s(now)
    )


@dataclass(frozen=True)
class CheckedAnswer:
    probe_id: int
    answer: str


def parse_answer(command: ProbeAnswer, _live: RunningTrial, _database: Database) -> CheckedAnswer:
    """The probe answer in the POST body; whether it is one of the choices is checked under
    the trial's lock (`_answer_checked`)."""
    answer = json_object(command.body).get("answer")
    if not isinstance(answer, str):
        raise ActionError("'answer' must be one of the choices, as a string")
    return CheckedAnswer(command.probe_id, answer)


def _answer_checked(live: RunningTrial, answer: CheckedAnswer) -> None:
    probe = _open_probe(live, answer.probe_id, ready=True)
    if answer.answer not in probe.choices:
        raise ActionError(f"{answer.answer!r} is not one of the choices {probe.choices}")


def _probe_answered(live: RunningTrial, answer: CheckedAnswer, now: float) -> ProbeAnswered:
    """Timed from the question's delivery (or the Ready press, if never sent)."""
    probe = _open_probe(live, answer.probe_id, ready=True)
    asked_s = (
        probe.question_delivered_s if probe.question_delivered_s is not None else probe.ready_s
    )
    return ProbeAnswered(
        probe.id,
        answer.answer,
        probe.truth,
        _latency_ms(asked_s, live.trial_clock.running_wall_s(now)),
        **_when(live),
    )


def _answer_taken(
    live: RunningTrial,
    answer: CheckedAnswer,
    _fact: ProbeAnswered,
    _row_id: int | None,
    _now: float,
) -> None:
    """The probe is off screen; a level-3 answer waits for the next decision."""
    live.probe_answered(answer.answer)


def _ok(_fact: Fact, _row_id: int | None) -> dict[str, Any]:
    return {"ok": True}


def _when(live: RunningTrial) -> dict[str, Any]:
    """The step and trial time a command lands at (between two steps)."""
    return {"step": live.sim.step_count, "sim_time": float(live.sim.time)}


def _latency_ms(since_s: float | None, now_s: float | None) -> float | None:
    if since_s is None or now_s is None:
        return None
    return round(max(0.0, now_s - since_s) * 1000.0, 1)


#: The table: each participant command's declaration, by the command's type.
COMMANDS: dict[type, Declaration[Any, Any]] = {
    SubmitRequest: Declaration(
        route="/requests",
        endpoint="submit_request",
        status=200,
        make=lambda trial_id, _values, body: SubmitRequest(trial_id, body),
        parse=parse_request,
        check=_nothing_more,
        fact=_request_applied,
        answer=_request_answer,
        taken=_request_taken,
        also_written=_statuses_written,
        changes_simulation=True,
    ),
    Observe: Declaration(
        route="/observations",
        endpoint="observe",
        status=201,
        make=lambda trial_id, _values, body: Observe(trial_id, body),
        parse=parse_observation,
        check=_on_the_map,
        fact=_observation_made,
        answer=lambda _fact, row_id: {"observation_id": row_id},
    ),
    ProbeReady: Declaration(
        route="/probes/<int:probe_id>/ready",
        endpoint="probe_ready",
        status=200,
        make=lambda trial_id, values, body: ProbeReady(trial_id, values["probe_id"], body),
        parse=lambda command, _live, _database: command,
        check=_ready_checked,
        fact=_ready_pressed,
        answer=_ok,
        taken=_ready_taken,
    ),
    ProbeAnswer: Declaration(
        route="/probes/<int:probe_id>/answer",
        endpoint="probe_answer",
        status=200,
        make=lambda trial_id, values, body: ProbeAnswer(trial_id, values["probe_id"], body),
        parse=parse_answer,
        check=_answer_checked,
        fact=_probe_answered,
        answer=_ok,
        taken=_answer_taken,
    ),
}
