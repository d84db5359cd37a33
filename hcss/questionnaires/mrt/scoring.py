"""MRT answers, validation, practice feedback and scoring.

An answer to an item is the set of alternatives the participant ticked,
0-based in the order shown (A=0 ... D=3). Participants may tick any number;
an item earns its point only when exactly its two correct alternatives are
ticked, so guessing three or four never pays. Items not reached before a
part's time limit have no answer and earn nothing.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

from hcss.questionnaires.definitions import (
    InvalidAnswers,
    ScoreRow,
    ValidationErrors,
    parse_int,
)
from hcss.questionnaires.mrt.items import ALTERNATIVE_COUNT, MrtItem, item_bank
from hcss.questionnaires.mrt.protocol import INSTRUMENT

#: One participant's raw MRT answer: chosen alternative indices (as numbers, or as the
#: form's text values), or their stored text form "0,2".
Selection = Collection[int] | Collection[str] | str


def format_selection(chosen: Collection[int]) -> str:
    """The stored text of a selection, e.g. "0,2"; "" when nothing was ticked."""
    return ",".join(str(index) for index in sorted(set(chosen)))


def parse_selection(value: Selection) -> frozenset[int]:
    """The chosen indices from a selection or its stored text; raises ValueError if malformed."""
    errors = selection_errors(value)
    if errors:
        raise ValueError(" ".join(errors))
    parts = [part for part in value.split(",") if part.strip()] if isinstance(value, str) else value
    return frozenset(int(str(part).strip()) for part in parts)


def selection_errors(value: Selection) -> list[str]:
    """Messages for a malformed selection; empty when it is well formed."""
    if isinstance(value, str):
        parts: list[object] = [part for part in value.split(",") if part.strip()]
    elif isinstance(value, Collection):
        parts = list(value)
    else:
        return ["A selection is a list of alternative numbers."]
    numbers = [number for number in map(parse_int, parts) if number is not None]
    if len(numbers) != len(parts):
        return ["Alternatives are identified by whole numbers."]
    if any(not 0 <= number < ALTERNATIVE_COUNT for number in numbers):
        return [f"Alternatives are numbered 0 to {ALTERNATIVE_COUNT - 1}."]
    if len(set(numbers)) != len(numbers):
        return ["An alternative was chosen twice."]
    return []


def score_item(item: MrtItem, chosen: Selection) -> int:
    """1 when exactly the item's two correct alternatives are chosen, else 0."""
    return int(parse_selection(chosen) == item.correct)


@dataclass(frozen=True)
class PracticeFeedback:
    """What a participant is told after a practice item."""

    correct: bool
    correct_alternatives: frozenset[int]
    message: str


def practice_feedback(item: MrtItem, chosen: Selection) -> PracticeFeedback:
    selection = parse_selection(chosen)
    letters = " and ".join(chr(ord("A") + index) for index in sorted(item.correct))
    if selection == item.correct:
        message = f"Correct: {letters} are the target figure turned to another position."
    elif len(selection) > len(item.correct):
        message = (
            f"Not quite: you chose {len(selection)} figures, but exactly two match. "
            f"The matching figures are {letters}; the others are mirror images or other figures."
        )
    else:
        message = (
            f"Not quite: the matching figures are {letters}. "
            "The others cannot be turned to look like the target."
        )
    return PracticeFeedback(selection == item.correct, item.correct, message)


def validate(
    answers: Mapping[str, Selection], items: Sequence[MrtItem] | None = None
) -> ValidationErrors:
    """Well-formed selections for known items. Unanswered items are allowed (they score 0)."""
    items = item_bank() if items is None else items
    keys = {item.key for item in items}
    errors: ValidationErrors = {}
    for key, value in answers.items():
        if key not in keys:
            errors[key] = ["Not an item of this test."]
            continue
        messages = selection_errors(value)
        if messages:
            errors[key] = messages
    return errors


@dataclass(frozen=True)
class MrtScore:
    """Total (0-24), per-part and per-item credit."""

    total: int
    part_scores: tuple[int, ...]
    item_scores: tuple[tuple[str, int], ...]

    def rows(self) -> tuple[ScoreRow, ...]:
        parts = tuple(
            ScoreRow(INSTRUMENT, f"part_{number}", float(score))
            for number, score in enumerate(self.part_scores, start=1)
        )
        return (ScoreRow(INSTRUMENT, "total", float(self.total)), *parts)


def score(answers: Mapping[str, Selection], items: Sequence[MrtItem] | None = None) -> MrtScore:
    """Score a whole test; raises InvalidAnswers on malformed input."""
    items = item_bank() if items is None else items
    errors = validate(answers, items)
    if errors:
        raise InvalidAnswers(errors)
    item_scores = tuple(
        (item.key, score_item(item, answers[item.key]) if item.key in answers else 0)
        for item in items
    )
    credit = dict(item_scores)
    part_numbers = sorted({item.part for item in items})
    part_scores = tuple(
        sum(credit[item.key] for item in items if item.part == part) for part in part_numbers
    )
    return MrtScore(sum(credit.values()), part_scores, item_scores)
