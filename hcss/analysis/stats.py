"""Omnibus and two-sample tests, and correlations, as small typed results.

Each function takes plain arrays (or a mapping of group name to values) and
returns a frozen :class:`TestResult`, so table builders only arrange numbers
and tests can compare them with R's output. The computation is scipy's; the
code here chooses the options the study's R analysis used and adds the
effect sizes scipy does not report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class TestResult:
    """One test: its statistic, degrees of freedom, p, sample size and effect.

    ``df`` is NaN for tests without degrees of freedom (Mann-Whitney).
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

    __test__ = False  # not a pytest test class, despite its name

    def apa(self) -> str:
        """The result as the study writes it, e.g. ``χ²(4, N = 116) = 29.27, p < .001``."""
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
    return array[~np.isnan(array)]


def _has_ties(values: np.ndarray) -> bool:
    return len(np.unique(values)) < len(values)


def kruskal_wallis(groups: Mapping[str, Sequence[float]]) -> TestResult:
    """Kruskal-Wallis H across groups, tie-corrected as R's ``kruskal.test``.

    Effect size ε² = H / (n − 1) (Tomczak & Tomczak 2014), which reads as the
    share of rank variance explained by the grouping. Groups without values
    are dropped; at least two non-empty groups are needed.
    """
    samples = [values for values in map(_clean, groups.values()) if len(values)]
    if len(samples) < 2:
        raise ValueError("Kruskal-Wallis needs at least two groups with values")
    n = sum(len(values) for values in samples)
    pooled = np.concatenate(samples)
    if np.all(pooled == pooled[0]):
        return TestResult("kruskal_wallis", "H", 0.0, len(samples) - 1, 1.0, n, "ε²", 0.0)
    statistic, p = stats.kruskal(*samples)
    return TestResult(
        "kruskal_wallis",
        "H",
        float(statistic),
        float(len(samples) - 1),
        float(p),
        n,
        "ε²",
        float(statistic) / (n - 1),
    )


MannWhitneyMethod = Literal["auto", "exact", "asymptotic"]


def mann_whitney(
    first: Sequence[float],
    second: Sequence[float],
    method: MannWhitneyMethod = "auto",
    continuity: bool = True,
) -> TestResult:
    """Two-sided Mann-Whitney-Wilcoxon test with R's ``wilcox.test`` defaults.

    U is R's W: the rank sum of ``first`` minus n₁(n₁ + 1)/2. ``method="auto"``
    follows R rather than scipy: exact when both samples have fewer than 50
    values and there are no ties, else the normal approximation with tie
    correction and, if ``continuity``, the continuity correction. (scipy's
    own "auto" switches at 8 values, which would not reproduce the study.)

    Effect size: rank-biserial r = 2U / (n₁n₂) − 1, positive when ``first``
    tends to be larger.
    """
    x, y = _clean(first), _clean(second)
    if not len(x) or not len(y):
        raise ValueError("Mann-Whitney needs values in both samples")
    if method == "auto":
        exact = len(x) < 50 and len(y) < 50 and not _has_ties(np.concatenate([x, y]))
        method = "exact" if exact else "asymptotic"
    result = stats.mannwhitneyu(
        x, y, alternative="two-sided", method=method, use_continuity=continuity
    )
    u = float(result.statistic)
    description = method if method == "exact" else f"asymptotic, continuity={continuity}"
    return TestResult(
        "mann_whitney",
        "U",
        u,
        float("nan"),
        float(result.pvalue),
        len(x) + len(y),
        "r",
        2.0 * u / (len(x) * len(y)) - 1.0,
        description,
    )


def spearman(first: Sequence[float], second: Sequence[float]) -> TestResult:
    """Spearman's rank correlation with its two-sided p.

    Pairs with a missing value are dropped. p comes from scipy's t
    approximation with n − 2 degrees of freedom (reported as df); R's
    ``cor.test`` would use an exact permutation p for small samples without
    ties, so p may differ from R there, while ρ is identical. The effect size
    is ρ itself.
    """
    x = np.asarray(first, dtype=float)
    y = np.asarray(second, dtype=float)
    keep = ~(np.isnan(x) | np.isnan(y))
    x, y = x[keep], y[keep]
    n = len(x)
    if n < 3:
        raise ValueError("Spearman correlation needs at least three complete pairs")
    if np.all(x == x[0]) or np.all(y == y[0]):
        raise ValueError("Spearman correlation is undefined for a constant variable")
    rho, p = stats.spearmanr(x, y)
    return TestResult("spearman", "ρ", float(rho), float(n - 2), float(p), n, "ρ", float(rho))
