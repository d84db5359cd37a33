"""The instruction check: the study file's questions on the introduction, before training.

Its steps grow with the participant's answers: ``try_1``; after a wrong try
``reread_1`` (the pages that explain the questions missed; only when the file
says ``after_wrong = "reread"``) and ``try_2``; and so on up to the file's
``tries``. A try answered rightly, or the last one, ends the stage. `steps` is
read from the answers stored, so a reload, a closed tab or a restart finds
the participant where they were.

Each try's answers are stored under the instrument ``instruction_check`` as
``<key>_try_<n>``, and, once the stage ends, two scores: ``passed`` (1 or 0)
and ``tries`` (how many were used). Both reach the export's
questionnaire_items and scores tables with the other stages'.
"""

from __future__ import annotations

from typing import Any

from flask_wtf import FlaskForm

from hcss.platform.study.forms import answers_of, form_of, item_field
from hcss.platform.study.instruction_items import InstructionCheck as CheckSettings
from hcss.platform.study.instruction_items import InstructionItem
from hcss.platform.study.markdown import render_markdown
from hcss.platform.study.stage_protocol import (
    Shown,
    Stage,
    StageContext,
    Submission,
    SubmissionMustFail,
)
from hcss.platform.study.texts import fill
from hcss.questionnaires import pages
from hcss.questionnaires.definitions import Choice, ChoiceItem, ScoreRow

INSTRUMENT = "instruction_check"


def stored_key(item: InstructionItem, attempt: int) -> str:
    return f"{item.key}_try_{attempt}"


class InstructionCheck(Stage):
    name = "instruction_check"
    title = "Checking the instructions"
    template = "study/instruction_check.html"

    def _settings(self, here: StageContext) -> CheckSettings:
        settings = here.study.instruction_check
        assert settings is not None, "the study file is checked to declare it"
        return settings

    def _given(self, here: StageContext, attempt: int) -> dict[str, str] | None:
        """A try's answers (question key -> choice), or None before it was answered."""
        stored = here.answers(INSTRUMENT)
        settings = self._settings(here)
        given = {
            item.key: stored[stored_key(item, attempt)]
            for item in settings.items
            if stored_key(item, attempt) in stored
        }
        return given or None

    def steps(self, here: StageContext) -> tuple[str, ...]:
        settings = self._settings(here)
        steps: list[str] = []
        for attempt in range(1, settings.tries + 1):
            steps.append(f"try_{attempt}")
            given = self._given(here, attempt)
            if given is None or not settings.wrong(given) or attempt == settings.tries:
                break
            if settings.after_wrong == "reread":
                steps.append(f"reread_{attempt}")
        return tuple(steps)

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        if not here.step.startswith("try_"):
            return FlaskForm(formdata=formdata)
        fields = {
            item.key: item_field(
                ChoiceItem(item.key, item.question, tuple(Choice(c, c) for c in item.choices))
            )
            for item in self._settings(here).items
        }
        return form_of(fields, formdata, "InstructionCheckForm")

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        settings = self._settings(here)
        kind, _, number = here.step.partition("_")
        attempt = int(number)
        before = self._given(here, attempt - 1 if kind == "try" else attempt)
        missed = settings.wrong(before) if before is not None else ()
        context: dict[str, Any] = {
            "kind": kind,
            "attempt": attempt,
            "tries": settings.tries,
            "missed": [item.question for item in missed],
        }
        if kind == "try":
            context["questions"] = [(form[item.key], item in missed) for item in settings.items]
        else:
            introduction = pages.introduction_pages()
            numbers = sorted({item.page for item in missed})
            context["pages"] = [
                render_markdown(fill(introduction[number - 1].markdown, here.study))
                for number in numbers
            ]
        return context

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        if not here.step.startswith("try_"):
            return True  # a re-read page: Continue
        settings = self._settings(here)
        attempt = int(here.step.removeprefix("try_"))
        given = answers_of(form, [item.key for item in settings.items])
        here.record_answers(
            INSTRUMENT, {stored_key(item, attempt): given[item.key] for item in settings.items}
        )
        passed = not settings.wrong(given)
        if passed or attempt == settings.tries:
            here.flow.record_scores(
                (
                    ScoreRow(INSTRUMENT, "passed", 1.0 if passed else 0.0),
                    ScoreRow(INSTRUMENT, "tries", float(attempt)),
                )
            )
        return True

    def bot_submissions(self, shown: Shown) -> tuple[Submission | SubmissionMustFail, ...]:
        """Nothing answered is refused; then the study file's answers (the page does not
        show them), so a bot passes at its first try."""
        if not shown.step.startswith("try_"):
            return (Submission({}),)
        assert shown.study is not None and shown.study.instruction_check is not None
        items = shown.study.instruction_check.items
        return (SubmissionMustFail({}), Submission({item.key: item.answer for item in items}))
