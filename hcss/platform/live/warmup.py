"""Compile and run the simulation's kernels before a server takes participants.

Numba compiles a kernel on its first call and keeps the result in its disk
cache (hcss/simulation/jit.py). After an install or an upgrade that cache is
empty, and without this the first live trial would wait for the compile (about
10 to 25 s) with a blank map and a stopped clock, while its deadline runs on.
`hcss serve` calls `warm_simulation` before it listens, so the cost is paid at
start-up, in front of the experimenter, and every trial's first frame comes at
once. With a filled cache the same calls take well under a second.
"""

from __future__ import annotations

import time

#: Steps each warm-up simulation runs: enough to pass through the start and a request.
WARM_STEPS = 3


def warm_simulation() -> float:
    """Build, step, command, draw and snapshot one simulation per model and trial kind.

    These are the calls a live trial makes (the runner's steps, a request of
    each kind, the page's view, a snapshot and its restore), so each compiled
    kernel they reach is compiled or loaded from the cache here. Returns the
    seconds it took.
    """
    from hcss.simulation import MODELS, Params, Scenario, Simulation

    started = time.perf_counter()
    # A live trial's parameters and scenario, through the dicts its row stores.
    params = Params.from_dict(Params().with_changes(decision_timeout_s=None).to_dict())
    for model in MODELS:
        for scenario in (Scenario.training(1), Scenario.generate(1)):
            sim = Simulation(Scenario.from_dict(scenario.to_dict()), model=model, params=params)
            sim.step(WARM_STEPS)
            sim.investigate(0, 1)
            sim.abandon(0, 1)
            sim.decide(0, 1)
            sim.step(WARM_STEPS)
            sim.display().to_json()
            sim.truth()
            sim.best_target(0)
            sim.drain_events()
            sim.drain_status_changes()
            Simulation.restore(sim.snapshot()).state_digest()
    return time.perf_counter() - started
