"""The live trial's JSON API: the state stream and the participant's actions.

Every route is under the participant's token and checks that the trial is
theirs. Every POST is CSRF-protected (X-CSRFToken header, from the page's
meta tag) and idempotent when it carries an Idempotency-Key header
(hcss.platform.live.idempotency). Bad input gets a JSON error and changes nothing.
"""

from __future__ import annotations

from typing import Any

from flask import Blueprint, Response, current_app, jsonify, request
from sqlalchemy import select

from hcss.platform.db import database, get_session
from hcss.platform.live import actions
from hcss.platform.live.access import runner, trial_for
from hcss.platform.live.idempotency import idempotent
from hcss.platform.live.session import LiveTrial
from hcss.platform.live.stream import ended_stream, event_stream
from hcss.platform.models import COMMAND_KINDS, Observation

bp = Blueprint("api", __name__, url_prefix="/api/live/<token>/trials/<int:trial_id>")


@bp.errorhandler(actions.ActionError)
def _action_error(error: actions.ActionError):  # type: ignore[no-untyped-def]
    return jsonify(error=error.code, message=error.message), error.status


def _live(token: str, trial_id: int) -> LiveTrial:
    trial = trial_for(token, trial_id)
    live = runner().get(trial.id)
    if live is None:
        raise actions.ActionError("the trial has ended", 409, "ended")
    return live


def _body() -> dict[str, Any]:
    body = request.get_json(silent=True)
    if not isinstance(body, dict):
        raise actions.ActionError("send a JSON object (Content-Type: application/json)")
    return body


def _int_field(body: dict[str, Any], name: str, *, required: bool = True) -> int | None:
    value = body.get(name)
    if value is None and not required:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise actions.ActionError(f"'{name}' must be a non-negative integer")
    return value


@bp.get("/stream")
def stream(token: str, trial_id: int) -> Response:
    trial = trial_for(token, trial_id)
    live = runner().get(trial.id)
    headers = {"Cache-Control": "no-cache", "X-Accel-Buffering": "no"}
    if live is None:
        body = ended_stream(trial.id, trial.duration_s)
    else:
        last = request.headers.get("Last-Event-ID", request.args.get("after", "0"))
        body = event_stream(
            live,
            after_seq=int(last) if last.isdigit() else 0,
            interval_s=float(current_app.config["STREAM_INTERVAL_S"]),
            max_s=float(current_app.config["STREAM_MAX_S"]),
            clock=runner().clock,
        )
    return Response(body, mimetype="text/event-stream", headers=headers)


@bp.get("/state")
def state(token: str, trial_id: int) -> Response:
    """One frame of the stream as plain JSON, for bots and scripts."""
    live = _live(token, trial_id)
    with live.lock:
        text, _ = live.frame(runner().clock(), 0)
    return Response(text, mimetype="application/json")


@bp.post("/requests")
@idempotent
def submit_request(token: str, trial_id: int):  # type: ignore[no-untyped-def]
    live = _live(token, trial_id)
    body = _body()
    kind = body.get("kind")
    if kind not in COMMAND_KINDS:
        raise actions.ActionError(f"'kind' must be one of {', '.join(COMMAND_KINDS)}")
    if kind == "cancel":
        request_input = actions.RequestInput(kind, request_id=_int_field(body, "request_id"))
    else:
        request_input = actions.RequestInput(
            kind,
            collective=_int_field(body, "collective"),
            target=_int_field(body, "target"),
            selections=_selections(body, trial_id),
        )
    outcome = actions.submit_request(database(), live, request_input)
    return jsonify(outcome), 200


def _selections(body: dict[str, Any], trial_id: int) -> tuple[int, ...]:
    """Observation ids of the clicks that filled the form; they must be this trial's."""
    ids = body.get("selections", [])
    if not isinstance(ids, list) or any(isinstance(i, bool) or not isinstance(i, int) for i in ids):
        raise actions.ActionError("'selections' must be a list of observation ids")
    if ids:
        found = set(
            get_session().scalars(
                select(Observation.id).where(
                    Observation.id.in_(ids), Observation.trial_id == trial_id
                )
            )
        )
        if found != set(ids):
            raise actions.ActionError("'selections' names observations of another trial")
    return tuple(ids)


@bp.post("/observations")
@idempotent
def observe(token: str, trial_id: int):  # type: ignore[no-untyped-def]
    live = _live(token, trial_id)
    body = _body()
    kind, button = body.get("kind"), body.get("button")
    if kind not in ("collective", "target"):
        raise actions.ActionError("'kind' must be 'collective' or 'target'")
    if button not in ("left", "right"):
        raise actions.ActionError("'button' must be 'left' or 'right'")
    observation_id = actions.record_observation(
        database(),
        live,
        kind=kind,
        collective=_int_field(body, "collective", required=kind == "collective"),
        target=_int_field(body, "target", required=kind == "target"),
        button=button,
    )
    return jsonify(observation_id=observation_id), 201


@bp.post("/probes/<int:probe_id>/ready")
@idempotent
def probe_ready(token: str, trial_id: int, probe_id: int):  # type: ignore[no-untyped-def]
    live = _live(token, trial_id)
    actions.probe_ready(database(), live, probe_id, now=runner().clock())
    return jsonify(ok=True)


@bp.post("/probes/<int:probe_id>/answer")
@idempotent
def probe_answer(token: str, trial_id: int, probe_id: int):  # type: ignore[no-untyped-def]
    live = _live(token, trial_id)
    answer = _body().get("answer")
    if not isinstance(answer, str):
        raise actions.ActionError("'answer' must be one of the choices, as a string")
    actions.probe_answer(database(), live, probe_id, answer, now=runner().clock())
    return jsonify(ok=True)
