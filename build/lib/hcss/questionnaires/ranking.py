"""Post-experiment ranking of the three models, named only by the order met.

Participants never see model codes: they rank the "first", "second" and
"third collective type". The form stores ranks under order labels, and
`model_for_label` turns a label back into a model code using the
participant's model order, so the scores table names models, not positions.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from hcss.questionnaires.definitions import (
    InvalidAnswers,
    ScoreRow,
    ValidationErrors,
    ordinal_labels,
    parse_int,
)

INSTRUMENT = "ranking"
MODEL_COUNT = 3
ORDER_LABELS: tuple[str, ...] = tuple(ordinal_labels(MODEL_COUNT))


@dataclass(frozen=True)
class RankingDimension:
    key: str
    prompt: str


DIMENSIONS: tuple[RankingDimension, ...] = (
    RankingDimension(
        "responsiveness",
        "Rank the collective types by how responsive they were to your requests.",
    ),
    RankingDimension(
        "performance",
        "Rank the collective types by how well they chose good targets on their own.",
    ),
    RankingDimension(
        "comprehension",
        "Rank the collective types by how easy they were to understand.",
    ),
)

INSTRUCTIONS = (
    "You supervised three types of collective, in the order you met them. For each "
    "question give every type a different rank: 1 is the best and 3 the worst."
)


def display_name(label: str) -> str:
    """What the participant sees for an order label, e.g. "first collective type"."""
    return f"{label} collective type"


def item_key(dimension: str, label: str) -> str:
    """Key of the rank given on `dimension` to the type met in position `label`."""
    return f"{dimension}_{label}"


ITEM_KEYS: tuple[str, ...] = tuple(
    item_key(dimension.key, label) for dimension in DIMENSIONS for label in ORDER_LABELS
)


def model_for_label(label: str, model_order: Sequence[str]) -> str:
    """The model code met in position `label` (e.g. "second" with M2,M1,M3 gives M1)."""
    if len(model_order) != MODEL_COUNT:
        raise ValueError(f"a model order names {MODEL_COUNT} models, got {list(model_order)}")
    if label not in ORDER_LABELS:
        raise ValueError(f"unknown order label {label!r}; expected one of {ORDER_LABELS}")
    return model_order[ORDER_LABELS.index(label)]


def validate(answers: Mapping[str, object]) -> ValidationErrors:
    """Each dimension's ranks must be 1, 2 and 3, each used once."""
    errors: ValidationErrors = {}
    for key in answers:
        if key not in ITEM_KEYS:
            errors[key] = ["Not a question of this form."]
    for dimension in DIMENSIONS:
        ranks = []
        for label in ORDER_LABELS:
            key = item_key(dimension.key, label)
            rank = parse_int(answers.get(key))
            if rank is None or not 1 <= rank <= MODEL_COUNT:
                errors[key] = [f"Give the {display_name(label)} a rank from 1 to {MODEL_COUNT}."]
            else:
                ranks.append(rank)
        if len(ranks) == MODEL_COUNT and sorted(ranks) != list(range(1, MODEL_COUNT + 1)):
            errors[dimension.key] = [
                "Each collective type needs a different rank: use 1, 2 and 3 once each."
            ]
    return errors


@dataclass(frozen=True)
class Ranking:
    """Ranks per dimension, keyed by model code."""

    ranks: tuple[tuple[str, str, int], ...]  # (dimension, model, rank)

    def rank(self, dimension: str, model: str) -> int:
        for row_dimension, row_model, rank in self.ranks:
            if (row_dimension, row_model) == (dimension, model):
                return rank
        raise KeyError((dimension, model))

    def rows(self) -> tuple[ScoreRow, ...]:
        return tuple(
            ScoreRow(INSTRUMENT, dimension, float(rank), model=model)
            for dimension, model, rank in self.ranks
        )


def score(answers: Mapping[str, object], model_order: Sequence[str]) -> Ranking:
    """Ranks attributed to model codes; raises InvalidAnswers on invalid answers."""
    errors = validate(answers)
    if errors:
        raise InvalidAnswers(errors)
    return Ranking(
        tuple(
            (
                dimension.key,
                model_for_label(label, model_order),
                int(str(answers[item_key(dimension.key, label)]).strip()),
            )
            for dimension in DIMENSIONS
            for label in ORDER_LABELS
        )
    )
