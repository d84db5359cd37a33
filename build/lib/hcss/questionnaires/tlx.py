"""NASA Task Load Index: six ratings, 15 pairwise comparisons, weighted workload.

Ratings are 0-100 in steps of 5. The pairwise comparisons ask which of two
subscales contributed more to the workload of the task just done; a
subscale's weight is how often it was chosen (0-5, summing to 15). The overall
score weights each rating by its weight / 15, so it stays on 0-100; the raw
(unweighted) TLX, the plain mean of the ratings, is kept as well because many
studies report only that.

Pairs have fixed keys (`pair_01`..`pair_15`, in the order of
`itertools.combinations` over the subscales) so that stored answers mean the
same thing whatever order they were shown in; the random presentation order
and side swaps come from `comparison_order` and are stored separately.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from hcss.questionnaires.definitions import (
    Questionnaire,
    RatingItem,
    ScoreRow,
    ValidationErrors,
    ensure_valid,
)
from hcss.questionnaires.definitions import validate as validate_items

INSTRUMENT = "nasa_tlx"
WEIGHT_TOTAL = 15


def _subscale(key: str, title: str, prompt: str, low: str, high: str, help_text: str) -> RatingItem:
    return RatingItem(
        key=key,
        prompt=f"{title}: {prompt}",
        minimum=0,
        maximum=100,
        step=5,
        low_anchor=low,
        high_anchor=high,
        help_text=help_text,
    )


SUBSCALES: tuple[RatingItem, ...] = (
    _subscale(
        "mental_demand",
        "Mental demand",
        "How mentally demanding was the task?",
        "Very low",
        "Very high",
        "How much thinking, deciding, remembering, looking and searching was needed?",
    ),
    _subscale(
        "physical_demand",
        "Physical demand",
        "How physically demanding was the task?",
        "Very low",
        "Very high",
        "How much physical activity was needed, such as clicking, moving or reaching?",
    ),
    _subscale(
        "temporal_demand",
        "Temporal demand",
        "How hurried or rushed was the pace of the task?",
        "Very low",
        "Very high",
        "How much time pressure did you feel from the pace at which things happened?",
    ),
    _subscale(
        "performance",
        "Performance",
        "How successful were you in accomplishing what you were asked to do?",
        "Good",
        "Poor",
        "How satisfied were you with your performance? Note: left is good, right is poor.",
    ),
    _subscale(
        "effort",
        "Effort",
        "How hard did you have to work to accomplish your level of performance?",
        "Very low",
        "Very high",
        "How hard did you have to work, mentally and physically?",
    ),
    _subscale(
        "frustration",
        "Frustration",
        "How insecure, discouraged, irritated, stressed and annoyed were you?",
        "Very low",
        "Very high",
        "How insecure, discouraged, irritated and stressed, versus secure, content and relaxed?",
    ),
)

SUBSCALE_KEYS: tuple[str, ...] = tuple(item.key for item in SUBSCALES)
SUBSCALE_TITLES: dict[str, str] = {item.key: item.prompt.split(":")[0] for item in SUBSCALES}

RATINGS = Questionnaire(
    instrument=INSTRUMENT,
    title="Workload (NASA-TLX)",
    instructions=(
        "Rate the task you have just done on each of the six scales below. "
        "Each scale runs from 0 to 100 in steps of 5."
    ),
    items=SUBSCALES,
)

COMPARISON_INSTRUCTIONS = (
    "For each pair, choose the one that contributed more to the workload of the task "
    "you have just done."
)


@dataclass(frozen=True)
class Pair:
    """One pairwise comparison between two subscales, in canonical orientation."""

    key: str
    first: str
    second: str

    def sides(self) -> tuple[str, str]:
        return (self.first, self.second)


PAIRS: tuple[Pair, ...] = tuple(
    Pair(f"pair_{number:02d}", first, second)
    for number, (first, second) in enumerate(itertools.combinations(SUBSCALE_KEYS, 2), start=1)
)
PAIR_KEYS: tuple[str, ...] = tuple(pair.key for pair in PAIRS)
ITEM_KEYS: tuple[str, ...] = SUBSCALE_KEYS + PAIR_KEYS


@dataclass(frozen=True)
class PresentedPair:
    """A pair as shown: `position` is 1-based, `left`/`right` are subscale keys."""

    position: int
    pair: Pair
    swapped: bool

    @property
    def left(self) -> str:
        return self.pair.second if self.swapped else self.pair.first

    @property
    def right(self) -> str:
        return self.pair.first if self.swapped else self.pair.second


def comparison_order(rng: np.random.Generator) -> tuple[PresentedPair, ...]:
    """The 15 pairs in random order, each with its sides randomly swapped.

    Randomising both guards against order and position effects; the caller
    stores the result so the exact presentation can be reconstructed.
    """
    order = rng.permutation(len(PAIRS))
    swaps = rng.integers(0, 2, size=len(PAIRS)).astype(bool)
    return tuple(
        PresentedPair(position, PAIRS[int(index)], bool(swap))
        for position, (index, swap) in enumerate(zip(order, swaps, strict=True), start=1)
    )


def presentation_record(order: tuple[PresentedPair, ...]) -> dict[str, str]:
    """The presentation as item -> text, e.g. {"pair_03_position": "1", "pair_03_left": "performance"}.

    Stored with the answers, it lets a refreshed page show the same order and
    lets the analysis check for order effects.
    """
    record = {}
    for presented in order:
        record[f"{presented.pair.key}_position"] = str(presented.position)
        record[f"{presented.pair.key}_left"] = presented.left
    return record


def order_from_record(record: Mapping[str, str]) -> tuple[PresentedPair, ...]:
    """Rebuild a presentation from `presentation_record`'s output."""
    order = [
        PresentedPair(
            position=int(record[f"{pair.key}_position"]),
            pair=pair,
            swapped=record[f"{pair.key}_left"] != pair.first,
        )
        for pair in PAIRS
    ]
    return tuple(sorted(order, key=lambda presented: presented.position))


