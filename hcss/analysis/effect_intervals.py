"""95% confidence intervals for the effect sizes the tables show.

Analytic where a standard interval exists, from the effect's sampling
distribution on Fisher's z scale:

- rank-biserial r of two independent samples: SE of atanh(r) =
  √((n₁ + n₂ + 1) / (3n₁n₂)); of matched pairs (n non-zero differences):
  √((2n³ + 3n² + n) / 6) / (n(n + 1) / 2). Both as R's
  ``effectsize::rank_biserial``;
- Spearman's ρ: SE of atanh(ρ) = √((1 + ρ²/2) / (n − 3)) (Bonett & Wright
  2000), which holds for ranks where Pearson's 1/√(n − 3) is too narrow.

Otherwise a percentile bootstrap (``scipy.stats.bootstrap``, 2,000
resamples, seed :data:`SEED`, so a report is reproducible): ε² of
Kruskal-Wallis resamples within each group; Kendall's W of Friedman
resamples participants, each with all their conditions, because the
participant is the unit of the repeated-measures design. A bootstrap whose
resampled statistic is degenerate (every resample alike, or NaN, as when
almost every value is 0) gives no interval rather than scipy's warning.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence

import numpy as np
from scipy import stats

Z_975 = float(stats.norm.ppf(0.975))
SEED = 20_250_101
RESAMPLES = 2_000
BOOTSTRAP = f"percentile bootstrap, {RESAMPLES:,} resamples, seed {SEED}"
FISHER = "Fisher z"

Interval = tuple[float, float]
NO_INTERVAL: Interval = (math.nan, math.nan)


def _fisher(estimate: float, error: float) -> Interval:
    if not math.isfinite(estimate) or not math.isfinite(error) or abs(estimate) >= 1:
        return NO_INTERVAL
    centre = math.atanh(estimate)
    return math.tanh(centre - Z_975 * error), math.tanh(centre + Z_975 * error)


def rank_biserial_interval(r: float, n_first: int, n_second: int) -> Interval:
    """95% CI of the two-sample rank-biserial r (effectsize's Fisher-z interval)."""
    if n_first < 1 or n_second < 1:
        return NO_INTERVAL
    return _fisher(r, math.sqrt((n_first + n_second + 1) / (3.0 * n_first * n_second)))


def paired_rank_biserial_interval(r: float, n: int) -> Interval:
    """95% CI of the matched-pairs rank-biserial r of ``n`` complete pairs."""
    if n < 1:
        return NO_INTERVAL
    error = math.sqrt((2 * n**3 + 3 * n**2 + n) / 6.0) / (n * (n + 1) / 2.0)
    return _fisher(r, error)


def spearman_interval(rho: float, n: int) -> Interval:
    """95% CI of Spearman's ρ (Bonett & Wright's standard error); needs n ≥ 4."""
    if n < 4:
        return NO_INTERVAL
    return _fisher(rho, math.sqrt((1 + rho * rho / 2.0) / (n - 3)))


Statistic = Callable[..., np.ndarray]


def _percentile(samples: tuple[np.ndarray, ...], statistic: Statistic, paired: bool) -> Interval:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = stats.bootstrap(
            samples,
            statistic,
            paired=paired,
            vectorized=True,
            n_resamples=RESAMPLES,
            confidence_level=0.95,
            method="percentile",
            random_state=np.random.default_rng(SEED),
        )
    if caught:  # scipy: the resampled statistic is degenerate (e.g. almost every value 0)
        return NO_INTERVAL
    lower, upper = float(result.confidence_interval.low), float(result.confidence_interval.high)
    if not (math.isfinite(lower) and math.isfinite(upper)) or lower == upper:
        return NO_INTERVAL
    return lower, upper


def _epsilon_squared(*groups: np.ndarray, axis: int = -1) -> np.ndarray:
    pooled = np.concatenate(groups, axis=axis)
    ranks = stats.rankdata(pooled, axis=axis)
    n = pooled.shape[axis]
    ties = _tie_sum(ranks)
    start, h = 0, np.zeros(pooled.shape[:-1])
    for group in groups:
        size = group.shape[axis]
        mean_rank = ranks[..., start : start + size].mean(axis=axis)
        h += size * (mean_rank - (n + 1) / 2.0) ** 2
        start += size
    h *= 12.0 / (n * (n + 1))
    correction = 1.0 - ties / (n**3 - n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(h / correction / (n - 1), dtype=float)


def _tie_sum(ranks: np.ndarray) -> np.ndarray:
    """Σ(t³ − t) over the tie groups along the last axis, from the average ranks.

    A tie group of t values at average rank m loses (t³ − t)/12 of Σ rank²
    relative to untied ranks, so the sum follows from Σ rank² alone, which
    keeps the bootstrap vectorised.
    """
    n = ranks.shape[-1]
    return np.asarray(2.0 * n * (n + 1) * (2 * n + 1) - 12.0 * (ranks**2).sum(axis=-1))


def epsilon_squared_interval(groups: Sequence[Sequence[float] | np.ndarray]) -> Interval:
    """Bootstrap 95% CI of Kruskal-Wallis ε² = H/(n − 1), resampling within groups."""
    samples = tuple(np.asarray(group, dtype=float) for group in groups)
    if len(samples) < 2 or any(len(sample) < 2 for sample in samples):
        return NO_INTERVAL
    return _percentile(samples, _epsilon_squared, paired=False)


def _kendalls_w(*conditions: np.ndarray, axis: int = -1) -> np.ndarray:
    blocks = np.stack(conditions, axis=-1)  # (..., n, k)
    n, k = blocks.shape[-2], blocks.shape[-1]
    ranks = stats.rankdata(blocks, axis=-1)
    ties = _tie_sum(ranks).sum(axis=-1)
    sums = ranks.sum(axis=-2)
    chi2 = 12.0 * ((sums - n * (k + 1) / 2.0) ** 2).sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        chi2 = chi2 / (n * k * (k + 1) - ties / (k - 1))
        return np.asarray(chi2 / (n * (k - 1)), dtype=float)


def kendalls_w_interval(blocks: np.ndarray) -> Interval:
    """Bootstrap 95% CI of Kendall's W, resampling participants (rows) as clusters."""
    matrix = np.asarray(blocks, dtype=float)
    if matrix.ndim != 2 or matrix.shape[0] < 3 or matrix.shape[1] < 2:
        return NO_INTERVAL
    return _percentile(tuple(matrix.T), _kendalls_w, paired=True)
