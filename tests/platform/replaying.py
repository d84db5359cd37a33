"""An uninterrupted replay of a trial's logged commands, to compare a rebuild against."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.models import Command, Trial
from hcss.simulation import Scenario, Simulation


def replay_trial(session: Session, trial_id: int, until_step: int) -> Simulation:
    """From the scenario, apply every logged command at its step, up to `until_step`.

    Written without the platform's rebuild code (no snapshots), so the two
    paths check each other.
    """
    trial = session.get(Trial, trial_id)
    commands = [
        (c.step_applied, c.as_sim_command())
        for c in session.scalars(
            select(Command).where(Command.trial_id == trial_id).order_by(Command.id)
        )
        if c.step_applied <= until_step
    ]
    sim = Simulation(Scenario.from_dict(trial.scenario), model=trial.model)
    for step, command in commands:
        sim.step(step - sim.step_count)
        sim.apply(command)
    sim.step(until_step - sim.step_count)
    return sim