def validate(answers: Mapping[str, object]) -> ValidationErrors:
    """Ratings (multiples of 5 on 0-100) and all 15 choices (one side of each pair)."""
    ratings = {key: answers[key] for key in SUBSCALE_KEYS if key in answers}
    choices = {key: value for key, value in answers.items() if key not in SUBSCALE_KEYS}
    errors = validate_items(RATINGS, ratings)
    pairs = {pair.key: pair for pair in PAIRS}
    for key, value in choices.items():
        if key not in pairs:
            errors[key] = ["Not a question of this form."]
        elif value not in pairs[key].sides():
            left, right = (SUBSCALE_TITLES[side] for side in pairs[key].sides())
            errors[key] = [f"Choose either {left} or {right}."]
    for key in PAIR_KEYS:
        if key not in choices:
            errors[key] = ["Please choose one of the two."]
    return errors


@dataclass(frozen=True)
class TlxScore:
    """Weights (0-5, sum 15), weighted components, overall (0-100) and raw TLX."""

    ratings: tuple[tuple[str, int], ...]
    weights: tuple[tuple[str, int], ...]
    weighted: tuple[tuple[str, float], ...]
    overall: float
    raw_tlx: float

    def rows(self) -> tuple[ScoreRow, ...]:
        rows = [ScoreRow(INSTRUMENT, "overall", self.overall)]
        rows.append(ScoreRow(INSTRUMENT, "raw_tlx", self.raw_tlx))
        rows += [ScoreRow(INSTRUMENT, f"{key}_weight", float(w)) for key, w in self.weights]
        rows += [ScoreRow(INSTRUMENT, f"{key}_weighted", value) for key, value in self.weighted]
        return tuple(rows)


def weights(choices: Mapping[str, str]) -> dict[str, int]:
    """How often each subscale was chosen across the 15 pairs."""
    counts = dict.fromkeys(SUBSCALE_KEYS, 0)
    for key in PAIR_KEYS:
        counts[choices[key]] += 1
    return counts


def score(answers: Mapping[str, object]) -> TlxScore:
    """Score validated answers; raises InvalidAnswers otherwise."""
    ensure_valid(validate(answers))
    ratings = {key: int(str(answers[key]).strip()) for key in SUBSCALE_KEYS}
    counts = weights({key: str(answers[key]) for key in PAIR_KEYS})
    weighted = {key: ratings[key] * counts[key] / WEIGHT_TOTAL for key in SUBSCALE_KEYS}
    return TlxScore(
        ratings=tuple(ratings.items()),
        weights=tuple(counts.items()),
        weighted=tuple(weighted.items()),
        overall=sum(ratings[key] * counts[key] for key in SUBSCALE_KEYS) / WEIGHT_TOTAL,
        raw_tlx=sum(ratings.values()) / len(ratings),
    )
