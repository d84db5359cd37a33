"""A participant's code names them in exports and on the console; it must not repeat.

The code is unique in the database, and is drawn at random when the participant row is
made (every path: the console's Create, a study link's join, bots). A repeat is refused by
the unique constraint, so the request that drew it fails: the space of codes must make
that as unlikely for a large online study as a lost server is.
"""

from __future__ import annotations

import math
import re

from hcss.platform.models import new_code

#: Participants a large online study may make over its life (every link made, used or not).
LARGE_STUDY = 100_000
#: The chance of any two of them drawing the same code that is tolerated.
TOLERATED = 1e-4


def test_a_large_study_s_codes_repeat_with_negligible_chance() -> None:
    codes = {new_code() for _ in range(2_000)}
    assert len(codes) == 2_000
    shape = {re.fullmatch(r"P([0-9A-F]+)", code) is not None for code in codes}
    assert shape == {True}
    digits = {len(code) - 1 for code in codes}
    assert len(digits) == 1
    space = 16 ** digits.pop()
    # the birthday bound: 1 - exp(-n(n-1)/2 / space)
    chance = -math.expm1(-LARGE_STUDY * (LARGE_STUDY - 1) / 2 / space)
    assert chance < TOLERATED, chance
