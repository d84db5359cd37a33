"""Check a participant's command against the trial's real ranges before anything is written.

A command is logged and committed before it reaches the simulation, and the
log is what a rebuild replays and the export reads. So a field that names
something the trial cannot have (collective 16 of four, target 2**63, a
request id never issued, a selection that is not this trial's click) is
refused here, with a 400 and a message the client can show, and is never
stored. What is within range but not possible *now* (an undiscovered target,
a collective executing a move) stays a refusal from the simulation, logged
and shown in System Messages as before.

`parse_request`, `parse_observation` and `parse_answer` are the entry points,
one per command that carries a body; the live service's door
(hcss.platform.live.door) calls them once they have found the trial, so a
trial that has ended or moved is answered as such whatever the body says.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.live.actions import ActionError
from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.models import COMMAND_KINDS, Observation
from hcss.simulation import OperatorCommand

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


def parse_request(
    body: Any, live: RunningTrial, session: Session, trial_id: int
) -> tuple[OperatorCommand, tuple[int, ...]]:
    """The command in a POST body and the clicks that filled its form, every field checked.

    ActionError (400) otherwise. The `OperatorCommand` made here is the one
    applied, stored and (rebuilt from its row) replayed.
    """
    body = json_object(body)
    kind = body.get("kind")
    if not isinstance(kind, str) or kind not in COMMAND_KINDS:
        raise ActionError(f"'kind' must be one of {', '.join(COMMAND_KINDS)}")
    collectives, targets, issued = trial_ranges(live)
    if kind == "cancel":
        if issued < 1:
            raise ActionError("'request_id' names no assignment: none has been made in this trial")
        return OperatorCommand.cancel(
            bounded_int(body.get("request_id"), "request_id", 1, issued)
        ), ()
    command = OperatorCommand(
        kind,
        collective=bounded_int(body.get("collective"), "collective", 0, collectives - 1),
        target=bounded_int(body.get("target"), "target", 1, targets),
    )
    return command, parse_selections(body.get("selections", []), session, trial_id)


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


def parse_observation(body: Any, live: RunningTrial) -> tuple[str, int | None, int | None, str]:
    """(kind, collective, target, button) of a click on the map, every field checked.

    Whether the clicked collective or target is on the map now is the
    action's check, under the trial's lock.
    """
    body = json_object(body)
    kind, button = body.get("kind"), body.get("button")
    collectives, targets, _ = trial_ranges(live)
    if kind not in ("collective", "target"):
        raise ActionError("'kind' must be 'collective' or 'target'")
    if button not in ("left", "right"):
        raise ActionError("'button' must be 'left' or 'right'")
    collective = _clicked(body, "collective", kind, collectives - 1, low=0)
    return kind, collective, _clicked(body, "target", kind, targets, low=1), button


def _clicked(body: dict[str, Any], name: str, kind: str, high: int, *, low: int) -> int | None:
    """The clicked collective or target: required for its own kind, optional otherwise."""
    value = body.get(name)
    if value is None and kind != name:
        return None
    return bounded_int(value, name, low, high)


def parse_answer(body: Any) -> str:
    """The probe answer in the POST body; whether it is one of the choices is the action's check."""
    answer = json_object(body).get("answer")
    if not isinstance(answer, str):
        raise ActionError("'answer' must be one of the choices, as a string")
    return answer
