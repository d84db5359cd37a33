"""What every request passes through before any view sees it: bounds on what a client can send.

Some inputs would fail in every view alike: ids too large for the database's
integer columns, NUL bytes PostgreSQL refuses in text, JSON nested deeper
than Python's recursion limit, and bodies of any size. Each is answered here
with a 4xx and no database work:

- ``<int:...>`` URL parts accept only what an INTEGER column can hold (else 404);
- a NUL byte in the path, the query or a form field is a 400, and so is a form
  field whose name werkzeug cannot read (multipart ``name="\\"``);
- JSON nested too deeply is bad JSON (``get_json(silent=True)`` gives None);
- a body over ``MAX_CONTENT_LENGTH`` is a 413 before it is read;
- a JSON body to a page (not ``/api/``, nor a view marked `takes_json`) is a 415:
  pages take forms.

Every answer also carries the security headers (CSP, frame-ancestors, nosniff),
and every answer but a static file ``Cache-Control: no-store``. A page refuses
to be framed and posts forms only to this origin, unless its view widens that
for this one answer (`allow_framing_by`, `allow_form_action_to`): an MTurk study's
link is framed by MTurk, and its debrief posts the assignment to MTurk.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from flask import Flask, Response, abort, current_app, g, request
from flask.json.provider import DefaultJSONProvider
from flask.sessions import SecureCookieSessionInterface
from werkzeug.routing import IntegerConverter

#: The largest id PostgreSQL's INTEGER (and so every id column) can hold.
MAX_ID = 2**31 - 1


class IdConverter(IntegerConverter):
    """``<int:...>`` that matches only 0..2**31-1, so a huge id is a 404, never an OverflowError."""

    def __init__(self, map: Any, *args: Any, **kwargs: Any) -> None:  # noqa: A002 - werkzeug's name
        kwargs.setdefault("max", MAX_ID)
        super().__init__(map, *args, **kwargs)


class BoundedJSONProvider(DefaultJSONProvider):
    """JSON nested past Python's recursion limit is invalid JSON, not a RecursionError."""

    def loads(self, s: str | bytes, **kwargs: Any) -> Any:
        try:
            return super().loads(s, **kwargs)
        except RecursionError as error:
            raise ValueError("JSON nested too deeply") from error


class SchemeSecureSessions(SecureCookieSessionInterface):
    """The session cookie is Secure whenever the request came over HTTPS.

    Behind the reverse proxy the scheme is the one the proxy reports (ProxyFix,
    ``PROXY_HOPS``), so a TLS deployment gets Secure cookies without a setting;
    ``SESSION_COOKIE_SECURE`` still forces them on a plain-HTTP hop.
    """

    def get_cookie_secure(self, app: Flask) -> bool:
        return bool(app.config["SESSION_COOKIE_SECURE"]) or (
            bool(request) and request.scheme == "https"
        )


def takes_json(view: Any) -> Any:
    """Mark a view outside ``/api/`` that reads a JSON body itself (the page heartbeat)."""
    view.takes_json = True
    return view


def _refuse_json_to_pages() -> None:
    """Pages take forms; Flask-WTF would read a JSON body as the form and fail on non-objects."""
    if request.method != "POST" or not request.is_json or request.path.startswith("/api/"):
        return
    if request.routing_exception is not None:
        return  # no such page: its 404 or 405 says more than a 415
    view = current_app.view_functions.get(request.endpoint or "")
    if not getattr(view, "takes_json", False):
        abort(415, description="This page takes a form, not JSON.")


def _refuse_nul_bytes() -> None:
    """PostgreSQL cannot store or even compare text with NUL; no real input has one."""
    if "\x00" in request.path:
        abort(404)
    for values in (request.args, request.form if request.method == "POST" else None):
        if values is None:
            continue
        for key, value in values.items(multi=True):
            if not isinstance(key, str) or not isinstance(value, str):
                # werkzeug parses a multipart name it cannot read (``name="\\"``) to None
                abort(400, description="A form field has no readable name.")
            if "\x00" in key or "\x00" in value:
                abort(400, description="A field contains a NUL byte.")


def _refuse_file_parts() -> None:
    """No page takes a file: a field sent as a multipart file part is a bad request, on
    every form at once. Flask-WTF reads the files with the form, and a validator that
    measured the field (``Length``) met a FileStorage: the sign-in page answered 500."""
    if request.method == "POST" and request.files:
        abort(400, description="No page of the study takes a file.")


def content_security_policy(
    frame_ancestors: Iterable[str] = (), form_action: Iterable[str] = ()
) -> str:
    """Everything from this origin only: no inline script or style (the pages have none),
    no plugins; framed by no one and forms posted only here unless origins are given."""
    ancestors = " ".join(frame_ancestors) or "'none'"
    actions = " ".join(("'self'", *form_action))
    return (
        "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
        f"connect-src 'self'; form-action {actions}; frame-ancestors {ancestors}; "
        "base-uri 'none'; object-src 'none'"
    )


CONTENT_SECURITY_POLICY = content_security_policy()
SECURITY_HEADERS = {
    "Content-Security-Policy": CONTENT_SECURITY_POLICY,
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",  # frame-ancestors for browsers without CSP 2
    # Participant links carry their token in the path: never send it to another site.
    "Referrer-Policy": "no-referrer",
}


def allow_framing_by(origins: Iterable[str]) -> None:
    """This answer may be shown in a frame of these origins (and no other), not DENY."""
    g.frame_ancestors = tuple(origins)


def allow_form_action_to(origins: Iterable[str]) -> None:
    """This answer's forms may post to these origins besides this one."""
    g.form_action = tuple(origins)


def _security_headers(response: Response) -> Response:
    ancestors = g.get("frame_ancestors", ())
    actions = g.get("form_action", ())
    for name, value in SECURITY_HEADERS.items():
        if name == "X-Frame-Options" and ancestors:
            continue  # it cannot name origins (ALLOW-FROM is gone); frame-ancestors does
        if name == "Content-Security-Policy" and (ancestors or actions):
            value = content_security_policy(ancestors, actions)
        response.headers.setdefault(name, value)
    if not (request.endpoint or "").endswith("static"):
        # Console pages list participant links and participant pages carry a token:
        # no browser or proxy cache may keep them. Static files may be cached.
        response.headers["Cache-Control"] = "no-store"
    return response


def install(app: Flask) -> None:
    """Bound ids, bodies, JSON and text for every route; call before registering blueprints."""
    app.url_map.converters["int"] = IdConverter
    app.json = BoundedJSONProvider(app)
    app.before_request(_refuse_json_to_pages)
    app.before_request(_refuse_nul_bytes)
    app.before_request(_refuse_file_parts)
    app.after_request(_security_headers)
