"""Participant-facing pages that are not the live trial: the landing page.

The study flow (`hcss.platform.study`) adds its own stage pages.
"""

from __future__ import annotations

from flask import Blueprint, render_template

bp = Blueprint("pages", __name__)


@bp.get("/")
def index() -> str:
    return render_template("index.html")
