"""The runner: one thread in the server that keeps every live trial on time.

Each tick it finds trials the database says are running (started here, by the
CLI, or before a restart), advances each to the step the wall clock says is
due, records what happened and wakes the streams. Commands do not wait for a
tick: they take the trial's lock and apply between two steps.
"""

from __future__ import annotations

import logging
import threading
import time as wallclock
from collections.abc import Callable

from flask import Flask
from sqlalchemy.exc import DBAPIError

from hcss.platform.db import Database
from hcss.platform.live.rebuild import load_trial
from hcss.platform.live.recorder import end_trial, record_progress, write_snapshot
from hcss.platform.live.session import LiveTrial
from hcss.platform.live.trials import latest_status, running_trial_ids
from hcss.platform.models import Trial, TrialProblem, TrialStatusChange

log = logging.getLogger(__name__)

TICK_S = 0.05
SYNC_EVERY_S = 1.0


class Runner:
    def __init__(
        self,
        database: Database,
        *,
        snapshot_interval_s: float = 5.0,
        clock: Callable[[], float] = wallclock.time,
    ) -> None:
        self.database = database
        self.snapshot_interval_s = snapshot_interval_s
        self.clock = clock
        self.trials: dict[int, LiveTrial] = {}
        self._registry_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._last_sync = -float("inf")

    # --- finding trials -------------------------------------------------------

    def get(self, trial_id: int) -> LiveTrial | None:
        """The live trial, loading it first if the database says it is running."""
        live = self.trials.get(trial_id)
        if live is not None:
            return live
        with self._registry_lock:
            live = self.trials.get(trial_id)
            if live is not None:
                return live
            try:
                with self.database.session_scope() as session:
                    if latest_status(session, trial_id) != "running":
                        return None
                    trial = session.get(Trial, trial_id)
                    live = load_trial(session, trial, self.clock())
            except DBAPIError:
                raise  # the database is away: try again later, the trial is not at fault
            except Exception as error:
                log.exception("live trial %s cannot be rebuilt; ending it", trial_id)
                self._give_up(trial_id, error)
                return None
            self.trials[trial_id] = live
            return live

    def _give_up(self, trial_id: int, error: Exception) -> None:
        """End a trial whose records cannot be rebuilt, saying why, instead of failing forever.

        Without this, every tick would retry and log a traceback, and the
        participant's stream, state and stage page would fail until someone
        edited the database. The ended status lets the study move on; the
        `TrialProblem` row tells the analyst the trial stopped here and why.
        """
        with self.database.session_scope() as session:
            session.add(
                TrialProblem(
                    trial_id=trial_id,
                    source="rebuild",
                    record=f"trial {trial_id}",
                    problem=f"cannot be rebuilt: {type(error).__name__}: {error}"[:300],
                )
            )
            session.add(
                TrialStatusChange(trial_id=trial_id, status="ended", reason="rebuild_failed")
            )

    def sync(self) -> None:
        """Load every running trial not yet in memory (after a restart, or from the CLI)."""
        with self.database.session_scope() as session:
            running = running_trial_ids(session)
        for trial_id in running:
            if trial_id not in self.trials:
                try:
                    self.get(trial_id)
                except Exception:
                    log.exception("could not load live trial %s", trial_id)

    # --- advancing --------------------------------------------------------------

    def tick(self) -> None:
        """Bring every live trial up to the wall clock; the thread calls this in a loop."""
        now = self.clock()
        if now - self._last_sync >= SYNC_EVERY_S:
            self._last_sync = now
            self.sync()
        for live in list(self.trials.values()):
            try:
                self.advance(live, now)
            except Exception:
                log.exception("live trial %s failed to advance", live.trial_id)
            if live.ended:
                self.trials.pop(live.trial_id, None)

    def advance(self, live: LiveTrial, now: float) -> None:
        with live.lock:
            if live.ended:
                return
            due = live.due_step(now)
            if due <= live.sim.step_count and due < live.total_steps:
                return
            # The end is judged by `due`, not by the simulation's step: a simulation
            # whose decisions are all made stops stepping early, and a trial rebuilt
            # after its deadline (load_trial steps it to `due`) has nothing left to step.
            live.sim.step(due - live.sim.step_count)
            live.touch()
            with self.database.session_scope() as session:
                record_progress(live, session)
                if due >= live.total_steps:
                    end_trial(live, session, "time_limit", now)
                elif now - live.last_snapshot_epoch >= self.snapshot_interval_s:
                    write_snapshot(live, session, now)
            live.touch()

    # --- the thread --------------------------------------------------------------

    def start(self) -> None:
        if self._thread is not None:
            return
        self._thread = threading.Thread(target=self._run, name="hcss-live-runner", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None

    def _run(self) -> None:
        while not self._stop.is_set():
            started = wallclock.monotonic()
            try:
                self.tick()
            except Exception:
                log.exception("runner tick failed")
            self._stop.wait(max(0.0, TICK_S - (wallclock.monotonic() - started)))


def init_runner(app: Flask) -> Runner:
    runner = Runner(
        app.extensions["hcss_db"], snapshot_interval_s=float(app.config["SNAPSHOT_INTERVAL_S"])
    )
    app.extensions["hcss_runner"] = runner
    if app.config["LIVE_RUNNER"]:
        runner.start()
    return runner
