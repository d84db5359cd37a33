"""The Hodges–Lehmann shift between two samples and its 95% interval, as R's ``wilcox.test``.

A rank test's p says whether two samples differ; the shift says by how much,
in the measure's own unit (minutes, percentage points). The estimate is the
median of all pairwise differences x − y (Hodges and Lehmann 1963), which is
R's estimate whenever R's test is exact. The interval inverts the same rank
test R uses (``wilcox.test(x, y, conf.int = TRUE)``):

- exact (both samples under 50 values, no ties): order statistics of the
  pairwise differences at ``qwilcox(0.025, n₁, n₂)``;
- otherwise the shifts d where the tie- and continuity-corrected normal score
  of the rank sum of x − d against y crosses ±1.96, found by root search
  on the same step function R searches (R stops at ``tol.root`` 1e-4, so
  R's ends agree to about that).

With ties R's *estimate* is also a root search (of the score without
continuity correction), which lands anywhere on a flat stretch of that step
function; the median of the differences is the estimator's definition and is
what is reported here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import optimize, stats

#: Both samples below this size and no ties: R's exact branch.
EXACT_BELOW = 50
_Z = float(stats.norm.ppf(0.975))


@dataclass(frozen=True)
class Shift:
    """Estimated location shift first − second, its 95% interval and how it was found."""

    estimate: float
    lower: float
    upper: float
    method: str


def _wilcox_counts(m: int, n: int) -> np.ndarray:
    """Number of arrangements of m x's and n y's for each U = 0..mn (the null of W)."""
    # counts[j][u]: arrangements of i x's and j y's with U = u, built up over i.
    previous = [np.ones(1, dtype=float) for _ in range(n + 1)]  # i = 0: U = 0 only
    for i in range(1, m + 1):
        current = [np.ones(1, dtype=float)]  # j = 0: U = 0
        for j in range(1, n + 1):
            # The largest value is an x (adds j to U) or a y (adds nothing).
            with_x = np.concatenate([np.zeros(j), previous[j]])
            with_y = current[j - 1]
            size = i * j + 1
            counts = np.zeros(size)
            counts[: len(with_x)] += with_x[:size]
            counts[: len(with_y)] += with_y
            current.append(counts)
        previous = current
    return previous[n]


def _qwilcox(p: float, m: int, n: int) -> int:
    """R's ``qwilcox(p, m, n)``: the smallest u with P(U ≤ u) ≥ p."""
    cumulative = np.cumsum(_wilcox_counts(m, n))
    cumulative /= cumulative[-1]
    return int(np.searchsorted(cumulative, p * (1 - 64 * np.finfo(float).eps)))


def _score(x: np.ndarray, y: np.ndarray, d: float, correct: bool) -> float:
    """R's W(d): the normal score of the rank sum of x − d against y."""
    n_x, n_y = len(x), len(y)
    ranks = stats.rankdata(np.concatenate([x - d, y]))
    dz = ranks[:n_x].sum() - n_x * (n_x + 1) / 2 - n_x * n_y / 2
    _, ties = np.unique(ranks, return_counts=True)
    ties = ties.astype(float)
    sigma = math.sqrt(
        (n_x * n_y / 12)
        * ((n_x + n_y + 1) - float(np.sum(ties**3 - ties)) / ((n_x + n_y) * (n_x + n_y - 1)))
    )
    correction = math.copysign(0.5, dz) if correct and dz != 0 else 0.0
    return (dz - correction) / sigma if sigma > 0 else math.nan


def _asymptotic_end(x: np.ndarray, y: np.ndarray, zq: float) -> float:
    low, high = float(x.min() - y.max()), float(x.max() - y.min())
    f_low = _score(x, y, low, True) - zq
    if f_low <= 0:
        return low
    f_high = _score(x, y, high, True) - zq
    if f_high >= 0:
        return high
    return float(
        optimize.brentq(lambda d: _score(x, y, d, True) - zq, low, high, xtol=1e-10, rtol=1e-12)
    )


def _kth_difference(x: np.ndarray, y: np.ndarray, k: int) -> float:
    """The k-th smallest (1-based) of all x_i − y_j, for sorted x and y, exactly.

    The n₁n₂ differences are never held in memory (5,040 units a model would take 200 MB
    twice over): bisection on the value, counting the differences at or below it with one
    sorted search, then the largest difference at or below the bound found.
    """
    low, high = float(x[0] - y[-1]), float(x[-1] - y[0])

    def at_most(value: float) -> int:
        return int(np.sum(len(y) - np.searchsorted(y, x - value, side="left")))

    for _ in range(200):
        middle = (low + high) / 2
        if middle in (low, high):
            break
        if at_most(middle) >= k:
            high = middle
        else:
            low = middle
    # the largest difference ≤ high: per x_i, the smallest y_j ≥ x_i − high
    index = np.searchsorted(y, x - high, side="left")
    valid = index < len(y)
    return float(np.max(x[valid] - y[index[valid]]))


def _median_difference(x: np.ndarray, y: np.ndarray) -> float:
    """The median of all pairwise differences, as ``np.median(np.subtract.outer(x, y))``."""
    count = len(x) * len(y)
    if count % 2:
        return _kth_difference(x, y, count // 2 + 1)
    return (_kth_difference(x, y, count // 2) + _kth_difference(x, y, count // 2 + 1)) / 2


def hodges_lehmann(first: Sequence[float], second: Sequence[float]) -> Shift:
    """Shift of ``first`` over ``second`` with R's 95% interval (module docstring).

    Missing values are dropped. Every value tied: the estimate 0 (or the one
    difference) and no interval, as R cannot give one.
    """
    x = np.asarray(first, dtype=float)
    y = np.asarray(second, dtype=float)
    x, y = x[~np.isnan(x)], y[~np.isnan(y)]
    if not len(x) or not len(y):
        raise ValueError("a shift needs values in both samples")
    estimate = _median_difference(np.sort(x), np.sort(y))
    pooled = np.concatenate([x, y])
    ties = len(np.unique(pooled)) < len(pooled)
    if len(x) < EXACT_BELOW and len(y) < EXACT_BELOW and not ties:
        differences = np.sort(np.subtract.outer(x, y).ravel())
        upper_index = _qwilcox(0.025, len(x), len(y)) or 1
        lower_index = len(x) * len(y) - upper_index
        return Shift(
            estimate,
            float(differences[upper_index - 1]),
            float(differences[lower_index]),
            "exact (order statistics of the pairwise differences)",
        )
    if np.all(pooled == pooled[0]):
        return Shift(estimate, math.nan, math.nan, "all values equal: no interval")
    return Shift(
        estimate,
        _asymptotic_end(x, y, _Z),
        _asymptotic_end(x, y, -_Z),
        "asymptotic (normal score, tie- and continuity-corrected, inverted)",
    )
