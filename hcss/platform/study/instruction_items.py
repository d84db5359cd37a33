"""A study file's `[instruction_check]`: questions on the introduction, asked before training.

Studies run on Gorilla or jsPsych commonly gate the first trial on a short quiz
about the instructions; this is ours. The file lists the questions, each with
its choices, its answer and the introduction page that explains it; how many
tries a participant has; and what follows a wrong try:

- ``after_wrong = "reread"``: the pages that explain the questions answered
  wrongly are shown again, then the questions (the default);
- ``after_wrong = "retry"``: the questions again at once, the wrong ones marked.

After the last try the participant goes on to training either way: the export
records every try's answers and whether and when the check was passed, and the
analysis decides what a failed check means. The instruction_check stage
(hcss.platform.study.instruction_check) asks the questions.
"""

from __future__ import annotations

import re
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, StrictStr, model_validator

from hcss.questionnaires import pages

#: Tries a study may give (each after the first follows a re-read or a retry).
MAX_TRIES = 5
KEY = re.compile(r"[a-z][a-z0-9_]{0,31}")


def _listed(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value


class _Table(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class InstructionItem(_Table):
    """One question: its key (in the export), the question, its choices and the answer."""

    key: StrictStr
    question: StrictStr
    choices: Annotated[tuple[StrictStr, ...], BeforeValidator(_listed)]
    answer: StrictStr
    #: The introduction page (1, 2, ...) that explains it: shown again after a wrong answer.
    page: int

    @model_validator(mode="after")
    def _answer_among_choices(self) -> InstructionItem:
        if not KEY.fullmatch(self.key):
            raise ValueError(f"key {self.key!r} must be lower case letters, digits and _")
        if len(self.choices) < 2 or len(set(self.choices)) != len(self.choices):
            raise ValueError(f"{self.key}: `choices` must list at least two distinct answers")
        if self.answer not in self.choices:
            raise ValueError(f"{self.key}: `answer` {self.answer!r} is not one of its `choices`")
        count = len(pages.introduction_pages())
        if not 1 <= self.page <= count:
            raise ValueError(f"{self.key}: `page` must be an introduction page, 1 to {count}")
        return self


class InstructionCheck(_Table):
    """The `[instruction_check]` table: `[[instruction_check.items]]`, tries, after_wrong."""

    tries: Annotated[int, Field(ge=1, le=MAX_TRIES)] = 2
    after_wrong: Literal["reread", "retry"] = "reread"
    items: Annotated[tuple[InstructionItem, ...], BeforeValidator(_listed)]

    @model_validator(mode="after")
    def _distinct_keys(self) -> InstructionCheck:
        keys = [item.key for item in self.items]
        if not keys:
            raise ValueError("`items` must list at least one question")
        if len(set(keys)) != len(keys):
            raise ValueError(f"the questions' keys must differ: {keys}")
        return self

    def wrong(self, answers: dict[str, str]) -> tuple[InstructionItem, ...]:
        """The questions `answers` (key -> choice) gets wrong."""
        return tuple(item for item in self.items if answers.get(item.key) != item.answer)
