"""The stage protocol: what every stage of a study declares (oTree's page classes).

A stage has one or more steps (a questionnaire has one; the MRT has its
instructions, practice items, timed parts and breaks). For each step it
declares its form, template, time limit and hooks; `flow.Flow` decides which
step is current and records what happened to it.

Each hook is given one `StageContext`: the slot, the step and the participant's
`Participation`, the part of the flow a stage may read and write. `Flow`
implements `Participation`, so the stages know the flow only through this
module and study/ is a tree, for the type checker as at run time.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any, ClassVar, Protocol

import numpy as np
from flask_wtf import FlaskForm
from sqlalchemy.orm import Session

from hcss.platform.models import ConsentRecord, Participant, StageEvent, StudyEnrolment
from hcss.platform.study.settings import Study
from hcss.questionnaires.definitions import Item, RatingItem, ScoreRow


class Refused(Exception):
    """A submission that does not fit where the participant is; nothing is written.

    `retry_after_s`: the refusal is "not now" (503 with Retry-After), not "no" (409): the
    same form is taken once the server is ready, and the page goes back by itself.
    """

    def __init__(
        self, message: str, status: int = 409, *, retry_after_s: int | None = None
    ) -> None:
        super().__init__(message)
        self.message = message
        self.status = 503 if retry_after_s is not None else status
        self.retry_after_s = retry_after_s


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


class Participation(Protocol):
    """One participant's part in a study, as its stages read and write it (`flow.Flow`)."""

    session: Session
    participant: Participant
    enrolment: StudyEnrolment
    study: Study
    now: datetime  # the study clock when the request began

    def event(self, index: int, step: str, kind: str) -> StageEvent | None:
        """The first event of `kind` at a stage's step, or None."""
        ...

    def answers(self, index: int, instrument: str) -> dict[str, str]:
        """The answers given at one stage, item -> value (the newest row wins)."""
        ...

    def record(
        self,
        slot: Slot,
        step: str,
        kind: str,
        *,
        at: datetime | None = None,
        deadline: datetime | None = None,
        detail: dict[str, Any] | None = None,
    ) -> StageEvent: ...

    def record_consent(self, version: str, decision: str) -> ConsentRecord: ...

    def record_answers(
        self, slot: Slot, instrument: str, answers: Mapping[str, object], model: str = ""
    ) -> None: ...

    def record_scores(self, rows: tuple[ScoreRow, ...]) -> None: ...


@dataclass(frozen=True)
class StageContext:
    """What a stage hook is given: the participant's flow, the stage's slot and the step.

    `steps` is asked before a step is chosen, so there `step` is "". The methods
    read and write at this slot, so a stage never passes its own index around.
    """

    flow: Participation
    slot: Slot
    step: str = ""

    @property
    def study(self) -> Study:
        return self.flow.study

    def answers(self, instrument: str) -> dict[str, str]:
        return self.flow.answers(self.slot.index, instrument)

    def event(self, kind: str, step: str | None = None) -> StageEvent | None:
        """The first event of `kind` at this step (or at `step` of the same stage)."""
        return self.flow.event(self.slot.index, self.step if step is None else step, kind)

    def record_answers(
        self, instrument: str, answers: Mapping[str, object], model: str = ""
    ) -> None:
        self.flow.record_answers(self.slot, instrument, answers, model)


#: A form as a bot posts it: field name -> value (or values, for ticked boxes).
Fields = Mapping[str, str | Sequence[str]]


@dataclass(frozen=True)
class Submission:
    """Answers a bot posts at a step, which the stage must accept (oTree's `Submission`)."""

    fields: Fields


@dataclass(frozen=True)
class SubmissionMustFail:
    """Answers the stage must refuse (oTree's `SubmissionMustFail`): the step is shown again
    with an error and nothing is stored."""

    fields: Fields


@dataclass(frozen=True)
class Shown:
    """What a bot sees of a step's page: the step and the values each radio group offers."""

    step: str
    rng: np.random.Generator
    radios: Mapping[str, Sequence[str]] = field(default_factory=dict)
    #: The study the bot walks: what the page cannot say (an instruction check's answers).
    study: Study | None = None


def answered(items: Iterable[Item], rng: np.random.Generator) -> dict[str, str]:
    """One allowed answer to each item, drawn at random (a bot's questionnaire)."""
    return {
        item.key: str(rng.choice(item.points() if isinstance(item, RatingItem) else item.values()))
        for item in items
    }


class Stage:
    """Base class; subclasses override what differs. Instances hold no participant state."""

    name: ClassVar[str]
    per_model: ClassVar[bool] = False
    template: ClassVar[str]
    title: ClassVar[str] = ""

    def steps(self, here: StageContext) -> tuple[str, ...]:
        return ("form",)

    def timeout_s(self, here: StageContext) -> float | None:
        """The step's time limit in study seconds, or None when untimed."""
        return None

    def on_enter(self, here: StageContext) -> dict[str, Any] | None:
        """Called once, when the step is first shown; the result is kept as `detail`."""
        return None

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        """The step's form; an empty one (CSRF only) for pages with a Continue button."""
        return FlaskForm(formdata=formdata)

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        """Template variables beyond the form and the remaining time."""
        return {}

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        """Write what the valid form says; True when the step is done.

        Return False to show the step again (with the form's errors, or the
        next item of a multi-item step).
        """
        return True

    def poll(self, here: StageContext, entered: StageEvent) -> tuple[str, datetime] | None:
        """Has the step ended by itself? The default enforces the stored deadline."""
        if entered.deadline is not None and here.flow.now >= entered.deadline:
            self.on_timeout(here)
            return ("timed_out", entered.deadline)
        return None

    def on_timeout(self, here: StageContext) -> None:
        """Called once when the step's deadline passed before it was submitted."""

    def redirect(self, here: StageContext) -> str | None:
        """A URL to send the participant to instead of rendering (e.g. the live trial)."""
        return None

    def bot_submissions(self, shown: Shown) -> tuple[Submission | SubmissionMustFail, ...]:
        """What a bot posts at the step, in order (hcss.platform.bots.participant, the fuzz test): answers
        the stage must refuse, then the answers that end the step. The default presses
        Continue."""
        return (Submission({}),)
