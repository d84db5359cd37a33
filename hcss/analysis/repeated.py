"""Tests that respect the repeated-measures design: each participant meets M1, M2 and M3.

The paper compared the three human conditions as independent groups
(Kruskal-Wallis, Tukey-Kramer); those tables stay, as the paper's. A
reviewer would ask for the paired analysis, which this module gives, with
R's conventions so a check in R agrees:

- :func:`friedman`: ``friedman.test`` (tie-corrected), with Kendall's
  W = χ² / (n(k − 1)) as ``rstatix::friedman_effsize`` reports it and a
  bootstrap interval over participants;
- :func:`paired_wilcoxon`: ``wilcox.test(x, y, paired = TRUE)``: zero
  differences dropped, exact signed-rank p when n < 50 without ties or
  zeros, else the normal approximation with tie and continuity corrections;
  effect size the matched-pairs rank-biserial r = (T₊ − T₋) / (T₊ + T₋),
  signed like the difference, with its Fisher-z interval, as
  ``effectsize::rank_biserial(Pair(x, y) ~ 1)``: zero differences are
  dropped from r and from its standard error alike.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import numpy as np
import pandas as pd
from scipy import stats

from hcss.analysis.effect_intervals import (
    kendalls_w_interval,
    paired_rank_biserial_interval,
)
from hcss.analysis.exact import exact_differences
from hcss.analysis.stats import ALL_EQUAL, TestResult, all_equal


def friedman(blocks: pd.DataFrame) -> TestResult:
    """Friedman χ² over the columns (conditions) of ``blocks`` (one row per participant).

    Rows with a missing value are dropped, as R's ``friedman.test`` does with
    incomplete blocks. Needs two or more complete rows and columns.
    """
    complete = blocks.dropna().to_numpy(dtype=float)
    n, k = complete.shape
    if n < 2 or k < 2:
        raise ValueError("Friedman needs at least two participants with every condition")
    ranks = np.apply_along_axis(stats.rankdata, 1, complete)
    ties = sum(
        float(((counts**3) - counts).sum())
        for counts in (np.unique(row, return_counts=True)[1] for row in complete)
    )
    denominator = n * k * (k + 1) - ties / (k - 1)
    df = float(k - 1)
    if denominator == 0 or all(all_equal(row) for row in complete):
        nan = float("nan")
        return TestResult("friedman", "χ²", nan, df, nan, n, "Kendall's W", nan, note=ALL_EQUAL)
    sums = ranks.sum(axis=0)
    statistic = 12.0 * float(((sums - n * (k + 1) / 2.0) ** 2).sum()) / denominator
    p = float(stats.chi2.sf(statistic, df))
    interval = kendalls_w_interval(complete)
    return TestResult(
        "friedman",
        "χ²",
        statistic,
        df,
        p,
        n,
        "Kendall's W",
        statistic / (n * df),
        FRIEDMAN_METHOD,
        effect_lower=interval.lower,
        effect_upper=interval.upper,
        interval_method=interval.method,
    )


FRIEDMAN_METHOD = "χ² approximation, tie-corrected"
PAIRED_EFFECT = "matched-pairs rank-biserial r"


@lru_cache(maxsize=64)
def _signed_rank_counts(n: int) -> np.ndarray:
    """Number of subsets of {1..n} with each sum 0..n(n+1)/2: the null of V × 2ⁿ."""
    counts = np.zeros(n * (n + 1) // 2 + 1, dtype=float)
    counts[0] = 1.0
    for rank in range(1, n + 1):
        counts[rank:] = counts[rank:] + counts[:-rank].copy()
    return counts


def _psignrank(v: float, n: int, lower_tail: bool) -> float:
    """R's psignrank: P(V ≤ v) or P(V > v)."""
    counts = _signed_rank_counts(n)
    cumulative = counts[: int(math.floor(v)) + 1].sum() / counts.sum() if v >= 0 else 0.0
    return float(cumulative if lower_tail else 1.0 - cumulative)


def paired_wilcoxon(first: Sequence[float], second: Sequence[float]) -> TestResult:
    """Two-sided Wilcoxon signed-rank test of ``first − second``, as R's paired wilcox.test.

    The statistic is R's V, the sum of the ranks of positive differences.
    Differences are taken on the exact values (:func:`exact_differences`),
    so two pairs whose differences are equal in exact arithmetic tie, as
    they do in R given the exact values (or ``digits.rank = 7`` on the same
    doubles; R's default ``digits.rank = Inf`` can split such a tie).
    Pairs with a missing value are dropped; ``n`` is the number of pairs
    with a non-zero difference (the pairs the test uses).
    """
    x = np.asarray(first, dtype=float)
    y = np.asarray(second, dtype=float)
    if x.shape != y.shape:
        raise ValueError("a paired test needs two samples of the same length")
    keep = ~(np.isnan(x) | np.isnan(y))
    differences = exact_differences(x[keep], y[keep])
    zeros = bool((differences == 0).any())
    differences = differences[differences != 0]
    n = len(differences)
    if n == 0:
        nan = float("nan")
        if not keep.any():
            raise ValueError("a paired test needs at least one complete pair")
        return TestResult(
            "wilcoxon_paired", "V", nan, nan, nan, 0, PAIRED_EFFECT, nan, note=ALL_EQUAL
        )
    ranks = stats.rankdata(np.abs(differences))
    v = float(ranks[differences > 0].sum())
    _, tie_counts = np.unique(ranks, return_counts=True)
    sigma = math.sqrt(
        n * (n + 1) * (2 * n + 1) / 24.0 - float((tie_counts**3 - tie_counts).sum()) / 48.0
    )
    centred = v - n * (n + 1) / 4.0
    ties = bool((tie_counts > 1).any())
    if n < 50 and not ties and not zeros:
        if v > n * (n + 1) / 4:
            one_sided = _psignrank(v - 1, n, lower_tail=False)
        else:
            one_sided = _psignrank(v, n, lower_tail=True)
        p, method = min(2 * one_sided, 1.0), "exact"
    elif sigma == 0:
        p, method = float("nan"), "asymptotic"
    else:
        z = (centred - math.copysign(0.5, centred) if centred != 0 else 0.0) / sigma
        p = float(min(2 * min(stats.norm.cdf(z), stats.norm.sf(z)), 1.0))
        method = "asymptotic, continuity=True"
        if zeros or ties:
            method += " (ties or zero differences: no exact p, as R)"
        elif n >= 50:
            method += " (n ≥ 50)"
    total = n * (n + 1) / 2.0
    effect = (v - (total - v)) / total
    interval = paired_rank_biserial_interval(effect, n)
    return TestResult(
        "wilcoxon_paired",
        "V",
        v,
        float("nan"),
        p,
        n,
        PAIRED_EFFECT,
        effect,
        method,
        effect_lower=interval.lower,
        effect_upper=interval.upper,
        interval_method=interval.method,
    )
