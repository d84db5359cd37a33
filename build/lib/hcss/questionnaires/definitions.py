"""Data-driven building blocks shared by every instrument.

An instrument is described, not coded: its items are frozen dataclasses that a
form layer can walk to render fields (radio buttons for a `ChoiceItem`, a
slider or a select for a `RatingItem`), and one generic `validate` checks the
answers against the same description. Instruments with rules that span several
items (NASA-TLX pairs, the ranking's permutations) add their own checks on top.

Answers arrive as a mapping from item key to raw value. Values may be `str`
(as posted by a browser) or `int` (as converted by a form library); both are
accepted so the rules live here once rather than in every form.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

#: Field key -> human-readable messages. Empty means the answers are valid.
ValidationErrors = dict[str, list[str]]


@dataclass(frozen=True)
class Choice:
    """One answer option: `value` is stored, `label` is shown."""

    value: str
    label: str


@dataclass(frozen=True)
class ChoiceItem:
    """A single-choice question (radio buttons)."""

    key: str
    prompt: str
    choices: tuple[Choice, ...]
    help_text: str = ""

    def values(self) -> tuple[str, ...]:
        return tuple(choice.value for choice in self.choices)


@dataclass(frozen=True)
class RatingItem:
    """An integer rating on `minimum..maximum` in steps of `step`.

    `low_anchor`/`high_anchor` label the ends; `point_labels`, when given,
    label every allowed point (for short verbal scales such as experience).
    """

    key: str
    prompt: str
    minimum: int
    maximum: int
    low_anchor: str
    high_anchor: str
    step: int = 1
    help_text: str = ""
    point_labels: tuple[str, ...] = ()

    def points(self) -> tuple[int, ...]:
        return tuple(range(self.minimum, self.maximum + 1, self.step))

    def __post_init__(self) -> None:
        if self.point_labels and len(self.point_labels) != len(self.points()):
            raise ValueError(f"{self.key}: one label per scale point is needed")


Item = ChoiceItem | RatingItem


@dataclass(frozen=True)
class Questionnaire:
    """An ordered list of items with a title and instructions to show first."""

    instrument: str
    title: str
    instructions: str
    items: tuple[Item, ...]

    def item_keys(self) -> tuple[str, ...]:
        return tuple(item.key for item in self.items)

    def item(self, key: str) -> Item:
        for item in self.items:
            if item.key == key:
                return item
        raise KeyError(key)


@dataclass(frozen=True)
class ScoreRow:
    """One row of the export's `scores` table.

    `model` is empty for per-participant instruments; the platform fills it for
    per-model instruments with `for_model`, because scoring itself does not
    need to know which model the answers were about.
    """

    instrument: str
    scale: str
    score: float
    model: str = ""

    def for_model(self, model: str) -> ScoreRow:
        return replace(self, model=model)


class InvalidAnswers(ValueError):
    """Raised by scoring functions given answers that `validate` rejects."""

    def __init__(self, errors: ValidationErrors) -> None:
        super().__init__(errors)
        self.errors = errors

    def __str__(self) -> str:
        return "; ".join(f"{key}: {' '.join(messages)}" for key, messages in self.errors.items())


def parse_int(value: object) -> int | None:
    """The integer a raw answer denotes, or None when it denotes none.

    Booleans are refused although Python treats them as ints: a checkbox value
    is never a rating.
    """
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        text = value.strip()
        if text.lstrip("+-").isdigit():
            return int(text)
    return None


def check_rating(item: RatingItem, value: object) -> list[str]:
    number = parse_int(value)
    if number is None:
        return [f"Please give a whole number from {item.minimum} to {item.maximum}."]
    if not item.minimum <= number <= item.maximum:
        return [f"Must be between {item.minimum} and {item.maximum}, got {number}."]
    if (number - item.minimum) % item.step != 0:
        return [f"Must be a multiple of {item.step}, got {number}."]
    return []


def check_choice(item: ChoiceItem, value: object) -> list[str]:
    if not isinstance(value, str) or value not in item.values():
        allowed = ", ".join(item.values())
        return [f"Please choose one of: {allowed}."]
    return []


def validate(questionnaire: Questionnaire, answers: Mapping[str, object]) -> ValidationErrors:
    """Check every item is answered within its range; report unknown keys too.

    Unknown keys are errors rather than ignored so that a renamed form field
    cannot silently drop answers from the record.
    """
    errors: ValidationErrors = {}
    for item in questionnaire.items:
        value = answers.get(item.key)
        if value is None or value == "":
            errors[item.key] = ["This question needs an answer."]
            continue
        messages = (
            check_rating(item, value) if isinstance(item, RatingItem) else check_choice(item, value)
        )
        if messages:
            errors[item.key] = messages
    for key in answers:
        if key not in questionnaire.item_keys():
            errors.setdefault(key, []).append("Not a question of this form.")
    return errors


def ensure_valid(errors: ValidationErrors) -> None:
    if errors:
        raise InvalidAnswers(errors)


def ratings(questionnaire: Questionnaire, answers: Mapping[str, object]) -> dict[str, int]:
    """Validated integer ratings keyed by item, for scoring rating-only instruments."""
    ensure_valid(validate(questionnaire, answers))
    return {key: int(str(answers[key]).strip()) for key in questionnaire.item_keys()}


def ordinal_labels(count: int) -> Sequence[str]:
    """`first`, `second`, ... used wherever order, not identity, must be shown."""
    words = ("first", "second", "third", "fourth", "fifth", "sixth")
    if count > len(words):
        raise ValueError(f"at most {len(words)} ordinal labels are defined")
    return words[:count]
