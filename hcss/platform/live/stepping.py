"""Stepping one trial: to the step the wall clock says is due, recorded, ended at its limit.

The runner's tick calls `advance_trial` for every trial it hosts, and so do
a console action (to stop the clock at the instant it acts) and a hand-back
(to hand over what is due). It needs the trial, the database and the clock's
`now`; none of the runner's registry.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from sqlalchemy.exc import DBAPIError

from hcss.platform.db import Database
from hcss.platform.errors import database_away
from hcss.platform.live.leases import LeaseLost
from hcss.platform.live.outages import record_database_outage
from hcss.platform.live.recorder import end_trial, record_progress, write_snapshot
from hcss.platform.live.unit_of_work import trial_unit

if TYPE_CHECKING:
    from hcss.platform.live.running_trial import RunningTrial

log = logging.getLogger(__name__)


def advance_trial(
    database: Database, live: RunningTrial, now: float, *, snapshot_interval_s: float
) -> None:
    """Step the trial to the step due at `now`, record it, end it at its time limit.

    While the database is away or takes no writes (`database_away_since`;
    `errors.database_away` says which errors mean that) the trial stands
    still and each call tries again to write what it holds.
    """
    with live.lock:
        if live.ended or live.moved:
            return
        due = live.due_step(now)
        if live.trial_clock.database_away_since is None and live.fence and not live.fence.holds():
            # The holder's own deadline passed with no renewal answered (a stall, a
            # partition): it stops before anyone else may start, without asking.
            live.database_away(now)
            live.touch()
            return
        if live.trial_clock.database_away_since is None:
            if due <= live.sim.step_count and due < live.total_steps:
                return
            # The end is judged by `due`, not by the simulation's step: a simulation
            # whose decisions are all made stops stepping early, and a trial rebuilt
            # after its deadline (load_trial steps it to `due`) has nothing left to step.
            live.sim.step(due - live.sim.step_count)
            live.touch()
        try:
            with trial_unit(database, live) as unit:
                record_progress(live, unit.session)
                if live.trial_clock.database_away_since is not None:
                    record_database_outage(live, unit.session, now)
                if due >= live.total_steps:
                    end_trial(live, unit.session, "time_limit", now)
                elif now - live.log.last_snapshot_epoch >= snapshot_interval_s:
                    write_snapshot(live, unit.session, now)
        except (DBAPIError, LeaseLost) as error:
            if isinstance(error, DBAPIError) and not database_away(error):
                raise  # a bug, not an outage: the tick logs it
            # Away, or the lease is not proved (its deadline passed before a renewal
            # answered): the trial stands still until a renewal or a takeover decides.
            if live.trial_clock.database_away_since is None:
                # One line, no traceback: an outage, not a bug (the driver's words say why).
                cause = getattr(error, "orig", None) or error
                log.warning(
                    "live trial %s: the database takes no writes (%s: %s); the trial stands "
                    "still and what it holds is written when the database is back",
                    live.trial_id,
                    type(cause).__name__,
                    (str(cause).strip().splitlines() or [""])[0][:200],
                )
                live.database_away(now)
                live.touch()
            return
        if live.trial_clock.database_away_since is not None:
            live.database_back(now)
            log.warning("live trial %s: the database is back; the trial goes on", live.trial_id)
        live.touch()


# --- the thread --------------------------------------------------------------
