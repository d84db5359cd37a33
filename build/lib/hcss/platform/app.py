"""The application factory.

There is no global app: `create_app` builds one from settings, so every test
gets its own app and database, and the server builds exactly one.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from flask import Flask, jsonify, request
from flask_wtf.csrf import CSRFError, CSRFProtect
from werkzeug.exceptions import HTTPException

from hcss.platform import config as platform_config
from hcss.platform import db, hardening
from hcss.platform.errors import error_page, http_error_page

# (module, attribute) of each blueprint; each part of the platform adds its line.
BLUEPRINTS: list[tuple[str, str]] = [
    ("hcss.platform.pages", "bp"),
    ("hcss.platform.live.views", "bp"),
    ("hcss.platform.live.api", "bp"),
    ("hcss.platform.study.views", "bp"),
    ("hcss.platform.console.views", "bp"),
    ("hcss.platform.console.presence", "bp"),
    ("hcss.platform.study.recruitment", "bp"),
    ("hcss.platform.replay.views", "bp"),
]

csrf = CSRFProtect()


def create_app(config: Mapping[str, Any] | None = None) -> Flask:
    app = Flask(__name__, instance_path=str(platform_config.instance_path()))
    app.config.update(platform_config.defaults())
    if config:
        app.config.update(config)
    if not app.config.get("SECRET_KEY"):
        app.config["SECRET_KEY"] = platform_config.secret_key()

    hardening.install(app)
    db.init_app(app)
    csrf.init_app(app)
    _register_json_errors(app)
    for module_name, attribute in BLUEPRINTS:
        app.register_blueprint(getattr(importlib.import_module(module_name), attribute))

    from hcss.platform.live.runner import init_runner

    init_runner(app)
    return app


def _register_json_errors(app: Flask) -> None:
    """API clients get JSON errors they can show; pages keep Flask's HTML ones."""

    @app.errorhandler(CSRFError)
    def _csrf_error(error: CSRFError):  # type: ignore[no-untyped-def]
        if request.path.startswith("/api/"):
            return jsonify(error="csrf", message=error.description), 400
        return error_page(400)

    @app.errorhandler(HTTPException)
    def _http_error(error: HTTPException):  # type: ignore[no-untyped-def]
        if request.path.startswith("/api/"):
            return jsonify(error=error.name.lower().replace(" ", "_"), message=error.description), (
                error.code or 500
            )
        return http_error_page(error)
