"""Check a participant's command against the trial's real ranges before anything is written.

A command is logged and committed before it reaches the simulation, and the
log is what a rebuild replays and the export reads. So a field that names
something the trial cannot have (collective 16 of four, target 2**63, a
request id never issued, a selection that is not this trial's click) is
refused here, with a 400 and a message the client can show, and is never
stored. What is within range but not possible *now* (an undiscovered target,
a collective executing a move) stays a refusal from the simulation, logged
and shown in System Messages as before.

The commands' declarations (hcss.platform.live.commands) read their bodies
with these checks, once the door has found the trial, so a trial that has
ended or moved is answered as such whatever the body says. `ActionError` is
a command refused: a 4xx JSON answer, nothing written.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.models import Observation


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
