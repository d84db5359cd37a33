"""The console's replay pages: any recorded trial, live or finished, watched again.

Experimenters only (the console's login). The page is the Collective
Interface itself (the participant's template and drawing code, in replay
mode) with a timeline below it; its frames come from `frames` and its marks
from `timeline`. URLs name trials by id and never carry a participant token.
"""

from __future__ import annotations

from typing import Any

from flask import Blueprint, Flask, Response, abort, current_app, render_template, request
from flask.typing import ResponseReturnValue
from flask_login import login_required
from sqlalchemy import select

from hcss.platform.db import get_session
from hcss.platform.live.trials import latest_status
from hcss.platform.models import Participant, Trial
from hcss.platform.replay.frames import MAX_CHUNK, ReplayCache
from hcss.platform.replay.timeline import timeline
from hcss.simulation import Params
from hcss.simulation.messages import collective_names

bp = Blueprint("replay", __name__, url_prefix="/console/trials")

MAX_ID = 2**31 - 1  # a database integer; larger ids name no trial
#: The trial-seconds per wall-second the page offers.
SPEEDS = (1, 2, 5, 10, 20)


@bp.record_once
def _init_cache(state: Any) -> None:
    app: Flask = state.app
    app.extensions["hcss_replays"] = ReplayCache()


@bp.app_template_global()
def recorded_trials(participant: Participant) -> list[dict[str, Any]]:
    """The participant's trials for the console's participant page, oldest first."""
    session = get_session()
    trials = session.scalars(
        select(Trial).where(Trial.participant_id == participant.id).order_by(Trial.id)
    )
    return [{"trial": t, "status": latest_status(session, t.id) or "?"} for t in trials]


def _trial(trial_id: int) -> Trial:
    trial = get_session().get(Trial, trial_id) if 0 < trial_id <= MAX_ID else None
    if trial is None:
        abort(404)
    return trial


def _dt(trial: Trial) -> float:
    params = Params.from_dict(trial.params) if trial.params else Params()
    return float(params.dt_s)


@bp.get("/<int:trial_id>/replay")
@login_required
def page(trial_id: int) -> str:
    trial = _trial(trial_id)
    return render_template(
        "replay/replay.html",
        trial=trial,
        participant=get_session().get(Participant, trial.participant_id),
        recorded_status=latest_status(get_session(), trial.id),
        # The live template builds its API URLs from a token; the replay page
        # sends nothing, and a token no participant has keeps it that way.
        token="replay",
        status="replay",
        speeds=SPEEDS,
        max_chunk=MAX_CHUNK,
        collective_names=collective_names(),
    )


@bp.get("/<int:trial_id>/replay/timeline")
@login_required
def timeline_json(trial_id: int) -> ResponseReturnValue:
    trial = _trial(trial_id)
    return current_app.json.response(timeline(get_session(), trial, _dt(trial)))


@bp.get("/<int:trial_id>/replay/frames")
@login_required
def frames_json(trial_id: int) -> ResponseReturnValue:
    trial = _trial(trial_id)
    start = _bounded_int("start", 0)
    count = _bounded_int("count", MAX_CHUNK)
    for refusal in (start, count):
        if isinstance(refusal, str):
            return current_app.json.response(error="bad_request", message=refusal), 400
    assert isinstance(start, int) and isinstance(count, int)
    body = current_app.extensions["hcss_replays"].chunk(get_session(), trial, start, count)
    return Response(body, mimetype="application/json")


def _bounded_int(name: str, default: int) -> int | str:
    """A query parameter that is a whole number 0..2**31-1, or the message refusing it."""
    raw = request.args.get(name)
    if raw is None:
        return default
    if not (raw.isascii() and raw.isdigit()) or len(raw) > 10 or int(raw) > MAX_ID:
        return f"'{name}' must be a whole number from 0 to {MAX_ID}"
    return int(raw)
