"""Passing a hosted trial to another process: home, once its home restarted (`hand_back`),
or over to one that withdraws it (`hand_over`).

Either way what the trial holds is written and the lease passed in one
fenced unit of work under the trial's lock, and then this process lets the
trial go (`Runner.let_go`): its streams close and the page reconnects to the
new host. See hcss.platform.live.leases for the lease's side.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from sqlalchemy.exc import DBAPIError

from hcss.platform.live.leases import LeaseLost
from hcss.platform.live.orders import PendingOrder, mark_done
from hcss.platform.live.recorder import record_progress, write_snapshot
from hcss.platform.live.unit_of_work import kept_until_written, trial_transaction

if TYPE_CHECKING:
    from hcss.platform.live.runner import Runner
    from hcss.platform.live.running_trial import RunningTrial

log = logging.getLogger(__name__)


def hand_over(runner: Runner, live: RunningTrial, order: PendingOrder) -> None:
    """Stop hosting the trial and pass its lease to the process withdrawing it, which sent a
    hand-over order for it (`Runner.withdrawing`)."""
    assert runner.leases is not None
    with live.lock:
        with trial_transaction(runner.database, live) as session:
            now = runner.clock()
            runner.leases.pass_on(session, live.trial_id, order.issued_by, now)
            mark_done(session, order.id, now, "done")
        runner.let_go(live)


def hand_back(runner: Runner, live: RunningTrial, heir: str) -> bool:
    """Give the trial to `heir`, its home's process (back after a restart; nginx sends its
    participant there): what it holds and a snapshot written and the lease passed in one
    fenced unit of work, then it stops hosting here. False: not now (a command under way
    or the lock taken), try again at the next tick.

    Under the trial's lock, with no participant's command under way: nothing is
    applied that is not written, and a command that comes after finds the trial
    moved (503, which the page retries and nginx sends to the heir).
    """
    assert runner.leases is not None
    if not live.lock.acquire(blocking=False):
        return False
    try:
        if runner.commands_under_way(live.trial_id):
            return False
        now = runner.clock()
        runner.advance(live, now)
        if live.ended or live.moved or live.trial_clock.database_away_since is not None:
            return True  # nothing to hand over, or not safely now (the next renewal decides)
        with kept_until_written(live), trial_transaction(runner.database, live) as session:
            record_progress(live, session)
            handed = runner.leases.send_home(session, live.trial_id, heir, now)
            if handed:
                write_snapshot(live, session, now)
        if handed:
            runner.let_go(live)
            log.info("live trial %s handed back to %s", live.trial_id, heir)
        return True
    except (DBAPIError, LeaseLost):
        log.warning("live trial %s: not handed back now", live.trial_id, exc_info=True)
        return True
    finally:
        live.lock.release()
