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
from typing import TYPE_CHECKING, Any

from flask import url_for
from flask_wtf import FlaskForm

from hcss.platform.live.trials import latest_status, start_trial
from hcss.platform.live.warmup import simulation_ready
from hcss.platform.models import StageEvent
from hcss.platform.models import Trial as TrialRow
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.study.stage import Refused, Slot, Stage
from hcss.platform.study.texts import duration

if TYPE_CHECKING:
    from hcss.platform.study.flow import Flow


class LiveStage(Stage):
    """A stage that runs a trial on the live interface: the training or the trial."""

    per_model = True
    template = "study/trial_start.html"
    kind: str

    def steps(self, flow: Flow, slot: Slot) -> tuple[str, ...]:
        return ("ready", "run")

    def duration_s(self, flow: Flow) -> float:
        return flow.study.training_s if self.kind == "training" else flow.study.trial_s

    def context(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "type_name": f"{slot.order_label} collective type",
            "duration": duration(self.duration_s(flow)),
            "simulation_ready": simulation_ready(),
        }

    def submit(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> bool:
        if step != "ready":
            raise Refused("The trial is already under way.")
        if not simulation_ready():  # its clock would run while the server compiles
            raise Refused("The simulation is still being prepared; please wait a moment.")
        trial = start_trial(
            flow.session,
            flow.participant,
            kind=self.kind,
            model=slot.model,
            first_section=flow.enrolment.first_sections.get(slot.model, "easy"),
            duration_s=self.duration_s(flow),
            time_acceleration=flow.enrolment.time_acceleration,
            started_at=flow.now,
            probe_counts=flow.study.probe_counts,
            preset=flow.study.simulation_preset,
        )
        flow.record(slot, step, "submitted")
        flow.record(slot, "run", "entered", deadline=trial.deadline, detail={"trial_id": trial.id})
        return False  # the flow has moved on by itself: both rows are written

    def redirect(self, flow: Flow, slot: Slot, step: str) -> str | None:
        if step == "run":
            return url_for("live.trial_page", token=flow.participant.token)
        return None

    def poll(
        self, flow: Flow, slot: Slot, step: str, entered: StageEvent
    ) -> tuple[str, datetime] | None:
        """The run step ends when its trial has ended (time limit or experimenter's abort)."""
        if step != "run":
            return None
        trial = flow.session.get(TrialRow, int((entered.detail or {})["trial_id"]))
        assert trial is not None
        if latest_status(flow.session, trial.id) != TrialStatus.ENDED:
            return None
        return ("submitted", min(flow.now, trial.deadline))


class TrainingStage(LiveStage):
    name = "training"
    title = "Training"
    kind = "training"


class TrialStage(LiveStage):
    """The study's trial stage (the database row is `models.Trial`, the run in memory
    `live.session.RunningTrial`)."""

    name = "trial"
    title = "Trial"
    kind = "trial"
