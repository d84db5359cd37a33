"""A server or database outage stops the trial clock, as an experimenter's pause does.

While the server is down nobody can see or command the trial, so it must not
run on. On a rebuild the trial resumes where the dead server was last seen
alive (the newest row's time, never earlier than the newest step in its
rows), and the wall time since then is added to the trial's paused time, so the simulation, the probes and the deadline all move on by the
outage's length (the stage flow already waits for a paused trial to end).

Each `Interruption` row keeps the outage (`outage_s`, wall seconds) and when
the server was last seen (`last_seen_at`, the newest row written before the
crash, read before the rebuild writes anything), so a later rebuild restores
every earlier outage and the export shows which trials were interrupted and
for how long. At most one snapshot interval of steps the dead server had
computed but not written is replayed again after the restart.

The database going away while the server lives stops the clock the same way
(`RunningTrial.database_away` .. `database_back`), with an `Interruption` too.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from sqlalchemy import Select, func, select
from sqlalchemy.orm import Session

from hcss.platform.live import trial_writer
from hcss.platform.models import (
    Command,
    DecisionRow,
    Interruption,
    Observation,
    Probe,
    ProbeEvent,
    RequestStatusChange,
    SimEvent,
    Snapshot,
    TrialStatusChange,
)

if TYPE_CHECKING:
    from hcss.platform.live.running_trial import RunningTrial


def _newest(session: Session, *newest: Select[Any]) -> list[Any]:
    """Each of these one-value queries' answers, asked in one statement (a rebuild asked them
    one by one: 13 of a takeover's 33 round trips)."""
    row = session.execute(select(*(query.scalar_subquery() for query in newest))).one()
    return [value for value in row if value is not None]


def last_seen(session: Session, trial_id: int) -> datetime | None:
    """When the newest row of the trial was written; call before the rebuild writes any."""
    present = _newest(
        session,
        *(
            select(func.max(model.created_at)).where(model.trial_id == trial_id)
            for model in (
                Snapshot,
                Command,
                SimEvent,
                Observation,
                DecisionRow,
                RequestStatusChange,
            )
        ),
    )
    return max(present) if present else None


def last_reached_step(session: Session, trial_id: int) -> int:
    """The newest step any row of the trial records: the dead server got at least this far."""
    steps = _newest(
        session,
        *(
            select(func.max(column)).where(model.trial_id == trial_id)
            for model, column in (
                (Snapshot, Snapshot.step),
                (Command, Command.step_applied),
                (Observation, Observation.step),
                (DecisionRow, DecisionRow.step),
                (RequestStatusChange, RequestStatusChange.step),
                (TrialStatusChange, TrialStatusChange.step),
            )
        ),
        select(func.max(ProbeEvent.step)).join(Probe).where(Probe.trial_id == trial_id),
    )
    return max(steps, default=0)


def earlier_outages_s(session: Session, trial_id: int) -> float:
    """Wall seconds of every earlier outage of the trial, each already a pause of its clock."""
    total = session.scalar(
        select(func.coalesce(func.sum(Interruption.outage_s), 0.0)).where(
            Interruption.trial_id == trial_id
        )
    )
    return float(total or 0.0)


def stop_clock_for_outage(
    live: RunningTrial, seen: datetime | None, reached_step: int, now: float
) -> float:
    """Pause the trial clock from the last moment the server was seen alive; returns the
    outage's wall seconds.

    The moment is the newest row's time (`seen`), not the newest step: a
    simulation whose decisions are all made stops stepping while the trial runs
    on to its deadline, and its rows (snapshots every few seconds) keep that
    step. The step the dead server reached is a floor, for rows without a time.
    """
    alive_wall_s = reached_step * live.dt / live.acceleration
    if seen is not None:
        seen_epoch = (seen if seen.tzinfo else seen.replace(tzinfo=UTC)).timestamp()
        alive_wall_s = max(alive_wall_s, live.trial_clock.running_wall_s(min(now, seen_epoch)))
    outage_s = max(0.0, live.trial_clock.running_wall_s(now) - alive_wall_s)
    live.stood_still(outage_s)
    return outage_s


def record_database_outage(live: RunningTrial, session: Session, now: float) -> None:
    """The outage as an `Interruption`, in the unit of work that writes the held rows.

    `outage_s` is the time the clock stood still, so a later rebuild (which
    adds every earlier outage to the trial's paused time) keeps it stopped too.
    An earlier unit of work may have stored part of this outage and lost its
    commit's answer (the trial stood still on): its rows stand (the table is
    append-only), and this one adds only the stretch after them, so the rows
    add up to the time the clock stood still and none counts it twice.
    """
    assert live.trial_clock.database_away_since is not None
    since = datetime.fromtimestamp(live.trial_clock.database_away_since, UTC)
    covered_s = float(
        session.scalar(
            select(func.coalesce(func.sum(Interruption.outage_s), 0.0)).where(
                Interruption.trial_id == live.trial_id,
                Interruption.last_seen_at >= since,
                Interruption.replayed_commands == 0,
            )
        )
        or 0.0
    )
    outage_s = max(0.0, now - live.trial_clock.database_away_since) - covered_s
    if covered_s and outage_s <= 0.0:
        return
    trial_writer.write_interruption(
        session,
        live.trial_id,
        snapshot_step=live.sim.step_count,
        resumed_step=live.sim.step_count,
        replayed_commands=0,
        state_digest=live.sim.state_digest(),
        last_seen_at=datetime.fromtimestamp(live.trial_clock.database_away_since + covered_s, UTC),
        outage_s=max(0.0, outage_s),
    )
