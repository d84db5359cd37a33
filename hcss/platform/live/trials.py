"""Starting trials and asking which are live.

The study flow and `hcss demo-trial` both start trials through `start_trial`;
the runner finds every trial whose latest status is ``running`` and steps it.
"""

from __future__ import annotations

import secrets
from datetime import datetime, timedelta

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from hcss.platform.models import Participant, Trial, TrialStatusChange, utcnow

TRIAL_DURATION_S = {"trial": 20 * 60.0, "training": 5 * 60.0}


def start_trial(
    session: Session,
    participant: Participant,
    *,
    kind: str = "trial",
    model: str = "M1",
    seed: int | None = None,
    first_section: str = "easy",
    duration_s: float | None = None,
    time_acceleration: float = 1.0,
    started_at: datetime | None = None,
) -> Trial:
    """Write a new trial whose clock starts now; the runner picks it up.

    The deadline is absolute, so the trial ends on time even if no page is
    open or the server was down in between. `started_at` (default: now) lets
    the study flow start it on the runner's clock, which tests and bots move.
    """
    from hcss.simulation import Params, Scenario

    if kind not in TRIAL_DURATION_S:
        raise ValueError(f"trial kind must be one of {sorted(TRIAL_DURATION_S)}, not {kind!r}")
    if model not in ("M1", "M2", "M3"):
        raise ValueError(f"model must be M1, M2 or M3, not {model!r}")
    if time_acceleration <= 0:
        raise ValueError("time_acceleration must be positive")
    if seed is None:
        seed = secrets.randbelow(2**31)
    if kind == "training":
        scenario = Scenario.training(seed)
    else:
        scenario = Scenario.generate(seed, first_section=first_section)
    scenario_dict = scenario.to_dict()
    duration = TRIAL_DURATION_S[kind] if duration_s is None else float(duration_s)
    if duration <= 0:
        raise ValueError("duration_s must be positive")
    started_at = started_at or utcnow()
    trial = Trial(
        participant_id=participant.id,
        kind=kind,
        model=model,
        scenario=scenario_dict,
        scenario_id=str(getattr(scenario, "scenario_id", None) or f"seed-{seed}"),
        seed=int(seed),
        first_section=None if kind == "training" else first_section,
        # A live trial has no per-decision cap, only its own time limit (spec §2).
        params=Params().with_changes(decision_timeout_s=None).to_dict(),
        time_acceleration=time_acceleration,
        duration_s=duration,
        started_at=started_at,
        deadline=started_at + timedelta(seconds=duration / time_acceleration),
    )
    session.add(trial)
    session.flush()
    session.add(TrialStatusChange(trial_id=trial.id, status="running", reason="started", step=0))
    session.flush()
    return trial


def latest_status(session: Session, trial_id: int) -> str | None:
    row = session.scalars(
        select(TrialStatusChange)
        .where(TrialStatusChange.trial_id == trial_id)
        .order_by(TrialStatusChange.id.desc())
        .limit(1)
    ).first()
    return None if row is None else row.status


def running_trial_ids(session: Session) -> list[int]:
    """Trials whose most recent status change is ``running``."""
    latest = (
        select(TrialStatusChange.trial_id, func.max(TrialStatusChange.id).label("last_id"))
        .group_by(TrialStatusChange.trial_id)
        .subquery()
    )
    rows = session.execute(
        select(TrialStatusChange.trial_id)
        .join(latest, TrialStatusChange.id == latest.c.last_id)
        .where(TrialStatusChange.status == "running")
        .order_by(TrialStatusChange.trial_id)
    )
    return [trial_id for (trial_id,) in rows]


def current_trial(session: Session, participant: Participant) -> Trial | None:
    """The participant's newest trial (running or ended), for the trial page."""
    return session.scalars(
        select(Trial)
        .where(Trial.participant_id == participant.id)
        .order_by(Trial.id.desc())
        .limit(1)
    ).first()
