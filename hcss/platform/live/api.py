"""The live trial's JSON API: the state stream and the participant's actions.

Every route is under the participant's token and checks that the trial is
theirs. A route parses HTTP (the JSON body, the headers) and hands the plain
values to the live service: a command as a value to its one door
(`door.carry_out`), which finds the trial, takes its lock, checks, applies,
writes and answers; the stream to `frames.open_stream`. It never holds the
trial itself. Every POST is CSRF-protected (X-CSRFToken header, from the page's
meta tag) and carries an Idempotency-Key header, without which it is refused
(hcss.platform.live.idempotency). Bad input gets a JSON error and changes nothing.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from flask import Blueprint, Response, current_app, jsonify, request

from hcss.platform.guards.clients import request_client
from hcss.platform.live.access import require_owner, trial_for
from hcss.platform.live.commands import COMMANDS, ActionError, Declaration
from hcss.platform.live.door import Answer, refusal
from hcss.platform.live.idempotency import idempotent
from hcss.platform.live.service import live_trials
from hcss.platform.live.stream_slots import RETRY_AFTER_S, StreamSlots, client_share, study_share

if TYPE_CHECKING:
    from hcss.platform.live.trial_writer import KeyedCommand

_POSITION = re.compile(r"[0-9]{1,18}")

bp = Blueprint("api", __name__, url_prefix="/api/live/<token>/trials/<int:trial_id>")


@bp.errorhandler(ActionError)
def _action_error(error: ActionError) -> Response:
    """An input refused before the door (a malformed key, a full server's stream)."""
    return _response(refusal(error))


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
            StreamSlots(
                ceiling,
                int(config.get("STREAMS_PER_TOKEN", 1)),
                per_client,
                per_study,
                # A share set by hand (a lab on one address) keeps no reserve for the few.
                reserve_for_few=not config.get("STREAMS_PER_CLIENT"),
            ),
        )
    return slots


def stream_position(text: str) -> int:
    """The message number a reconnecting stream resumes after; 0 for anything but a plain number.

    ``str.isdigit`` accepts "²" and 5,000-digit strings, which ``int`` then
    refuses; a position is at most 18 ASCII digits.
    """
    return int(text) if _POSITION.fullmatch(text) else 0


@bp.get("/stream")
def stream(token: str, trial_id: int) -> Response:
    trial = trial_for(token, trial_id)
    last = request.headers.get("Last-Event-ID", request.args.get("after", "0"))
    opened = live_trials().open_stream(
        stream_slots(),
        trial,
        token=token,
        client=request_client(),  # the address's prefix: an IPv6 /64 is one client
        after_seq=stream_position(last),
        interval_s=float(current_app.config["STREAM_INTERVAL_S"]),
        max_s=float(current_app.config["STREAM_MAX_S"]),
    )
    response = Response(
        opened.frames,
        mimetype="text/event-stream",
        headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"},
    )
    response.call_on_close(opened.closed)
    return response


@bp.get("/state")
def state(token: str, trial_id: int) -> Response:
    """One frame of the stream as plain JSON, for bots and scripts."""
    require_owner(token, trial_id)
    return Response(live_trials().frame(trial_id), mimetype="application/json")


def _command_view(declared: Declaration[Any, Any]) -> Callable[..., Response]:
    """The route of one participant command: its value made from the route's values and the
    body, carried out by the live service with the request's key."""

    def view(token: str, trial_id: int, key: KeyedCommand, **values: Any) -> Response:
        command = declared.make(trial_id, values, _json())
        return _response(live_trials().carry_out(command, key))

    return view


# One route per command declaration (hcss.platform.live.commands), each idempotent.
for _declared in COMMANDS.values():
    bp.add_url_rule(
        _declared.route,
        endpoint=_declared.endpoint,
        view_func=idempotent(_command_view(_declared)),
        methods=["POST"],
    )


def _response(answer: Answer) -> Response:
    """The live service's answer as the page gets it (a repeat of a keyed command says so;
    a 503, a trial moving to another process, says when to try again)."""
    response = jsonify(answer.body)
    response.status_code = answer.status
    if answer.replayed:
        response.headers["Idempotent-Replayed"] = "true"
    if answer.status == 503:
        response.headers["Retry-After"] = str(RETRY_AFTER_S)
    return response


def _json() -> Any:
    """The POST body parsed as JSON; None when it is not JSON (the command says what to send)."""
    return request.get_json(silent=True)
