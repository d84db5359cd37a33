"""Recover the exact value a measure stands for, so that ties are ties.

Decision times are whole seconds, so every decision measure is a ratio of
small integers (a mean time is Σ seconds / (60 n)). Floating point loses
that: 130/600 − 119/600 and 200/600 − 189/600 are both 11/600, yet the two
float differences may not be equal, and a rank test that sees them apart
reports an exact p where R, given the exact values, reports a tie-corrected
one. Rounding to a fixed number of decimals does not help: it moves each
value by up to half a unit in the last kept place, in either direction, so
equal differences of rounded values can differ by one unit.

:func:`exact_value` finds the simplest fraction (denominator at most
:data:`MAX_DENOMINATOR`) within :data:`TOLERANCE` of the float; such a
fraction is unique, because two of them lie at least 1/MAX_DENOMINATOR²
apart, far more than floating-point noise. A float that is no such fraction
is kept exactly as it is. ``fractions.Fraction.limit_denominator`` does the
search; nothing here is approximated beyond it.
"""

from __future__ import annotations

from collections.abc import Iterable
from fractions import Fraction

import numpy as np

#: Largest denominator recovered: 60 s × decisions × runs stays far below it.
MAX_DENOMINATOR = 10**6
#: Relative distance within which a float is taken to be the fraction.
TOLERANCE = 1e-13


def exact_value(value: float) -> Fraction:
    """The small-denominator fraction ``value`` is the rounded image of, else the float itself."""
    exact = Fraction(value)
    candidate = exact.limit_denominator(MAX_DENOMINATOR)
    if abs(candidate - exact) <= TOLERANCE * max(1.0, abs(value)):
        return candidate
    return exact


def snapped(values: Iterable[float]) -> np.ndarray:
    """Each value as the float nearest its exact fraction: equal fractions, equal floats.

    Missing and infinite values pass through unchanged.
    """
    array = np.asarray(list(values), dtype=float)
    out = array.copy()
    finite = np.isfinite(array)
    out[finite] = [float(exact_value(value)) for value in array[finite]]
    return out


def exact_differences(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """``first − second`` taken on the exact values, then rounded once to floats.

    Equal exact differences therefore come out as equal floats, and a zero
    difference is exactly zero. Pairs with a missing value give NaN.
    """
    out = np.full(len(first), np.nan)
    for index, (a, b) in enumerate(zip(first, second, strict=True)):
        if np.isfinite(a) and np.isfinite(b):
            out[index] = float(exact_value(float(a)) - exact_value(float(b)))
    return out
