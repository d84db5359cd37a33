"""The stage protocol: what every stage of a study declares (oTree's page classes).

A stage has one or more steps (a questionnaire has one; the MRT has its
instructions, practice items, timed parts and breaks). For each step it
declares its form, template, time limit and hooks; `flow.Flow` decides which
step is current and records what happened to it.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import TYPE_CHECKING, Any, ClassVar

from flask_wtf import FlaskForm

if TYPE_CHECKING:
    from hcss.platform.models import StageEvent
    from hcss.platform.study.flow import Flow


class Refused(Exception):
    """A submission that does not fit where the participant is; nothing is written."""

    def __init__(self, message: str, status: int = 409) -> None:
        super().__init__(message)
        self.message = message
        self.status = status


@dataclass(frozen=True)
class Slot:
    """One stage at one position of a participant's sequence (per-model stages repeat)."""

    index: int
    stage: Stage
    model: str = ""
    order_label: str = ""  # "first", "second", ... for per-model stages

    @property
    def name(self) -> str:
        return self.stage.name


class Stage:
    """Base class; subclasses override what differs. Instances hold no participant state."""

    name: ClassVar[str]
    per_model: ClassVar[bool] = False
    template: ClassVar[str]
    title: ClassVar[str] = ""

    def steps(self, flow: Flow, slot: Slot) -> tuple[str, ...]:
        return ("form",)

    def timeout_s(self, flow: Flow, slot: Slot, step: str) -> float | None:
        """The step's time limit in study seconds, or None when untimed."""
        return None

    def on_enter(self, flow: Flow, slot: Slot, step: str) -> dict[str, Any] | None:
        """Called once, when the step is first shown; the result is kept as `detail`."""
        return None

    def form(self, flow: Flow, slot: Slot, step: str, formdata: Any = None) -> FlaskForm:
        """The step's form; an empty one (CSRF only) for pages with a Continue button."""
        return FlaskForm(formdata=formdata)

    def context(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> dict[str, Any]:
        """Template variables beyond the form and the remaining time."""
        return {}

    def submit(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> bool:
        """Write what the valid form says; True when the step is done.

        Return False to show the step again (with the form's errors, or the
        next item of a multi-item step).
        """
        return True

    def poll(
        self, flow: Flow, slot: Slot, step: str, entered: StageEvent
    ) -> tuple[str, datetime] | None:
        """Has the step ended by itself? The default enforces the stored deadline."""
        if entered.deadline is not None and flow.now >= entered.deadline:
            self.on_timeout(flow, slot, step)
            return ("timed_out", entered.deadline)
        return None

    def on_timeout(self, flow: Flow, slot: Slot, step: str) -> None:
        """Called once when the step's deadline passed before it was submitted."""

    def redirect(self, flow: Flow, slot: Slot, step: str) -> str | None:
        """A URL to send the participant to instead of rendering (e.g. the live trial)."""
        return None
