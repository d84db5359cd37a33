"""The live service: what the console asks of live trials, in plain values.

The console names a trial by its id and an action by its word; it never holds
a `RunningTrial`, its lock or a session of the trial log. Whether this
process hosts the trial (then `control_trial` carries the action out under
the trial's lock, in one unit of work) or another one does (then a
`TrialOrder` asks that host, and this waits for its confirmation) is decided
here. The import-linter contract "The console reaches live trials through the
live service" (pyproject.toml) keeps it so.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live.control import control_trial
from hcss.platform.live.leases import HostedElsewhere
from hcss.platform.live.orders import send_order
from hcss.platform.live.runner import Runner
from hcss.platform.live.trials import current_trial, latest_status
from hcss.platform.models import Participant
from hcss.platform.models.vocabularies import TrialStatus

__all__ = [
    "HostedElsewhere",
    "OrderUnconfirmed",
    "control_session_trial",
    "finish_overdue_trial",
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
    try:
        live = runner.host(trial_id)
    except HostedElsewhere:
        issued_by = "" if runner.leases is None else runner.leases.owner
        outcome = send_order(
            database, trial_id, action, experimenter_id=experimenter_id, issued_by=issued_by
        )
        if outcome is None:
            raise OrderUnconfirmed(trial_id, action) from None
        return True
    if live is None:
        return False
    control_trial(
        runner, live, action, participant_id=participant_id, experimenter_id=experimenter_id
    )
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
