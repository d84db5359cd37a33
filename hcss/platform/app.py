"""The application factory.

There is no global app: `create_app` builds one from settings, so every test
gets its own app and database, and the server builds exactly one.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from flask import Flask, Response, jsonify, request
from flask_wtf.csrf import CSRFError, CSRFProtect
from sqlalchemy.exc import DBAPIError, InterfaceError, OperationalError
from sqlalchemy.exc import TimeoutError as PoolTimeout
from werkzeug.exceptions import HTTPException
from werkzeug.middleware.proxy_fix import ProxyFix

from hcss.platform import config as platform_config
from hcss.platform import db, eventlog
from hcss.platform.console import presence
from hcss.platform.console import views as console_views
from hcss.platform.errors import (
    database_away,
    database_unavailable_page,
    error_page,
    http_error_page,
)
from hcss.platform.guards import hardening
from hcss.platform.guards.hardening import SchemeSecureSessions
from hcss.platform.live import api as live_api
from hcss.platform.live import views as live_views
from hcss.platform.live.forwarding import forwarded
from hcss.platform.live.service import init_live
from hcss.platform.replay import views as replay_views
from hcss.platform.study import landing, recruitment
from hcss.platform.study import views as study_views

# Each part of the platform adds its blueprint here.
BLUEPRINTS = (
    landing.bp,
    live_views.bp,
    live_api.bp,
    study_views.bp,
    console_views.bp,
    presence.bp,
    recruitment.bp,
    replay_views.bp,
)

csrf = CSRFProtect()


class Platform(Flask):
    """Flask, but a request the database refused is no "Exception on ..." with a traceback:
    its 503 handler logs one line (hcss.platform.errors.log_database_away)."""

    def log_exception(self, exc_info: Any) -> None:
        if database_away(exc_info[1]):
            return
        super().log_exception(exc_info)


def create_app(config: Mapping[str, Any] | None = None) -> Flask:
    app = Platform(__name__, instance_path=str(platform_config.instance_path()))
    app.config.update(platform_config.defaults())
    if config:
        app.config.update(config)
    if not app.config.get("SECRET_KEY"):
        app.config["SECRET_KEY"] = platform_config.secret_key()

    hops = int(app.config.get("PROXY_HOPS") or 0)
    if hops:
        # Flask's documented way to add WSGI middleware; its stubs call the method final.
        app.wsgi_app = ProxyFix(  # type: ignore[method-assign]
            app.wsgi_app, x_for=hops, x_proto=hops, x_host=hops, x_port=hops
        )
    app.session_interface = SchemeSecureSessions()
    hardening.install(app)
    db.init_app(app)
    csrf.init_app(app)
    _register_json_errors(app)
    for blueprint in BLUEPRINTS:
        app.register_blueprint(blueprint)
    init_live(app)
    eventlog.install(app)  # the server's terminal: one line per participant event
    return app


def _register_json_errors(app: Flask) -> None:
    """API clients get JSON errors they can show; pages keep Flask's HTML ones."""

    @app.errorhandler(CSRFError)
    def _csrf_error(error: CSRFError):
        if request.path.startswith("/api/"):
            return jsonify(error="csrf", message=error.description), 400
        return error_page(400)

    @app.errorhandler(OperationalError)
    @app.errorhandler(InterfaceError)
    @app.errorhandler(PoolTimeout)
    def _database_away(error: Exception):
        return database_unavailable_page(error)

    @app.errorhandler(DBAPIError)
    def _database_error(error: DBAPIError):
        # Not an OperationalError, yet the database is away: a connection the server closed
        # (a transaction ended for idling, 25P03), a read-only standby. Anything else is a bug.
        if database_away(error):
            return database_unavailable_page(error)
        raise error

    @app.errorhandler(HTTPException)
    def _http_error(error: HTTPException):
        forward = forwarded(error)  # a trial held by another member: nginx sends it there
        if forward is not None:
            return forward
        original = getattr(error, "original_exception", None)
        if database_away(original):
            return database_unavailable_page(original)  # the request's commit failed
        # A 503 that says when to ask again (a trial hosted by another server process,
        # not yet taken over) keeps its Retry-After, or bots and scripts give up at once.
        retry = {k: v for k, v in error.get_headers() if k == "Retry-After"}
        if request.path.startswith("/api/"):
            name = error.name.lower().replace(" ", "_")
            # A 503 here is a trial hosted by another server process: the page retries.
            held = {"held_by": "server"} if error.code == 503 else {}
            body = jsonify(error=name, message=error.description, **held)
            return body, (error.code or 500), retry
        page = http_error_page(error)
        if isinstance(page, Response):
            page.headers.update(retry)
            return page
        return page[0], page[1], retry
