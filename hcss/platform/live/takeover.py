"""Taking a trial up in this process: claim its lease, rebuild it, or end it if it cannot be.

`Runner.host` calls `take_up` with the trial's loader held, for a trial the
database says is running and that is not in memory: after a restart, a
takeover when its holder died, or a hand-back. A trial whose records cannot be
rebuilt is ended (`rebuild_failed`) with a `TrialProblem` saying why, instead
of failing at every tick.
"""

from __future__ import annotations

import logging
import time as wallclock
from typing import TYPE_CHECKING

from sqlalchemy.exc import DBAPIError

from hcss.platform.live import trial_writer
from hcss.platform.live.leases import Fence, HostedElsewhere, LeaseLost
from hcss.platform.live.rebuild import load_trial
from hcss.platform.live.trials import latest_status
from hcss.platform.models import Trial
from hcss.platform.models.vocabularies import TrialStatus

if TYPE_CHECKING:
    from hcss.platform.live.runner import Runner
    from hcss.platform.live.running_trial import RunningTrial

log = logging.getLogger(__name__)

#: Seconds past a quiet holder's lease that a process getting a request for its trial claims
#: it: the database's clock has moved on by then, whatever the two hosts' clocks say.
QUIET_MARGIN_S = 0.05


def take_up(runner: Runner, trial_id: int) -> RunningTrial | None:
    """Claim and rebuild the trial (`Runner.host` holds its loader); None if it is not running.

    With leases, the claim takes a new epoch (the trial's `Fence`); a holder
    gone quiet is waited out; a trial another live process holds is
    `HostedElsewhere`, naming the holder (a participant's request is forwarded
    there, hcss.platform.live.forwarding), and so is one nobody holds whose
    home is another live member (hcss.platform.live.placement): it is claimed
    there, where its participant's requests arrive, never here.
    """
    with runner.database.session_scope() as session:
        if latest_status(session, trial_id) != TrialStatus.RUNNING:
            return None
    # Another process's lease, run out: it hosted the trial and died, maybe before
    # its first snapshot; the rebuild must still stop the clock for the outage.
    earlier = None if runner.leases is None else runner.leases.owner_of(trial_id)
    fence = None
    if runner.leases is not None:
        home = runner.leases.home_elsewhere(trial_id, runner.clock())
        if home is not None:
            raise HostedElsewhere(trial_id, home)
        claimed_at = runner.leases.monotonic()
        epoch = runner.leases.claim(trial_id, runner.clock())
        quiet_for = (
            None
            if epoch is not None
            else runner.leases.runs_out_unrenewed(trial_id, runner.clock())
        )
        if quiet_for is not None:  # its holder has gone quiet: wait its lease out
            wallclock.sleep(quiet_for + QUIET_MARGIN_S)
            epoch = runner.leases.claim(trial_id, runner.clock())
        if epoch is None:
            holder = runner.leases.holder(trial_id, runner.clock())
            raise HostedElsewhere(trial_id, holder or "")
        fence = Fence(runner.leases, trial_id, epoch, runner.leases.deadline_after(claimed_at))
    host_died = runner.leases is not None and earlier not in (None, runner.leases.owner)
    try:
        with runner.database.session_scope() as session:
            if fence is not None:
                fence.prove(session, runner.clock())
            trial = session.get(Trial, trial_id)
            assert trial is not None  # it has a status, so it exists
            live = load_trial(session, trial, runner.clock(), host_died=host_died)
            live.leased(fence)
    except LeaseLost:
        raise  # taken by another process while this one rebuilt it: nothing written
    except DBAPIError:
        runner.release_lease(trial_id)
        raise  # the database is away: try again later, the trial is not at fault
    except Exception as error:
        log.exception("live trial %s cannot be rebuilt; ending it", trial_id)
        _give_up(runner, trial_id, error, fence)
        runner.release_lease(trial_id)
        return None
    return live


def _give_up(runner: Runner, trial_id: int, error: Exception, fence: Fence | None) -> None:
    """End a trial whose records cannot be rebuilt, saying why, instead of failing forever.

    Without this, every tick would retry and log a traceback, and the
    participant's stream, state and stage page would fail until someone
    edited the database. The ended status lets the study move on; the
    `TrialProblem` row tells the analyst the trial stopped here and why.
    """
    with runner.database.session_scope() as session:
        if fence is not None:
            fence.prove(session, runner.clock())
        trial_writer.write_problem(
            session,
            trial_id,
            "rebuild",
            f"trial {trial_id}",
            f"cannot be rebuilt: {type(error).__name__}: {error}",
        )
        trial_writer.write_status(session, trial_id, TrialStatus.ENDED, "rebuild_failed", 0)
