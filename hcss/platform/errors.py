"""Error pages for people, in the study's look, each saying what to do next.

API routes keep their JSON errors (hcss.platform.app). A page under a
participant's link (``/p/<token>``, ``/live/<token>``) offers the way back to
their current page. A 500 or 503 says pages finished earlier are kept, which is
true (every answer is committed when its page is submitted), and that the page
just sent may ask again: its request may not have been stored.
"""

from __future__ import annotations

from flask import Response, render_template, request, url_for
from flask.globals import request_ctx
from flask.typing import ResponseReturnValue
from sqlalchemy import select
from werkzeug.exceptions import HTTPException

ADVICE = {
    400: (
        "This page could not be sent",
        "The page was probably open for a long time, or your browser blocked cookies. "
        "Nothing was changed. Go to your current page and try again.",
    ),
    404: (
        "Page not found",
        "This address does not lead to a page of the study. If you typed or copied your "
        "link, check that it is complete; otherwise ask the experimenter for your link.",
    ),
    405: (
        "This page cannot be opened like that",
        "Nothing was changed. Go to your current page to carry on.",
    ),
    429: (
        "Too many sign-ups from your network",
        "Nothing was changed. Please wait a few minutes and open the study link again.",
    ),
    503: (
        "Please wait a moment",
        "The study's database is not answering just now. Please wait: this page tries "
        "again by itself in a few seconds. "
        "Pages you finished earlier are saved; the page you had just sent may ask for its answers again.",
    ),
    500: (
        "Something went wrong on our side",
        "Pages you finished earlier are saved; the page you had just sent may ask for its answers again. Please wait a moment and go to your current page; "
        "if this happens again, tell the experimenter.",
    ),
}


def participant_token() -> str | None:
    """The token in the address, when it is a real participant's link (else None)."""
    token = (request.view_args or {}).get("token")
    if not isinstance(token, str):
        parts = request.path.split("/")
        token = parts[2] if len(parts) >= 3 and parts[1] in ("p", "live") else None
    if not token or len(token) > 128:
        return None
    try:
        from hcss.platform.db import get_session
        from hcss.platform.models import Participant

        session = get_session()
        session.rollback()  # the request may have failed mid-transaction
        found = session.scalar(select(Participant.id).where(Participant.token == token))
    except Exception:  # noqa: BLE001 - the database itself may be what failed: offer no link
        return None
    return token if found is not None else None


#: Seconds a client is asked to wait before trying again while the database is away.
DATABASE_RETRY_S = 5


#: SQLSTATEs after which the database cannot be used just now, though the driver calls them
#: no OperationalError: a write in a read-only transaction (25006: a standby, or
#: default_transaction_read_only, raised as an InternalError), a transaction the server
#: ended for idling (25P03, and the connection with it), a server shutting down or starting
#: (57P01-57P03), too many connections (53300), a full disk (53100).
AWAY_SQLSTATES = frozenset({"25006", "25P03", "57P01", "57P02", "57P03", "53300", "53100"})
#: SQLSTATE classes of a lost connection (08: connection exception).
AWAY_CLASSES = ("08",)


def database_away(error: BaseException | None) -> bool:
    """Whether an exception means the database cannot be used just now (not a bug):
    unreachable, restarting, read-only, full, locked, its pool exhausted, or the connection
    closed by the server (a transaction idle too long)."""
    from sqlalchemy.exc import DBAPIError, InterfaceError, OperationalError
    from sqlalchemy.exc import TimeoutError as PoolTimeout

    if isinstance(error, OperationalError | InterfaceError | PoolTimeout):
        return True
    if not isinstance(error, DBAPIError):
        return False
    if error.connection_invalidated:
        return True
    sqlstate = getattr(error.orig, "sqlstate", None) or ""
    return sqlstate in AWAY_SQLSTATES or sqlstate.startswith(AWAY_CLASSES)


def database_unavailable_page(error: BaseException | None = None) -> ResponseReturnValue:
    """503 with Retry-After: JSON for the API (the bots and the page retry), else a
    "please wait" page that reloads itself. Logged as one line (`log_database_away`)."""
    from flask import g, jsonify

    log_database_away(error)
    failed = g.get("db_session")
    if failed is not None:
        failed.rollback()  # its transaction failed with the connection: none of it is kept
    headers = {"Retry-After": str(DATABASE_RETRY_S)}
    if request.path.startswith("/api/"):
        body = jsonify(error="database_unavailable", message=ADVICE[503][1], held_by="database")
        return body, 503, headers
    page = error_page(503, retry_after=DATABASE_RETRY_S)
    if isinstance(page, Response):
        page.headers.update(headers)
        return page
    return page[0], 503, headers


def log_database_away(error: BaseException | None) -> None:
    """One WARNING line for a request the database refused (an outage, expected), never a
    traceback, so the log tells an outage from a bug; the driver's first line says why."""
    from flask import current_app

    cause = getattr(error, "orig", None) or error
    words = str(cause).strip().splitlines()[0][:200] if cause is not None else "unknown"
    current_app.logger.warning(
        "database away on %s %s: %s: %s",
        request.method,
        request.path[:200],
        type(cause).__name__,
        words,
    )


def error_page(
    code: int, description: str | None = None, *, retry_after: int | None = None
) -> tuple[str, int] | Response:
    title, advice = ADVICE.get(code, ADVICE[500] if code >= 500 else ADVICE[400])
    if request_ctx.url_adapter is None:
        # The request could not be bound to this server (a Host header that is no
        # hostname): no URL can be built, so no page with links; plain text says it.
        return Response(f"{title}\n\n{advice}\n", code, mimetype="text/plain")
    token = participant_token()
    _user_without_the_database()
    return (
        render_template(
            "error.html",
            code=code,
            heading=title,
            detail=description,
            advice=advice,
            current_url=url_for("study.enter", token=token) if token else None,
            retry_after=retry_after,
        ),
        code,
    )


def _user_without_the_database() -> None:
    """Let the page's templates know who is signed in, or take them for anonymous when the
    database cannot say: an error page must not need the database that may have failed.

    Flask-Login loads the experimenter for every template (`current_user`); while the
    database is away that query fails again inside the error handler, and the please-wait
    page became a 500.
    """
    from flask import current_app, g
    from flask_login import current_user

    manager = getattr(current_app, "login_manager", None)
    if manager is None or "_login_user" in g:
        return
    try:
        current_user._get_current_object()  # loads it into g._login_user
    except Exception as error:
        if not database_away(error):
            raise
        from hcss.platform.db import get_session

        get_session().rollback()
        g._login_user = manager.anonymous_user()


def http_error_page(error: HTTPException) -> tuple[str, int] | Response:
    """An HTTP error as a page; a custom description (e.g. a bad link) is shown too."""
    code = error.code or 500
    default = type(error).description
    custom = error.description if error.description and error.description != default else None
    return error_page(code, custom)
