"""The Collective Interface page (the trial and training screen)."""

from __future__ import annotations

from flask import Blueprint, render_template
from flask.typing import ResponseReturnValue

from hcss.platform.db import get_session
from hcss.platform.live.access import participant_for
from hcss.platform.live.trials import current_trial, latest_status
from hcss.simulation.messages import collective_names

bp = Blueprint("live", __name__, url_prefix="/live")


@bp.get("/<token>")
def trial_page(token: str) -> ResponseReturnValue:
    """The participant's current trial; a refresh lands back in it at its current time."""
    participant = participant_for(token)
    trial = current_trial(get_session(), participant)
    if trial is None:
        return render_template("live/no_trial.html"), 404
    return render_template(
        "live/trial.html",
        token=token,
        trial=trial,
        status=latest_status(get_session(), trial.id),
        collective_names=collective_names(),
    )
