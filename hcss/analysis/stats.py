"""Omnibus and two-sample tests, and correlations, as small typed results.

Each function takes plain arrays (or a mapping of group name to values) and
returns a frozen :class:`TestResult`, so table builders only arrange numbers
and tests can compare them with R's output. The computation is scipy's; the
code here chooses the options the study's R analysis used and adds the
effect sizes scipy does not report.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import stats

from hcss.analysis.effect_intervals import (
    epsilon_squared_interval,
    rank_biserial_interval,
    spearman_interval,
)
from hcss.analysis.r_distributions import spearman_p

ALL_EQUAL = "all values equal"
KRUSKAL_METHOD = "χ² approximation, tie-corrected"
KRUSKAL_METHOD_UNTIED = "χ² approximation (no ties)"
RANK_BISERIAL = "rank-biserial r"


@dataclass(frozen=True)
class TestResult:
    """One test: its statistic, degrees of freedom, p, sample size and effect.

    ``df`` is NaN for tests without degrees of freedom (Mann-Whitney).
    ``effect_lower``/``effect_upper`` bound the effect size's 95% confidence
    interval, computed as ``interval_method`` says
    (:mod:`hcss.analysis.effect_intervals`); NaN when none can be given. A test
    that R would answer with NaN (every value tied) has NaN statistic and p
    and says why in ``note``, so no table shows a p that looks like a result.
    """

    test: str
    statistic_name: str
    statistic: float
    df: float
    p: float
    n: int
    effect_name: str
    effect_size: float
    method: str = ""
    note: str = ""
    effect_lower: float = math.nan
    effect_upper: float = math.nan
    interval_method: str = ""

    __test__ = False  # not a pytest test class, despite its name

    def apa(self) -> str:
        """The result as the study writes it, e.g. ``χ²(4, N = 116) = 29.27, p < .001``."""
        if math.isnan(self.p):
            return f"{self.statistic_name} undefined ({self.note or 'no p-value'})"
        p_text = "p < .001" if self.p < 0.001 else f"p = {self.p:.3f}"
        if self.test == "kruskal_wallis":
            head = f"χ²({self.df:g}, N = {self.n}) = {self.statistic:.2f}"
        elif self.test == "spearman":
            head = f"rₛ({self.df:g}) = {self.statistic:.2f}"
        else:
            head = f"{self.statistic_name} = {self.statistic:.2f}"
        return f"{head}, {p_text}, {self.effect_name} = {self.effect_size:.2f}"


def _clean(values: Sequence[float] | np.ndarray) -> np.ndarray:
    """Values as floats with missing ones dropped, as R's na.omit would."""
    array = np.asarray(values, dtype=float)
    return np.asarray(array[~np.isnan(array)])


def _has_ties(values: np.ndarray) -> bool:
    return len(np.unique(values)) < len(values)


def all_equal(values: np.ndarray) -> bool:
    """True when every value is the same: rank tests have no variance to test."""
    return len(values) > 0 and bool(np.all(values == values[0]))


def kruskal_wallis(groups: Mapping[str, Sequence[float]]) -> TestResult:
    """Kruskal-Wallis H across groups, tie-corrected as R's ``kruskal.test``.

    Effect size ε² = H / (n − 1) (Tomczak & Tomczak 2014), which reads as the
    share of rank variance explained by the grouping. Groups without values
    are dropped; at least two non-empty groups are needed. When every value
    is tied R returns NaN (0/0 after the tie correction); so does this, with
    the note "all values equal".
    """
    samples = [values for values in map(_clean, groups.values()) if len(values)]
    if len(samples) < 2:
        raise ValueError("Kruskal-Wallis needs at least two groups with values")
    n = sum(len(values) for values in samples)
    df = float(len(samples) - 1)
    if all_equal(np.concatenate(samples)):
        nan = float("nan")
        return TestResult("kruskal_wallis", "H", nan, df, nan, n, "ε²", nan, note=ALL_EQUAL)
    statistic, p = stats.kruskal(*samples)
    interval = epsilon_squared_interval(samples)
    return TestResult(
        "kruskal_wallis",
        "H",
        float(statistic),
        df,
        float(p),
        n,
        "ε²",
        float(statistic) / (n - 1),
        KRUSKAL_METHOD if _has_ties(np.concatenate(samples)) else KRUSKAL_METHOD_UNTIED,
        effect_lower=interval.lower,
        effect_upper=interval.upper,
        interval_method=interval.method,
    )


