"""`LiveTrials`: the live wing as one service, the only live object the rest of the platform
holds.

`create_app` builds it (`init_live`); the console, the study flow and the
participant's JSON API get it (`live_trials()`) and nothing else. It answers
in plain values: a command (`door.Command`) is carried out by `carry_out`,
which gives an `Answer`; the console's pause, resume and abort by `control`;
the stream's reads by `frame` and `open_stream`; the questions the others
ask (is this trial held here for this token? what time is it for the
trials?) by methods of their own. The runner, the trial in memory, its lock
and the trial log's writer stay inside the wing: the import contract "Only
the live service reaches into the live wing" (pyproject.toml) forbids them
to every other package of the platform, and tests/test_architecture.py
keeps every module outside the wing from the runner's app extension.

The console's pause, resume and abort go through the same door as the
participant's commands (`door.carry_out` with a `door.Control`), which
decides whether this process hosts the trial (then the action is carried
out under the trial's lock, in one unit of work) or another one does (then
a `TrialOrder` asks that host, whose runner carries it out through the
door, and this waits for its confirmation).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

from flask import Flask, current_app
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live import door, frames
from hcss.platform.live.leases import LEASE_S, HostedElsewhere, Leases
from hcss.platform.live.runner import Runner
from hcss.platform.live.trials import current_trial, latest_status
from hcss.platform.models import Participant, Trial
from hcss.platform.models.vocabularies import TrialStatus

if TYPE_CHECKING:
    from hcss.platform.live.stream_slots import StreamSlots
    from hcss.platform.live.trial_writer import KeyedCommand

__all__ = [
    "Answer",
    "HostedElsewhere",
    "LiveTrials",
    "OrderUnconfirmed",
    "init_live",
    "live_trials",
    "running_trial_id",
]

Answer = door.Answer


class OrderUnconfirmed(Exception):
    """The action was sent to the process hosting the trial, which has not confirmed it yet."""

    def __init__(self, trial_id: int, action: str) -> None:
        super().__init__(
            f"the {action} is sent to the server process hosting trial {trial_id}, which has "
            "not confirmed it yet; it is carried out as soon as that process (or the one "
            "taking the trial over) gets to it"
        )
        self.trial_id = trial_id
        self.action = action


def running_trial_id(session: Session, participant: Participant) -> int | None:
    """The id of the participant's trial if the database says it is running, else None."""
    trial = current_trial(session, participant)
    if trial is None or latest_status(session, trial.id) != TrialStatus.RUNNING:
        return None
    return trial.id


def finish_overdue_trial(runner: Runner, participant: Participant) -> None:
    """Bring the participant's trial to its end if its deadline passed while nobody stepped it.

    A trial outlives its deadline only when no runner stepped it (a closed
    browser during a restart, or tests). The study flow only reads a trial's
    status, so its caller runs this first, before the caller's session
    writes anything: the runner writes the trial's end in units of work of
    its own, which on SQLite would wait for a write lock held by the caller,
    and beside an open session would hold a second connection. Only the
    trial's host ends it (`Runner.finish_overdue`); elsewhere the flow sees
    it running until its host has.
    """
    with runner.database.session_scope() as session:
        trial = current_trial(session, participant)
        overdue = (
            trial is not None
            and runner.database.now() >= trial.deadline
            and latest_status(session, trial.id) == TrialStatus.RUNNING
        )
    if overdue:
        assert trial is not None
        runner.finish_overdue(trial.id)


class LiveTrials:
    """The live trials of this process, as the rest of the platform sees them."""

    def __init__(self, database: Database, runner: Runner) -> None:
        self._database = database
        self._runner = runner

    # --- commands -------------------------------------------------------------------

    def carry_out(self, command: door.Command, key: KeyedCommand | None = None) -> door.Answer:
        """The command carried out (once per `key`) and answered (`door.carry_out`)."""
        return door.carry_out(self._database, self._runner, command, key)

    def control(
        self, trial_id: int, action: str, *, participant_id: int, experimenter_id: int | None
    ) -> bool:
        """Pause, resume or abort a running trial wherever it is hosted; False if it runs
        nowhere.

        Hosted here (or taken over now): carried out at once. Hosted by another
        live process: a `TrialOrder` for it, confirmed within the order's wait,
        else `OrderUnconfirmed` (the order stays and is carried out later).
        """
        control = door.Control(
            trial_id, action, participant_id=participant_id, experimenter_id=experimenter_id
        )
        answer = self.carry_out(control)
        if answer.status == 404:
            return False
        if answer.status == 202:
            raise OrderUnconfirmed(trial_id, action)
        return True

    @contextmanager
    def withdrawing(self, trial_ids: list[int], reason: str) -> Iterator[None]:
        """No process writes a row for these trials while the block deletes them; then they
        end (`reason`) and are let go (`Runner.withdrawing`). `HostedElsewhere` when their
        host did not hand them over in time (nothing is deleted)."""
        with self._runner.withdrawing(trial_ids, reason):
            yield

    def finish_overdue(self, participant: Participant) -> None:
        """End the participant's trial if its deadline passed unstepped (`finish_overdue_trial`)."""
        finish_overdue_trial(self._runner, participant)

    # --- questions --------------------------------------------------------------------

    def now(self) -> float:
        """The clock the trials step by and their rows are stamped with (epoch seconds)."""
        return self._runner.clock()

    def holds_for(self, token: str, trial_id: int) -> bool:
        """Whether this process holds the trial in memory for this token (`Runner.holds_for`);
        False: ask the database."""
        return self._runner.holds_for(token, trial_id)

    # --- the stream's reads ---------------------------------------------------------------

    def frame(self, trial_id: int) -> str:
        """One frame of the trial's stream as JSON text (`frames.frame`)."""
        return frames.frame(self._runner, trial_id)

    def open_stream(self, slots: StreamSlots, trial: Trial, **reading: Any) -> frames.Stream:
        """The trial's stream (`frames.open_stream`: token, client, position, pace)."""
        return frames.open_stream(self._database, self._runner, slots, trial, **reading)

    # --- the runner's thread ------------------------------------------------------------

    def catch_up(self) -> None:
        """Bring every trial hosted here up to the clock now (one pass of the runner): for
        in-process bots and scripts that move a `ManualClock` instead of running the thread."""
        self._runner.tick()

    def start(self) -> None:
        self._runner.start()

    def stop(self) -> None:
        self._runner.stop()


def init_live(app: Flask) -> LiveTrials:
    """Build the app's live service (`app.extensions["hcss_live"]`) around its runner; the
    runner's thread starts only if LIVE_RUNNER (`hcss serve`) asks.

    The runner carries out the console's orders for its trials through the
    service's door (`door.carry_out_order`), the one way into a trial. The
    runner is kept among the app's extensions for the wing's own modules and
    the tests; nothing outside the wing names it.
    """
    database = app.extensions["hcss_db"]
    process = app.config.get("PROCESS_NAME")
    runner = Runner(
        database,
        snapshot_interval_s=float(app.config["SNAPSHOT_INTERVAL_S"]),
        leases=None
        if not process
        else Leases(
            database,
            str(process),
            lease_s=float(app.config.get("LEASE_S", LEASE_S)),
            members=[m.strip() for m in app.config.get("GROUP_MEMBERS") or ()],
        ),
        carry_out_order=door.carry_out_order,
    )
    app.extensions["hcss_runner"] = runner
    live = app.extensions["hcss_live"] = LiveTrials(database, runner)
    if app.config["LIVE_RUNNER"]:
        live.start()
    return live


def live_trials() -> LiveTrials:
    """The current app's live service."""
    return current_app.extensions["hcss_live"]
