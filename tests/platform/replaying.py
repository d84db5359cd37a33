"""An uninterrupted replay of a trial's logged commands, to compare a rebuild against."""

from __future__ import annotations

from sqlalchemy.orm import Session

from hcss.platform.live.trial_log import build_simulation
from hcss.platform.models import Trial
from hcss.simulation import Simulation


def replay_trial(session: Session, trial_id: int, until_step: int) -> Simulation:
    """From the trial row at step 0, every logged command at its step, up to `until_step`.

    No snapshot is used (the platform's rebuild starts from one), so the two
    paths check each other: a snapshot that lost or changed state would make
    them differ.
    """
    trial = session.get(Trial, trial_id)
    assert trial is not None
    return build_simulation(session, trial, until_step)
