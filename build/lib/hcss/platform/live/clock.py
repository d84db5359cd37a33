"""The trial clock: wall time since the start, experimenter pauses excluded, times the acceleration.

One definition, used by the live run (which step is due, the page's timer) and
by the console's progress table (a trial not loaded in this process).

A pause stops the clock where it stands: the runner advances a trial only to
the step the *running* wall time allows, so nothing happens in the simulation,
no probe times out and the deadline moves on by the pause's length. The pause
and resume instants are `ConsoleAction` rows, so a trial rebuilt after a
restart stands still (or has caught up) exactly as before.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.models import ConsoleAction

if TYPE_CHECKING:
    from hcss.platform.live.session import RunningTrial


def running_wall_s(
    started_epoch: float, paused_s: float, paused_since: float | None, now: float
) -> float:
    """Wall seconds the trial clock has run by `now`: pauses do not count."""
    stopped = now if paused_since is None else min(now, paused_since)
    return max(0.0, stopped - started_epoch - paused_s)


def trial_time_s(
    started_epoch: float,
    paused_s: float,
    paused_since: float | None,
    now: float,
    *,
    acceleration: float,
    duration_s: float,
) -> float:
    """Trial seconds by `now`, capped at the trial's duration."""
    running = running_wall_s(started_epoch, paused_s, paused_since, now)
    return min(duration_s, running * acceleration)


def paused_intervals(session: Session, trial_id: int) -> tuple[float, float | None]:
    """(closed pause seconds, start of the open pause or None) from the action log."""
    total, open_since = 0.0, None
    rows = session.scalars(
        select(ConsoleAction)
        .where(
            ConsoleAction.trial_id == trial_id,
            ConsoleAction.action.in_(("pause", "resume")),
        )
        .order_by(ConsoleAction.id)
    )
    for row in rows:
        if row.action == "pause" and open_since is None:
            open_since = row.at_epoch
        elif row.action == "resume" and open_since is not None:
            total += max(0.0, row.at_epoch - open_since)
            open_since = None
    return total, open_since


def restore_pauses(session: Session, live: RunningTrial) -> None:
    """Give a trial loaded from the database the pauses it had; call before stepping it."""
    live.paused_s, live.paused_since = paused_intervals(session, live.trial_id)


def pause_clock(live: RunningTrial, now: float) -> None:
    """Stop the clock at `now`; call with the trial's lock held, after advancing it to `now`."""
    if live.paused_since is None:
        live.paused_since = now
        live.touch()


def resume_clock(live: RunningTrial, now: float) -> None:
    """Restart the clock; the paused wall time never counts towards the trial."""
    if live.paused_since is not None:
        live.paused_s += max(0.0, now - live.paused_since)
        live.paused_since = None
        live.touch()
