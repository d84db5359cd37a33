"""How the MRT is administered: practice, two timed parts, instructions, caveats.

Timing is enforced by the platform (deadlines stored server-side); the limits
live here so that the definition of the test is in one place.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

from hcss.questionnaires.mrt.items import MrtItem, item_bank, practice_items

INSTRUMENT = "mrt"
PART_TIME_LIMIT_S = 180.0
BREAK_S = 60.0

NORMS_NOTE = (
    "The figures of this Mental Rotations Test are generated (Shepard-Metzler style "
    "polycubes drawn from fixed seeds), not the published drawings. Scores use the "
    "published rule (one point per item only when both matching figures, and no others, "
    "are chosen; 0-24) but are not comparable with the norms of the published test."
)

INSTRUCTIONS = """\
Each row shows a **target figure** on the left and four figures on the right.

Two of the four are the target figure itself, turned to a different position in
space. The other two cannot be turned to look like the target: they are its
mirror image or a different figure.

For each row, choose the **two** figures that are the target turned. A row earns
a point only when both of your choices are right and you chose no other figure.

The test has two parts of 12 rows. You have 3 minutes for each part, with a
short break between them. Work quickly but carefully. First, a few practice rows
show you whether your answers were right.
"""


@dataclass(frozen=True)
class MrtPart:
    number: int
    items: tuple[MrtItem, ...]
    time_limit_s: float


@dataclass(frozen=True)
class MentalRotationsTest:
    """Everything a stage needs to administer the test."""

    instrument: str
    title: str
    instructions: str
    norms_note: str
    practice: tuple[MrtItem, ...]
    parts: tuple[MrtPart, ...]
    break_s: float
    choices_per_item: int = 2

    def items(self) -> tuple[MrtItem, ...]:
        return tuple(item for part in self.parts for item in part.items)

    def item_keys(self) -> tuple[str, ...]:
        return tuple(item.key for item in self.items())

    @property
    def max_score(self) -> int:
        return len(self.items())


@cache
def mental_rotations_test() -> MentalRotationsTest:
    bank = item_bank()
    parts = tuple(
        MrtPart(number, tuple(item for item in bank if item.part == number), PART_TIME_LIMIT_S)
        for number in (1, 2)
    )
    return MentalRotationsTest(
        instrument=INSTRUMENT,
        title="Mental Rotations Test",
        instructions=INSTRUCTIONS,
        norms_note=NORMS_NOTE,
        practice=practice_items(),
        parts=parts,
        break_s=BREAK_S,
    )
