"""The landing page at ``/``: what someone who opens the site without a link is told.

Participants arrive by their own link (`views`) or a study's public link
(`recruitment`); this page sends everyone else to theirs.
"""

from __future__ import annotations

from flask import Blueprint, render_template

bp = Blueprint("landing", __name__)


@bp.get("/")
def index() -> str:
    return render_template("index.html")
