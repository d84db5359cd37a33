"""An uninterrupted replay of a trial's logged commands, to compare a rebuild against."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.models import Command, Trial
from hcss.simulation import Params, Scenario, Simulation
from hcss.simulation.replay import replay


def replay_trial(session: Session, trial_id: int, until_step: int) -> Simulation:
    """From the scenario and the trial's stored parameters, every logged command at its step.

    No snapshot is used (the platform's rebuild starts from one), so the two
    paths check each other; both go through the simulation's one `replay`.
    """
    trial = session.get(Trial, trial_id)
    assert trial is not None
    commands = [
        (c.step_applied, c.operator_command())
        for c in session.scalars(
            select(Command).where(Command.trial_id == trial_id).order_by(Command.id)
        )
        if c.step_applied <= until_step
    ]
    params = Params.from_dict(trial.params) if trial.params else None
    return replay(Scenario.from_dict(trial.scenario), trial.model, commands, until_step, params)
