"""Compile and run the simulation's kernels before a server takes participants.

Numba compiles a kernel on its first call and keeps the result in its disk
cache (hcss/simulation/jit.py). After an install or an upgrade that cache is
empty, and without this the first live trial would wait for the compile with a
blank map and a stopped clock, while its deadline runs on. The compile took 94 s
on a busy 2-core machine, far too long to keep the server from answering: a
reverse proxy gives every visitor a 502 meanwhile. So `hcss serve` listens at
once and runs `warm_simulation` in a background thread (`Warmup`): pages that
need no simulation (the study link, consent, questionnaires, the console) are
served during the compile, and a training or trial page waits with a notice,
its Start refused, until the simulation is ready. With a filled cache the
same calls take well under a second.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from flask import Flask, current_app

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


class Warmup:
    """The server's warm-up, run once in a background thread; `ready` once it has finished.

    Stored in `app.extensions["hcss_warmup"]` by `hcss serve`; an app without one
    (tests, bots, the CLI's commands) has nothing to wait for.
    """

    def __init__(self, work: Callable[[], object]) -> None:
        self._work = work
        self._done = threading.Event()
        self.seconds: float | None = None
        self.error: BaseException | None = None

    def start(self, on_done: Callable[[Warmup], None] | None = None) -> threading.Thread:
        def run() -> None:
            started = time.perf_counter()
            try:
                self._work()
            except BaseException as error:  # noqa: BLE001 - said by on_done; trials compile lazily
                self.error = error
            self.seconds = time.perf_counter() - started
            self._done.set()  # a failed warm-up leaves the first trial to compile, as before
            if on_done is not None:
                on_done(self)

        thread = threading.Thread(target=run, name="hcss-warmup", daemon=True)
        thread.start()
        return thread

    @property
    def ready(self) -> bool:
        return self._done.is_set()

    def install(self, app: Flask) -> None:
        app.extensions["hcss_warmup"] = self


def simulation_ready() -> bool:
    """Whether this server's simulation is warm (always, for an app without a warm-up)."""
    warmup = current_app.extensions.get("hcss_warmup")
    return warmup is None or warmup.ready
