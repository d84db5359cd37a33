"""Token → participant → trial: the only way into a trial's stream and commands."""

from __future__ import annotations

import hmac

from flask import abort, current_app, g
from sqlalchemy import select

from hcss.platform.db import database, get_session
from hcss.platform.live.runner import Runner
from hcss.platform.live.session import RunningTrial
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


def held_trial(token: str, trial_id: int) -> RunningTrial | None:
    """The trial this process holds in memory, if it is the token's; None: ask `trial_for`.

    The live API's looks and commands come several times a second per trial;
    checking a held trial's owner in memory spares each of them a query and a
    transaction. A trial not held, or held for another token, goes the
    database's way, so every answer (404, 409) is the same either way.
    """
    live = runner().loaded(trial_id)
    if live is None or not hmac.compare_digest(live.participant_token.encode(), token.encode()):
        return None
    return live


def require_owner(token: str, trial_id: int) -> None:
    """404 unless the trial is the token's: in memory when this process holds it, else by query."""
    if held_trial(token, trial_id) is None:
        trial_for(token, trial_id)


def runner() -> Runner:
    return current_app.extensions["hcss_runner"]
