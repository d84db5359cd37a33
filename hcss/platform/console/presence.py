"""Heartbeats from the participant's pages, so the console can say who is connected.

Every participant page (stage pages and the Collective Interface) loads
``static/heartbeat.js``, which POSTs ``/p/<token>/heartbeat`` on load, every
`HEARTBEAT_EVERY_S` seconds and whenever the tab is hidden or shown again.
The route answers 204 and overwrites the participant's one
`ParticipantPresence` row (operational state, not study data; see
hcss/platform/models/presence.py). A participant is *connected* while the
last heartbeat is younger than `CONNECTED_WITHIN_S`: three missed beats,
so one slow request does not flip the console.

The route is exempt from CSRF: it is keyed by the participant's secret token,
changes no study data, and must keep working on a page left open for hours.
Anything else than a short JSON object with the fields below is a 400, an
unknown or malformed token a 404, a database that is busy a 503; never a 500.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from typing import Any

from flask import Blueprint, Response, abort, current_app, jsonify, request
from sqlalchemy import select
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session

from hcss.platform.db import get_session
from hcss.platform.errors import DATABASE_RETRY_S
from hcss.platform.guards.hardening import takes_json
from hcss.platform.live.service import live_trials
from hcss.platform.models import Participant, ParticipantPresence, StageEvent

HEARTBEAT_EVERY_S = 10.0
CONNECTED_WITHIN_S = 3 * HEARTBEAT_EVERY_S
PAGES = ("study", "trial")
MAX_BODY_BYTES = 256
TOKEN = re.compile(r"[A-Za-z0-9_-]{1,64}")
STEP = re.compile(r"[a-z0-9_]{1,32}")

bp = Blueprint("presence", __name__, url_prefix="/p")


def _csrf_exempt(state: Any) -> None:
    state.app.extensions["csrf"].exempt(heartbeat)


bp.record_once(_csrf_exempt)


def _body() -> dict[str, Any]:
    """The heartbeat's fields (page, hidden), checked; 400/413 for anything else."""
    if request.content_length is not None and request.content_length > MAX_BODY_BYTES:
        abort(413)
    raw = request.stream.read(MAX_BODY_BYTES + 1)
    if len(raw) > MAX_BODY_BYTES:
        abort(413)
    if not raw.strip():
        return {"page": "study", "hidden": False, "stage": None, "step": None}
    try:
        body = json.loads(raw)
    except (ValueError, RecursionError):
        abort(400, "the heartbeat body is not JSON")
    shape = (
        'the heartbeat body is {"page": "study"|"trial", "hidden": true|false}, and on a '
        'study page the step it shows: "stage": 0-999, "step": "page_2"'
    )
    if not isinstance(body, dict) or set(body) - {"page", "hidden", "stage", "step"}:
        abort(400, shape)
    page, hidden = body.get("page", "study"), body.get("hidden", False)
    if page not in PAGES or not isinstance(hidden, bool):
        abort(400, shape)
    stage, step = body.get("stage"), body.get("step")
    if (stage is None) != (step is None) or (
        stage is not None
        and not (
            isinstance(stage, int)
            and not isinstance(stage, bool)
            and 0 <= stage < 1000
            and isinstance(step, str)
            and STEP.fullmatch(step)
        )
    ):
        abort(400, shape)
    return {"page": page, "hidden": hidden, "stage": stage, "step": step}


def record_heartbeat(
    session: Session, participant_id: int, now: float, page: str, hidden: bool
) -> None:
    """Insert or overwrite the participant's presence row in one statement (no race)."""
    values = {
        "participant_id": participant_id,
        "last_seen_epoch": now,
        "page": page,
        "hidden": hidden,
    }
    dialect = session.get_bind().dialect.name
    upserts: dict[str, Callable[..., postgresql.Insert | sqlite.Insert]] = {
        "postgresql": postgresql.insert,
        "sqlite": sqlite.insert,
    }
    insert = upserts.get(dialect)
    if insert is None:  # another database: read, then write
        row = session.get(ParticipantPresence, participant_id)
        if row is None:
            session.add(ParticipantPresence(**values))
        else:
            row.last_seen_epoch, row.page, row.hidden = now, page, hidden
        session.flush()
        return
    statement = insert(ParticipantPresence).values(**values)
    session.execute(
        statement.on_conflict_do_update(
            index_elements=["participant_id"],
            set_={"last_seen_epoch": now, "page": page, "hidden": hidden},
        )
    )


@bp.post("/<token>/heartbeat")
@takes_json
def heartbeat(token: str) -> Response:
    if not TOKEN.fullmatch(token):
        abort(404)
    body = _body()
    session = get_session()
    try:
        participant_id = session.scalar(select(Participant.id).where(Participant.token == token))
        if participant_id is None:
            abort(404)
        now = live_trials().now()
        record_heartbeat(session, participant_id, now, body["page"], body["hidden"])
        session.commit()
        moved = body["stage"] is not None and _skipped(
            session, participant_id, body["stage"], body["step"]
        )
    except SQLAlchemyError:
        session.rollback()
        current_app.logger.warning("heartbeat not stored (database busy)", exc_info=True)
        return Response(
            "the database is busy or away; the next heartbeat will tell",
            status=503,
            mimetype="text/plain",
            headers={"Retry-After": str(DATABASE_RETRY_S)},
        )
    if moved:  # the page shows a step the experimenter skipped: it moves on (heartbeat.js)
        return jsonify({"moved_on": True})
    return Response(status=204)


def _skipped(session: Session, participant_id: int, stage: int, step: str) -> bool:
    """Whether the experimenter skipped this step (hcss.platform.console.skipping)."""
    return (
        session.scalar(
            select(StageEvent.id).where(
                StageEvent.participant_id == participant_id,
                StageEvent.stage_index == stage,
                StageEvent.step == step,
                StageEvent.kind == "skipped",
            )
        )
        is not None
    )


def presence_by_participant(
    session: Session, ids: list[int] | None = None
) -> dict[int, ParticipantPresence]:
    """Each participant's heartbeat row; only those of `ids` when given (a page of the table)."""
    query = select(ParticipantPresence)
    if ids is not None:
        query = query.where(ParticipantPresence.participant_id.in_(ids))
    return {row.participant_id: row for row in session.scalars(query)}
