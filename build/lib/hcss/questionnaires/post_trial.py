"""Post-trial questionnaire: the participant's view of the model just used.

Seven-point ratings of how effective each request type was, how responsive the
collectives were to requests, how well they chose targets on their own, and
how easy they were to understand. `effectiveness` is also reported as the mean
of the three request types, the single figure the study compares across models.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from hcss.questionnaires.definitions import (
    Questionnaire,
    RatingItem,
    ScoreRow,
    ValidationErrors,
    ratings,
)
from hcss.questionnaires.definitions import validate as validate_items

INSTRUMENT = "post_trial"
REQUEST_KINDS = ("investigate", "abandon", "decide")


def _rating(key: str, prompt: str, low: str, high: str) -> RatingItem:
    return RatingItem(
        key=key, prompt=prompt, minimum=1, maximum=7, low_anchor=low, high_anchor=high
    )


POST_TRIAL = Questionnaire(
    instrument=INSTRUMENT,
    title="About the collective type you just supervised",
    instructions="Think about the trial you have just completed and rate each statement from 1 to 7.",
    items=(
        *(
            _rating(
                f"{kind}_effectiveness",
                f"How effective were your {kind} requests?",
                "Not at all effective",
                "Very effective",
            )
            for kind in REQUEST_KINDS
        ),
        _rating(
            "responsiveness",
            "How responsive were the collectives to your requests?",
            "Not at all responsive",
            "Very responsive",
        ),
        _rating(
            "performance",
            "How well did the collectives choose good targets on their own?",
            "Very poorly",
            "Very well",
        ),
        _rating(
            "comprehension",
            "How easy was it to understand what the collectives were doing?",
            "Very hard",
            "Very easy",
        ),
    ),
)

ITEM_KEYS = POST_TRIAL.item_keys()


def validate(answers: Mapping[str, object]) -> ValidationErrors:
    return validate_items(POST_TRIAL, answers)


@dataclass(frozen=True)
class PostTrialScore:
    ratings: tuple[tuple[str, int], ...]

    @property
    def effectiveness(self) -> float:
        values = dict(self.ratings)
        return sum(values[f"{kind}_effectiveness"] for kind in REQUEST_KINDS) / len(REQUEST_KINDS)

    def rows(self) -> tuple[ScoreRow, ...]:
        return (
            ScoreRow(INSTRUMENT, "effectiveness", self.effectiveness),
            *(ScoreRow(INSTRUMENT, key, float(value)) for key, value in self.ratings),
        )


def score(answers: Mapping[str, object]) -> PostTrialScore:
    """Score validated answers; raises InvalidAnswers otherwise."""
    return PostTrialScore(tuple(ratings(POST_TRIAL, answers).items()))
