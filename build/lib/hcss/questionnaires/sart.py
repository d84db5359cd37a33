"""3-D Situation Awareness Rating Technique (3-D SART).

Three ratings on 1-7: Demand on Attentional Resources (DAR), Supply of
Attentional Resources (SAR) and Situational Understanding (SU). The combined
score SU - (DAR - SAR) rewards understanding and spare attention and
penalises demand, and so runs from 1 - (7 - 1) = -5 to 7 - (1 - 7) = 13.
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

INSTRUMENT = "sart"

SART = Questionnaire(
    instrument=INSTRUMENT,
    title="Situation awareness (3-D SART)",
    instructions="Rate the trial you have just completed on each of the three scales (1 to 7).",
    items=(
        RatingItem(
            key="attentional_demand",
            prompt=(
                "Demand on attentional resources: how much did the situation demand of your "
                "attention? Was it unstable, complex and changing, with many things to track?"
            ),
            minimum=1,
            maximum=7,
            low_anchor="Low",
            high_anchor="High",
        ),
        RatingItem(
            key="attentional_supply",
            prompt=(
                "Supply of attentional resources: how much attention could you give to the "
                "situation? Were you alert and concentrated, able to divide your attention, "
                "with spare mental capacity?"
            ),
            minimum=1,
            maximum=7,
            low_anchor="Low",
            high_anchor="High",
        ),
        RatingItem(
            key="situational_understanding",
            prompt=(
                "Understanding of the situation: how well did you understand what was going "
                "on? How much good-quality information did you have, and how familiar was it?"
            ),
            minimum=1,
            maximum=7,
            low_anchor="Low",
            high_anchor="High",
        ),
    ),
)

ITEM_KEYS = SART.item_keys()


def validate(answers: Mapping[str, object]) -> ValidationErrors:
    return validate_items(SART, answers)


@dataclass(frozen=True)
class SartScore:
    understanding: int
    demand: int
    supply: int

    @property
    def overall(self) -> int:
        return self.understanding - (self.demand - self.supply)

    def rows(self) -> tuple[ScoreRow, ...]:
        return (
            ScoreRow(INSTRUMENT, "overall", float(self.overall)),
            ScoreRow(INSTRUMENT, "SU", float(self.understanding)),
            ScoreRow(INSTRUMENT, "DAR", float(self.demand)),
            ScoreRow(INSTRUMENT, "SAR", float(self.supply)),
        )


def score(answers: Mapping[str, object]) -> SartScore:
    """Score validated answers; raises InvalidAnswers otherwise."""
    values = ratings(SART, answers)
    return SartScore(
        understanding=values["situational_understanding"],
        demand=values["attentional_demand"],
        supply=values["attentional_supply"],
    )
