"""The live trial's JSON API: the state stream and the participant's actions.

Every route is under the participant's token and checks that the trial is
theirs. Every POST is CSRF-protected (X-CSRFToken header, from the page's
meta tag) and idempotent when it carries an Idempotency-Key header
(hcss.platform.live.idempotency). Bad input gets a JSON error and changes nothing.
"""

from __future__ import annotations

import re
from typing import Any

from flask import Blueprint, Response, current_app, jsonify, request

from hcss.platform.db import database
from hcss.platform.live import actions, validation
from hcss.platform.live.access import held_trial, runner, study_of, trial_for
from hcss.platform.live.idempotency import idempotent
from hcss.platform.live.session import RunningTrial
from hcss.platform.live.stream import ended_stream, event_stream
from hcss.platform.live.streams import RETRY_AFTER_S, StreamSlots, client_share, study_share
from hcss.platform.live.trials import end_reason
from hcss.platform.models import CommandKey

_POSITION = re.compile(r"[0-9]{1,18}")

bp = Blueprint("api", __name__, url_prefix="/api/live/<token>/trials/<int:trial_id>")


@bp.errorhandler(actions.ActionError)
def _action_error(error: actions.ActionError):
    # A trial that moved to another server process holds the command back: the page retries.
    held = {"held_by": "server"} if error.code == "moved" else {}
    response = jsonify(error=error.code, message=error.message, **held)
    if error.status == 503:
        response.headers["Retry-After"] = str(RETRY_AFTER_S)
    return response, error.status


def stream_slots() -> StreamSlots:
    """The app's stream allowance (made on first use from MAX_STREAMS, STREAMS_PER_TOKEN,
    STREAMS_PER_CLIENT, STREAMS_PER_STUDY)."""
    slots = current_app.extensions.get("hcss_streams")
    if slots is None:
        config = current_app.config
        ceiling = config.get("MAX_STREAMS")
        per_client = config.get("STREAMS_PER_CLIENT") or client_share(ceiling)
        per_study = config.get("STREAMS_PER_STUDY") or study_share(ceiling)
        slots = current_app.extensions.setdefault(
            "hcss_streams",
            StreamSlots(ceiling, int(config.get("STREAMS_PER_TOKEN", 1)), per_client, per_study),
        )
    return slots


def _live(token: str, trial_id: int) -> RunningTrial:
    live = held_trial(token, trial_id) or runner().get(trial_for(token, trial_id).id)
    if live is None:
        raise actions.ActionError("the trial has ended", 409, "ended")
    return live


def _body() -> dict[str, Any]:
    body = request.get_json(silent=True)
    if not isinstance(body, dict):
        raise actions.ActionError("send a JSON object (Content-Type: application/json)")
    return body


def stream_position(text: str) -> int:
    """The message number a reconnecting stream resumes after; 0 for anything but a plain number.

    ``str.isdigit`` accepts "²" and 5,000-digit strings, which ``int`` then
    refuses; a position is at most 18 ASCII digits.
    """
    return int(text) if _POSITION.fullmatch(text) else 0


@bp.get("/stream")
def stream(token: str, trial_id: int) -> Response:
    trial = trial_for(token, trial_id)
    live = runner().get(trial.id)
    headers = {"Cache-Control": "no-cache", "X-Accel-Buffering": "no"}
    if live is None:
        with database().session_scope() as session:
            reason = end_reason(session, trial.id)
        return Response(
            ended_stream(trial.id, trial.duration_s, reason),
            mimetype="text/event-stream",
            headers=headers,
        )
    slots = stream_slots()
    ticket = slots.acquire(token, request.remote_addr or "?", study_of(trial.participant_id))
    if ticket is None:
        raise actions.ActionError(
            "the server has as many live streams as it can hold; retrying shortly",
            503,
            "busy",
        )
    with live.changed:
        live.changed.notify_all()  # an older stream of this link wakes up and hands over
    last = request.headers.get("Last-Event-ID", request.args.get("after", "0"))
    body = event_stream(
        live,
        after_seq=stream_position(last),
        interval_s=float(current_app.config["STREAM_INTERVAL_S"]),
        max_s=float(current_app.config["STREAM_MAX_S"]),
        clock=runner().clock,
        superseded=lambda: slots.superseded(ticket),
    )
    response = Response(body, mimetype="text/event-stream", headers=headers)
    response.call_on_close(lambda: slots.release(ticket))
    return response


@bp.get("/state")
def state(token: str, trial_id: int) -> Response:
    """One frame of the stream as plain JSON, for bots and scripts."""
    live = _live(token, trial_id)
    with live.lock:
        text, _ = live.frame(runner().clock(), 0)
    return Response(text, mimetype="application/json")


@bp.post("/requests")
@idempotent
def submit_request(token: str, trial_id: int, key: CommandKey | None):
    live = _live(token, trial_id)
    with database().session_scope() as session:  # read-only: back in the pool before the lock
        command, selections = validation.parse_request(
            request.get_json(silent=True), live, session, trial_id
        )
    answer = actions.submit_request(database(), live, command, selections, key=key)
    return jsonify(answer), 200


@bp.post("/observations")
@idempotent
def observe(token: str, trial_id: int, key: CommandKey | None):
    live = _live(token, trial_id)
    body = _body()
    kind, button = body.get("kind"), body.get("button")
    collectives, targets, _ = validation.trial_ranges(live)
    if kind not in ("collective", "target"):
        raise actions.ActionError("'kind' must be 'collective' or 'target'")
    if button not in ("left", "right"):
        raise actions.ActionError("'button' must be 'left' or 'right'")
    answer = actions.record_observation(
        database(),
        live,
        kind=kind,
        collective=_clicked(body, "collective", kind, collectives - 1, low=0),
        target=_clicked(body, "target", kind, targets, low=1),
        button=button,
        key=key,
    )
    return jsonify(answer), 201


def _clicked(body: dict[str, Any], name: str, kind: str, high: int, *, low: int) -> int | None:
    """The clicked collective or target: required for its own kind, optional otherwise."""
    value = body.get(name)
    if value is None and kind != name:
        return None
    return validation.bounded_int(value, name, low, high)


@bp.post("/probes/<int:probe_id>/ready")
@idempotent
def probe_ready(token: str, trial_id: int, probe_id: int, key: CommandKey | None):
    live = _live(token, trial_id)
    answer = actions.probe_ready(database(), live, probe_id, now=runner().clock(), key=key)
    return jsonify(answer)


@bp.post("/probes/<int:probe_id>/answer")
@idempotent
def probe_answer(token: str, trial_id: int, probe_id: int, key: CommandKey | None):
    live = _live(token, trial_id)
    answer = _body().get("answer")
    if not isinstance(answer, str):
        raise actions.ActionError("'answer' must be one of the choices, as a string")
    reply = actions.probe_answer(database(), live, probe_id, answer, now=runner().clock(), key=key)
    return jsonify(reply)
