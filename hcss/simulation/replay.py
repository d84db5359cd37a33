"""Deterministic replay: a scenario, a run number and a timed command log.

A live trial logs each command (an `OperatorCommand`) with the step count at
which it was applied.
Replaying the same log from the same scenario and run reproduces the trial bit
for bit, which is how a live trial survives a server restart and how a trial
is replayed for analysis.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from hcss.simulation.engine import Simulation
from hcss.simulation.params import Params
from hcss.simulation.requests import OperatorCommand, RequestOutcome
from hcss.simulation.scenario import Scenario

TimedCommand = tuple[int, OperatorCommand]


def replay(
    scenario: Scenario,
    model: str,
    commands: Iterable[TimedCommand],
    until_step: int,
    params: Params | None = None,
    run: int = 0,
    start: Simulation | None = None,
    held: int | None = None,
    on_outcome: Callable[[int, RequestOutcome], None] | None = None,
    on_step: Callable[[Simulation], None] | None = None,
) -> Simulation:
    """Run to `until_step`, applying each command before the step it was logged at.

    `commands` is the whole log in the order the commands were applied.
    `start` continues from a restored snapshot instead of the trial's start:
    the first `held` commands are already in it (default: as many as it
    counts applied, `start.commands_applied`; a caller that knows which
    logged command a snapshot holds last says so, so that a logged command
    the snapshot's simulation never applied does not shift the rest).
    `on_outcome(i, outcome)` hears each replayed command's outcome, `i` its
    position in `commands` (the platform records outcomes a crash lost).
    `on_step(sim)` sees each step reached, the start's included, once the
    commands logged at it are applied (the console replay draws its frames so).
    """
    sim = start if start is not None else Simulation(scenario, model, params, run=run)
    skipped = sim.commands_applied if held is None else held
    pending = [(int(step), command) for step, command in commands][skipped:]
    if any(step < sim.step_count for step, _ in pending):
        raise ValueError(
            "the command log has commands before the snapshot that it does not contain"
        )
    i = 0
    while True:
        while i < len(pending) and pending[i][0] <= sim.step_count:
            outcome = sim.apply(pending[i][1])
            if on_outcome is not None:
                on_outcome(skipped + i, outcome)
            i += 1
        if on_step is not None:
            on_step(sim)
        if sim.step_count >= until_step or sim.finished:
            return sim
        sim.step()
