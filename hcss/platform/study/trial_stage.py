"""Training and Trial stages: a start page, then a live trial run by hcss.platform.live.

The participant presses Start; the stage starts a trial through the live
engineer's `start_trial` on the study clock and hands over to the Collective
Interface (`/live/<token>`), whose Continue link leads back to `/p/<token>`.
The step ends when the trial has ended. The stage only reads the trial's
status: a trial whose deadline passed while no runner was stepping it (a
closed browser during a restart, or tests) is brought to its end by the
live service (`finish_overdue_trial`, the runner stepping it to its end, so
nothing is skipped) before the flow's unit of work begins: the participant's
pages and the console's skip run it first. Ending it from inside the flow
would need the flow's session committed mid-way (on SQLite the runner's own
unit of work waits for that session's write lock) or a second connection
beside it, which let a bounded pool deadlock.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from flask import url_for
from flask_wtf import FlaskForm

from hcss.platform.live.trials import latest_status, start_trial
from hcss.platform.live.warmup import simulation_ready
from hcss.platform.models import StageEvent
from hcss.platform.models import Trial as TrialRow
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.study.stage_protocol import Refused, Stage, StageContext
from hcss.platform.study.texts import duration

#: Seconds a Start refused during this process's warm-up is to wait (its page reloads as often).
WARMING_RETRY_S = 5


class LiveStage(Stage):
    """A stage that runs a trial on the live interface: the training or the trial."""

    per_model = True
    template = "study/trial_start.html"
    kind: str

    def steps(self, here: StageContext) -> tuple[str, ...]:
        return ("ready", "run")

    def duration_s(self, here: StageContext) -> float:
        return (
            here.study.timing.training_s if self.kind == "training" else here.study.timing.trial_s
        )

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "type_name": f"{here.slot.order_label} collective type",
            "duration": duration(self.duration_s(here)),
            "simulation_ready": simulation_ready(),
        }

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        if here.step != "ready":
            raise Refused("The trial is already under way.")
        if not simulation_ready():
            # Its clock would run while this process compiles. Not now, not no: in a group
            # the page may have come from a warm member and the Start reached one that
            # has just restarted (a 409 stopped the participant there).
            raise Refused(
                "The simulation is still being prepared; please wait a moment.",
                retry_after_s=WARMING_RETRY_S,
            )
        trial = start_trial(
            here.flow.session,
            here.flow.participant,
            kind=self.kind,
            model=here.slot.model,
            first_section=here.flow.enrolment.first_sections.get(here.slot.model, "easy"),
            duration_s=self.duration_s(here),
            time_acceleration=here.flow.enrolment.time_acceleration,
            started_at=here.flow.now,
            probe_counts=here.study.probes.per_level,
            preset=here.study.simulation.preset,
        )
        here.flow.record(here.slot, here.step, "submitted")
        here.flow.record(
            here.slot, "run", "entered", deadline=trial.deadline, detail={"trial_id": trial.id}
        )
        return False  # the flow has moved on by itself: both rows are written

    def redirect(self, here: StageContext) -> str | None:
        if here.step == "run":
            return url_for("live.trial_page", token=here.flow.participant.token)
        return None

    def poll(self, here: StageContext, entered: StageEvent) -> tuple[str, datetime] | None:
        """The run step ends when its trial has ended (time limit or experimenter's abort)."""
        if here.step != "run":
            return None
        trial = here.flow.session.get(TrialRow, int((entered.detail or {})["trial_id"]))
        assert trial is not None
        if latest_status(here.flow.session, trial.id) != TrialStatus.ENDED:
            return None
        return ("submitted", min(here.flow.now, trial.deadline))


class TrainingStage(LiveStage):
    name = "training"
    title = "Training"
    kind = "training"


class TrialStage(LiveStage):
    """The study's trial stage (the database row is `models.Trial`, the run in memory
    `live.running_trial.RunningTrial`)."""

    name = "trial"
    title = "Trial"
    kind = "trial"
