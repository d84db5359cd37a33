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

from dataclasses import dataclass, field

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.models import ConsoleAction


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


@dataclass
class TrialClock:
    """A live trial's clock, changed only by what stops and restarts it.

    It stands still while the experimenter pauses the trial, while the
    database takes none of its rows, and for every server outage (added
    whole, on a rebuild: hcss.platform.live.outages).
    """

    started_epoch: float  # wall clock, seconds since the epoch
    acceleration: float
    duration_s: float
    # Wall seconds the clock stood still, and the start of the stop under way, if any.
    _paused_s: float = field(default=0.0, init=False)
    _paused_since: float | None = field(default=None, init=False)
    # The wall instant the database stopped taking the trial's rows, if it is away now.
    _database_away_since: float | None = field(default=None, init=False)

    @property
    def paused_since(self) -> float | None:
        return self._paused_since

    @property
    def database_away_since(self) -> float | None:
        return self._database_away_since

    def running_wall_s(self, now: float) -> float:
        return running_wall_s(self.started_epoch, self._paused_s, self._paused_since, now)

    def trial_time_s(self, now: float) -> float:
        return trial_time_s(
            self.started_epoch,
            self._paused_s,
            self._paused_since,
            now,
            acceleration=self.acceleration,
            duration_s=self.duration_s,
        )

    def pauses_restored(self, paused_s: float, paused_since: float | None) -> None:
        """The pauses the action log holds (`paused_intervals`), for a trial loaded from it."""
        self._paused_s, self._paused_since = paused_s, paused_since

    def stood_still(self, wall_s: float) -> None:
        """An outage that is over: the clock stood still for `wall_s` more seconds."""
        self._paused_s += wall_s

    def pause(self, now: float) -> bool:
        """Stop the clock at `now`; whether it ran until now."""
        if self._paused_since is not None:
            return False
        self._paused_since = now
        return True

    def resume(self, now: float) -> bool:
        """Run the clock again; the stopped wall time never counts. Whether it stood still."""
        if self._paused_since is None:
            return False
        self._paused_s += max(0.0, now - self._paused_since)
        self._paused_since = None
        return True

    def database_away(self, now: float) -> bool:
        self._database_away_since = now
        return self.pause(now)

    def database_back(self, now: float) -> bool:
        self._database_away_since = None
        return self.resume(now)
