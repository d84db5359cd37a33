"""Pairwise comparisons after an omnibus test, as small typed results.

Three flavours, because the study's analyses used more than one:

- :func:`tukey_kramer_ranks`: Tukey-Kramer on the Kruskal-Wallis mean ranks,
  as MATLAB's ``multcompare`` does after ``kruskalwallis``. No scipy,
  statsmodels or scikit-posthocs function computes this, so it is written
  here, from R's studentized-range distribution (:mod:`r_distributions`).
- :func:`tukey_hsd`: classic Tukey HSD (Tukey-Kramer for unequal sizes) on
  the raw values, as R's ``TukeyHSD(aov(...))`` (a group of one value included).
- :func:`dunn_holm`: Dunn's z test on mean ranks with Holm's step-down
  adjustment; raw p from scikit-posthocs, z and Holm recomputed here.

Every row is oriented ``group_a − group_b`` with ``group_a`` earlier in the
given order; :meth:`PairwiseComparison.pair` turns a row round if needed.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import combinations

import numpy as np
import pandas as pd
import scikit_posthocs
from scipy import stats

from hcss.analysis.r_distributions import holm, qtukey, tukey_sf
from hcss.analysis.stats import ALL_EQUAL, all_equal


@dataclass(frozen=True)
class PairRow:
    """One pair: difference (of means or mean ranks), its interval, statistic and p."""

    group_a: str
    group_b: str
    difference: float
    lower: float
    upper: float
    statistic: float
    p: float


@dataclass(frozen=True)
class PairwiseComparison:
    """All pairs of one post-hoc test; ``statistic_name`` is q or z."""

    test: str
    statistic_name: str
    n: int
    rows: tuple[PairRow, ...]
    note: str = ""

    def pair(self, group_a: str, group_b: str) -> PairRow:
        """The row for ``group_a − group_b``, turned round if stored the other way."""
        for row in self.rows:
            if (row.group_a, row.group_b) == (group_a, group_b):
                return row
            if (row.group_a, row.group_b) == (group_b, group_a):
                return replace(
                    row,
                    group_a=group_a,
                    group_b=group_b,
                    difference=-row.difference,
                    lower=-row.upper,
                    upper=-row.lower,
                    statistic=-row.statistic,
                )
        raise KeyError(f"no pair {group_a} − {group_b}")


def _samples(groups: Mapping[str, Sequence[float]]) -> dict[str, np.ndarray]:
    cleaned = {name: np.asarray(values, dtype=float) for name, values in groups.items()}
    cleaned = {name: values[~np.isnan(values)] for name, values in cleaned.items()}
    cleaned = {name: values for name, values in cleaned.items() if len(values)}
    if len(cleaned) < 2:
        raise ValueError("a pairwise comparison needs at least two groups with values")
    return cleaned


def rank_variance(values: np.ndarray) -> float:
    """Variance of the ranks 1..N, corrected for ties: N(N+1)/12 − Σ(t³−t)/(12(N−1))."""
    n = len(values)
    _, ties = np.unique(values, return_counts=True)
    ties = ties.astype(float)
    return n * (n + 1) / 12.0 - float(np.sum(ties**3 - ties)) / (12.0 * (n - 1))


def _mean_ranks(samples: dict[str, np.ndarray]) -> tuple[dict[str, float], float, int]:
    pooled = np.concatenate(list(samples.values()))
    ranks = stats.rankdata(pooled)
    mean_ranks, start = {}, 0
    for name, values in samples.items():
        mean_ranks[name] = float(ranks[start : start + len(values)].mean())
        start += len(values)
    return mean_ranks, rank_variance(pooled), len(pooled)


def tukey_kramer_ranks(
    groups: Mapping[str, Sequence[float]], alpha: float = 0.05
) -> PairwiseComparison:
    """Tukey-Kramer comparisons of Kruskal-Wallis mean ranks (``multcompare`` style).

    For groups i, j with nᵢ, nⱼ values: se = sqrt(v·(1/nᵢ + 1/nⱼ)/2), with v
    the tie-corrected rank variance, q = (R̄ᵢ − R̄ⱼ)/se, and p from the
    studentized range with k groups and infinite degrees of freedom (the
    ranks' variance is known, not estimated): R's ``ptukey(q, k, Inf)``,
    which integrates the range of k normals only. Intervals are
    R̄ᵢ − R̄ⱼ ± q₁₋α·se.
    """
    samples = _samples(groups)
    if all_equal(np.concatenate(list(samples.values()))):
        return _undefined("tukey_kramer_ranks", "q", samples)
    mean_ranks, variance, n = _mean_ranks(samples)
    k = len(samples)
    critical = qtukey(1 - alpha, k, math.inf)
    rows = []
    for a, b in combinations(samples, 2):
        se = np.sqrt(variance * (1 / len(samples[a]) + 1 / len(samples[b])) / 2.0)
        difference = mean_ranks[a] - mean_ranks[b]
        q = difference / se
        p = tukey_sf(abs(q), k, math.inf)
        rows.append(
            PairRow(
                a,
                b,
                difference,
                float(difference - critical * se),
                float(difference + critical * se),
                float(q),
                min(p, 1.0),
            )
        )
    return PairwiseComparison("tukey_kramer_ranks", "q", n, tuple(rows))


def tukey_hsd(groups: Mapping[str, Sequence[float]], alpha: float = 0.05) -> PairwiseComparison:
    """Classic Tukey HSD on raw values (``TukeyHSD(aov(y ~ g))`` in R).

    Computed as R does, not through ``scipy.stats.tukey_hsd``, which refuses
    a group of one value: a single value contributes no spread, but the
    pooled error variance MSE (from the other groups, N − k df) exists, so
    its mean can still be compared. For groups i, j:
    se = sqrt(MSE/2 · (1/nᵢ + 1/nⱼ)), q = (ȳᵢ − ȳⱼ)/se, p = P(Q > |q|) for
    the studentized range with k groups and N − k df, and the interval
    diff ± q₁₋α·se, with p and q₁₋α from R's own ``ptukey``/``qtukey``
    (:mod:`hcss.analysis.r_distributions`). Undefined (NaN, with a note) when there are no error df
    (every group has one value) or no error variance.
    """
    samples = _samples(groups)
    names = list(samples)
    sizes = [len(values) for values in samples.values()]
    n, k = sum(sizes), len(names)
    error_df = n - k
    if error_df < 1:
        return _undefined("tukey_hsd", "q", samples, "no error degrees of freedom (N = k)")
    mean_square_error = (
        sum(float(((values - values.mean()) ** 2).sum()) for values in samples.values()) / error_df
    )
    if mean_square_error == 0:
        note = (
            ALL_EQUAL
            if all_equal(np.concatenate(list(samples.values())))
            else ("no variance within groups")
        )
        return _undefined("tukey_hsd", "q", samples, note)
    means = [float(values.mean()) for values in samples.values()]
    critical = qtukey(1 - alpha, k, float(error_df))
    pairs = list(combinations(range(k), 2))
    differences = np.array([means[i] - means[j] for i, j in pairs])
    errors = np.sqrt(
        mean_square_error / 2 * np.array([1 / sizes[i] + 1 / sizes[j] for i, j in pairs])
    )
    q = differences / errors
    p = np.array([tukey_sf(abs(value), k, float(error_df)) for value in q])
    rows = [
        PairRow(
            names[i],
            names[j],
            float(differences[index]),
            float(differences[index] - critical * errors[index]),
            float(differences[index] + critical * errors[index]),
            float(q[index]),
            float(p[index]),
        )
        for index, (i, j) in enumerate(pairs)
    ]
    note = "a group has one value (it adds no spread to MSE)" if min(sizes) == 1 else ""
    return PairwiseComparison("tukey_hsd", "q", n, tuple(rows), note)


def _undefined(
    test: str, statistic: str, samples: dict[str, np.ndarray], note: str = ALL_EQUAL
) -> PairwiseComparison:
    """Every pair with NaN difference-test results: what R returns for degenerate data."""
    nan = float("nan")
    rows = tuple(
        PairRow(a, b, float(samples[a].mean() - samples[b].mean()), nan, nan, nan, nan)
        for a, b in combinations(samples, 2)
    )
    return PairwiseComparison(test, statistic, sum(map(len, samples.values())), rows, note)


def dunn_holm(groups: Mapping[str, Sequence[float]]) -> PairwiseComparison:
    """Dunn's test on mean ranks with Holm-adjusted p.

    z = (R̄ᵢ − R̄ⱼ) / sqrt(v·(1/nᵢ + 1/nⱼ)), v the tie-corrected rank variance.
    The unadjusted two-sided p come from scikit-posthocs' ``posthoc_dunn``;
    z and the mean-rank difference are recomputed here because it returns
    only the p matrix, and Holm's adjustment is :func:`holm`. Intervals are
    not defined for a step-down adjustment and are left NaN.
    """
    samples = _samples(groups)
    if all_equal(np.concatenate(list(samples.values()))):
        return _undefined("dunn_holm", "z", samples)
    long = pd.DataFrame(
        {
            "value": np.concatenate(list(samples.values())),
            "group": np.repeat(list(samples), [len(values) for values in samples.values()]),
        }
    )
    p_matrix = scikit_posthocs.posthoc_dunn(long, val_col="value", group_col="group")
    mean_ranks, variance, n = _mean_ranks(samples)
    pairs = list(combinations(samples, 2))
    adjusted = holm([float(p_matrix.loc[a, b]) for a, b in pairs])
    rows = []
    for (a, b), p in zip(pairs, adjusted, strict=True):
        se = np.sqrt(variance * (1 / len(samples[a]) + 1 / len(samples[b])))
        difference = mean_ranks[a] - mean_ranks[b]
        z = difference / se
        rows.append(PairRow(a, b, difference, np.nan, np.nan, float(z), float(p)))
    return PairwiseComparison("dunn_holm", "z", n, tuple(rows))