MannWhitneyMethod = Literal["auto", "exact", "asymptotic"]

#: Note when exact p was asked for but ties forbid it (R's warning, reworded).
EXACT_WITH_TIES = "cannot compute exact p-value with ties: normal approximation used, as R does"


def mann_whitney(
    first: Sequence[float],
    second: Sequence[float],
    method: MannWhitneyMethod = "auto",
    continuity: bool = True,
) -> TestResult:
    """Two-sided Mann-Whitney-Wilcoxon test with R's ``wilcox.test`` defaults.

    The statistic is R's W: the rank sum of ``first`` minus n₁(n₁ + 1)/2
    (U₁); the paper's U = min(U₁, U₂) is :func:`mann_whitney_u`.
    ``method="auto"`` follows R rather than scipy: exact when both samples
    have fewer than 50 values and there are no ties, else the normal
    approximation with tie correction and, if ``continuity``, the continuity
    correction. (scipy's own "auto" switches at 8 values.) ``"exact"`` with
    ties does what R does: the exact distribution assumes no ties, so the
    normal approximation is used and ``note`` says so (scipy would silently
    return the exact p of untied data).

    Effect size: rank-biserial r = 2U₁ / (n₁n₂) − 1, positive when ``first``
    tends to be larger. Every value tied: NaN, as R.
    """
    x, y = _clean(first), _clean(second)
    if not len(x) or not len(y):
        raise ValueError("Mann-Whitney needs values in both samples")
    pooled = np.concatenate([x, y])
    note = ""
    reason = ""
    if method == "auto":
        exact = len(x) < 50 and len(y) < 50 and not _has_ties(pooled)
        if not exact:
            reason = "ties: no exact p" if _has_ties(pooled) else "n ≥ 50"
        method = "exact" if exact else "asymptotic"
    elif method == "exact" and _has_ties(pooled):
        method, note, reason = "asymptotic", EXACT_WITH_TIES, "ties: no exact p"
    description = method if method == "exact" else f"asymptotic, continuity={continuity}"
    if reason:
        description += f" ({reason})"
    if all_equal(pooled):
        u = len(x) * len(y) / 2.0
        nan = float("nan")
        return TestResult(
            "mann_whitney",
            "W",
            u,
            nan,
            nan,
            len(pooled),
            RANK_BISERIAL,
            nan,
            description,
            ALL_EQUAL,
        )
    result = stats.mannwhitneyu(
        x, y, alternative="two-sided", method=method, use_continuity=continuity
    )
    u = float(result.statistic)
    r = 2.0 * u / (len(x) * len(y)) - 1.0
    interval = rank_biserial_interval(r, len(x), len(y))
    return TestResult(
        "mann_whitney",
        "W",
        u,
        float("nan"),
        float(result.pvalue),
        len(pooled),
        RANK_BISERIAL,
        r,
        description,
        note,
        interval.lower,
        interval.upper,
        interval.method,
    )


def mann_whitney_u(result: TestResult, n_first: int, n_second: int) -> float:
    """The paper's U = min(U₁, U₂) from R's W (= U₁)."""
    return min(result.statistic, n_first * n_second - result.statistic)


def spearman(first: Sequence[float], second: Sequence[float]) -> TestResult:
    """Spearman's rank correlation with its two-sided p, as R's ``cor.test`` default.

    Pairs with a missing value are dropped. p is exact (permutation) for
    n ≤ 9 and an Edgeworth series for larger n when there are no ties, and
    the t approximation with n − 2 df otherwise (:mod:`r_distributions`); the
    result's ``method`` names which. df is n − 2. A constant variable has no
    correlation: R gives NA, this gives NaN with the note "all values equal".
    """
    x = np.asarray(first, dtype=float)
    y = np.asarray(second, dtype=float)
    keep = ~(np.isnan(x) | np.isnan(y))
    x, y = x[keep], y[keep]
    n = len(x)
    if n < 3:
        raise ValueError("Spearman correlation needs at least three complete pairs")
    if all_equal(x) or all_equal(y):
        nan = float("nan")
        return TestResult("spearman", "ρ", nan, float(n - 2), nan, n, "ρ", nan, note=ALL_EQUAL)
    rho = float(stats.spearmanr(x, y).statistic)
    p, method = spearman_p(rho, n, _has_ties(x) or _has_ties(y))
    interval = spearman_interval(rho, n)
    return TestResult("spearman", "ρ", rho, float(n - 2), p, n, "ρ", rho, method, "", *interval)
