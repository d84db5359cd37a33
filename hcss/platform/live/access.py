"""Token → participant → trial: the only way into a trial's stream and commands."""

from __future__ import annotations

from flask import abort, current_app
from sqlalchemy import select

from hcss.platform.db import get_session, hand_back_connection
from hcss.platform.live.runner import Runner
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

    The check only reads, and its connection goes back to the pool here: the
    caller then waits for the runner's or the trial's lock, whose holder may
    need a connection itself. Holding one while waiting deadlocked 200 streams
    opened at once (each held a connection, the loader of their trials waited
    for one) until the pool timed out.
    """
    participant = participant_for(token)
    trial = get_session().get(Trial, trial_id)
    if trial is None or trial.participant_id != participant.id:
        abort(404)
    hand_back_connection()
    return trial


def runner() -> Runner:
    return current_app.extensions["hcss_runner"]
