"""The live service for the console and the study flow, in plain values; and the runner's
assembly with the service's door.

The console names a trial by its id and an action by its word; it never holds
a `RunningTrial`, its lock or a session of the trial log. Its pause, resume
and abort go through the same door as the participant's commands
(`door.carry_out` with a `door.Control`), which decides whether this process
hosts the trial (then the action is carried out under the trial's lock, in
one unit of work) or another one does (then a `TrialOrder` asks that host,
whose runner carries it out through the door, and this waits for its
confirmation). The import-linter contract "The console reaches live trials
through the live service" (pyproject.toml) keeps it so.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from flask import Flask
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live import door
from hcss.platform.live.leases import LEASE_S, HostedElsewhere, Leases
from hcss.platform.live.runner import Runner
from hcss.platform.live.trials import current_trial, latest_status
from hcss.platform.models import Participant
from hcss.platform.models.vocabularies import TrialStatus

__all__ = [
    "HostedElsewhere",
    "OrderUnconfirmed",
    "control_session_trial",
    "finish_overdue_trial",
    "init_runner",
    "running_trial_id",
    "withdrawing",
]


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


def control_session_trial(
    database: Database,
    runner: Runner,
    trial_id: int,
    action: str,
    *,
    participant_id: int,
    experimenter_id: int | None,
) -> bool:
    """Pause, resume or abort a running trial wherever it is hosted; False if it runs nowhere.

    Hosted here (or taken over now): carried out at once. Hosted by another
    live process: a `TrialOrder` for it, confirmed within the order's wait,
    else `OrderUnconfirmed` (the order stays and is carried out later).
    """
    control = door.Control(
        trial_id, action, participant_id=participant_id, experimenter_id=experimenter_id
    )
    answer = door.carry_out(database, runner, control)
    if answer.status == 404:
        return False
    if answer.status == 202:
        raise OrderUnconfirmed(trial_id, action)
    return True


@contextmanager
def withdrawing(runner: Runner, trial_ids: list[int], reason: str) -> Iterator[None]:
    """No process writes a row for these trials while the block deletes them (`Runner.withdrawing`)."""
    with runner.withdrawing(trial_ids, reason):
        yield


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


def init_runner(app: Flask) -> Runner:
    """Attach a runner to the app; its thread starts only if LIVE_RUNNER (`hcss serve`) asks.

    The runner carries out the console's orders for its trials through the
    service's door (`door.carry_out_order`), the one way into a trial.
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
    if app.config["LIVE_RUNNER"]:
        runner.start()
    return runner
