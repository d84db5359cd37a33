"""Read-side questions about a trial's log that the rebuild, the replay, the export and analysis ask."""

from __future__ import annotations

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.models import Command, Observation, Snapshot


def observation_actions(session: Session, trial_id: int) -> list[Observation]:
    """The study's observation actions: every click no committed request names.

    A left-click that filled the request form is logged when it happens; if
    the request is then committed, its `Command.selections` names the click,
    and it counts as part of the request instead.
    """
    used: set[int] = set()
    for selections in session.scalars(
        select(Command.selections).where(Command.trial_id == trial_id)
    ):
        used.update(int(i) for i in selections or [])
    clicks = session.scalars(
        select(Observation).where(Observation.trial_id == trial_id).order_by(Observation.id)
    )
    return [click for click in clicks if click.id not in used]


def newest_snapshot(session: Session, trial_id: int) -> Snapshot | None:
    """The trial's latest snapshot (a rebuild and a replay both start from it)."""
    return session.scalars(
        select(Snapshot)
        .where(Snapshot.trial_id == trial_id)
        .order_by(Snapshot.step.desc(), Snapshot.id.desc())
        .limit(1)
    ).first()
