"""Mental Rotations Test with generated Shepard-Metzler figures.

`shapes` decides geometric truth on the cube lattice, `render` draws figures
as SVG, `items` builds the seeded item bank, `scoring` scores answers and
`protocol` says how the test is administered. Norms are not those of the
published test (see `protocol.NORMS_NOTE`).
"""

from hcss.questionnaires.mrt.items import MrtItem, item_bank, practice_items
from hcss.questionnaires.mrt.protocol import NORMS_NOTE, MentalRotationsTest, mental_rotations_test
from hcss.questionnaires.mrt.scoring import (
    MrtScore,
    PracticeFeedback,
    format_selection,
    parse_selection,
    practice_feedback,
    score,
    score_item,
    validate,
)

__all__ = [
    "NORMS_NOTE",
    "MentalRotationsTest",
    "MrtItem",
    "MrtScore",
    "PracticeFeedback",
    "format_selection",
    "item_bank",
    "mental_rotations_test",
    "parse_selection",
    "practice_feedback",
    "practice_items",
    "score",
    "score_item",
    "validate",
]
