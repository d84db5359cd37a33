"""Token → participant → trial: the only way into a trial's stream and commands."""

from __future__ import annotations

from flask import abort, current_app, g
from sqlalchemy import select

from hcss.platform.db import database, get_session
from hcss.platform.models import Participant, Trial


def participant_for(token: str) -> Participant:
    participant = (
        get_session().scalars(select(Participant).where(Participant.token == token)).first()
    )
    if participant is None:
        abort(404)
    return participant


def trial_for(token: str, trial_id: int) -> Trial:
    """The trial, only if it belongs to the token's participant (else 404, revealing nothing).

    One query per request, remembered for the request: a keyed command asks
    in the idempotency wrapper and again in its view.

    The check is a read-only unit of work of its own, so its connection is
    back in the pool before the caller waits for the runner's or the trial's
    lock, whose holder may need a connection itself (a caller holding one
    while it waits could deadlock many streams opened at once until the pool
    timed out). The live API uses no request session at all.
    """
    checked: dict[tuple[str, int], Trial] = g.setdefault("checked_trials", {})
    trial = checked.get((token, trial_id))
    if trial is None:
        with database().session_scope() as session:
            trial = session.scalar(
                select(Trial)
                .join(Participant, Trial.participant_id == Participant.id)
                .where(Trial.id == trial_id, Participant.token == token)
            )
        if trial is None:
            abort(404)
        checked[(token, trial_id)] = trial
    return trial


def require_owner(token: str, trial_id: int) -> None:
    """404 unless the trial is the token's: in memory when this process holds it
    (`Runner.holds_for`, no query), else by `trial_for`."""
    if not current_app.extensions["hcss_live"].holds_for(token, trial_id):
        trial_for(token, trial_id)
