"""Starting trials and asking which are live.

The study flow and `hcss demo-trial` both start trials through `start_trial`;
the runner finds every trial whose latest status is ``running`` and steps it.
"""

from __future__ import annotations

import secrets
from collections.abc import Mapping
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.db import session_now
from hcss.platform.live import trial_writer
from hcss.platform.live.probes import stored_counts
from hcss.platform.models import Participant, Trial, TrialStatusChange
from hcss.platform.models.latest import latest_row, newest_ids
from hcss.platform.models.vocabularies import TrialKind, TrialStatus
from hcss.simulation.params import MODELS
from hcss.simulation.presets import DEFAULT_PRESET, preset_params

#: Kinds of live trial. Their lengths come from the study file (`[timing]`), never from here.
TRIAL_KINDS = tuple(TrialKind)


def start_trial(
    session: Session,
    participant: Participant,
    *,
    kind: str = "trial",
    model: str = "M1",
    seed: int | None = None,
    duration_s: float,
    first_section: str = "easy",
    time_acceleration: float = 1.0,
    started_at: datetime | None = None,
    probe_counts: Mapping[int, int] | None = None,
    preset: str = DEFAULT_PRESET,
) -> Trial:
    """Write a new trial whose clock starts now; the runner picks it up.

    `preset` is the study's `[simulation] preset`: a live trial runs the batch
    experiment's params of that preset, with no per-decision time-out.
    `probe_counts` is the study's `[probes]` (per 20-minute trial, by level;
    None: the original protocol's). `duration_s` is the study's `timing.trial_s` or `timing.training_s` (or a
    demo's chosen length): the caller reads it from the study file.

    The deadline is absolute, so the trial ends on time even if no page is
    open or the server was down in between. `started_at` defaults to now by
    the database's clock (the runner's; tests and bots move it); the study flow
    passes the instant its trial stage was entered.
    """
    from hcss.simulation import Scenario

    if kind not in TRIAL_KINDS:
        raise ValueError(f"trial kind must be one of {TRIAL_KINDS}, not {kind!r}")
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, not {model!r}")
    if time_acceleration <= 0:
        raise ValueError("time_acceleration must be positive")
    if seed is None:
        seed = secrets.randbelow(2**31)
    # The layout is drawn under the preset's readings (e.g. `easy_layout_others`),
    # the same as the batch experiment's scenarios.
    params = preset_params(preset).with_changes(decision_timeout_s=None)
    if kind == "training":
        scenario = Scenario.training(seed, params=params)
    else:
        scenario = Scenario.generate(seed, first_section=first_section, params=params)
    scenario_dict = scenario.to_dict()
    duration = float(duration_s)
    if duration <= 0:
        raise ValueError("duration_s must be positive")
    started_at = started_at or session_now(session)
    trial = trial_writer.new_trial(
        participant_id=participant.id,
        kind=kind,
        model=model,
        scenario=scenario_dict,
        scenario_id=str(getattr(scenario, "scenario_id", None) or f"seed-{seed}"),
        seed=int(seed),
        first_section=None if kind == "training" else first_section,
        # A live trial has no per-decision cap, only its own time limit (spec §2).
        params=params.to_dict(),
        probe_counts=stored_counts(probe_counts),
        time_acceleration=time_acceleration,
        duration_s=duration,
        started_at=started_at,
        deadline=started_at + timedelta(seconds=duration / time_acceleration),
    )
    return trial_writer.write_trial(session, trial)


def start_bot_trial(session: Session, **options: Any) -> tuple[Participant, Trial]:
    """A new bot participant and a live trial for it (`start_trial`'s options).

    For tests, benchmarks and load tools that need a running trial without
    walking the study up to it.
    """
    participant = Participant(is_bot=True)
    session.add(participant)
    session.flush()
    return participant, start_trial(session, participant, **options)


def latest_change(session: Session, trial_id: int) -> TrialStatusChange | None:
    """The trial's current status row (its status, reason and step); None before it starts."""
    return latest_row(session, TrialStatusChange, TrialStatusChange.trial_id, trial_id)


def latest_status(session: Session, trial_id: int) -> str | None:
    row = latest_change(session, trial_id)
    return None if row is None else row.status


def end_reason(session: Session, trial_id: int) -> str | None:
    """Why an ended trial ended (its last status change's reason); None while it runs."""
    row = latest_change(session, trial_id)
    return row.reason if row is not None and row.status == TrialStatus.ENDED else None


def running_trial_ids(session: Session) -> list[int]:
    """Trials whose most recent status change is ``running``."""
    newest = newest_ids(TrialStatusChange, TrialStatusChange.trial_id)
    return list(
        session.scalars(
            select(TrialStatusChange.trial_id)
            .where(
                TrialStatusChange.id.in_(newest),
                TrialStatusChange.status == TrialStatus.RUNNING,
            )
            .order_by(TrialStatusChange.trial_id)
        )
    )


def current_trial(session: Session, participant: Participant) -> Trial | None:
    """The participant's newest trial (running or ended), for the trial page."""
    return session.scalars(
        select(Trial)
        .where(Trial.participant_id == participant.id)
        .order_by(Trial.id.desc())
        .limit(1)
    ).first()
