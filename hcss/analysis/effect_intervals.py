"""95% confidence intervals for the effect sizes the tables show.

Analytic where a standard interval exists, from the effect's sampling
distribution on Fisher's z scale:

- rank-biserial r of two independent samples: SE of atanh(r) =
  √((n₁ + n₂ + 1) / (3n₁n₂)); of matched pairs: √((2n³ + 3n² + n) / 6) /
  (n(n + 1) / 2) with n the number of non-zero differences, the pairs r
  itself is computed from (zero differences dropped). Both as R's
  ``effectsize::rank_biserial`` (its ``Pair`` interface for the paired one);
- Spearman's ρ: SE of atanh(ρ) = √((1 + ρ²/2) / (n − 3)) (Bonett & Wright
  2000), which holds for ranks where Pearson's 1/√(n − 3) is too narrow.

Otherwise a percentile bootstrap (``scipy.stats.bootstrap``, 2,000
resamples, seed :data:`SEED`, so a report is reproducible): ε² of
Kruskal-Wallis resamples within each group; Kendall's W of Friedman
resamples participants, each with all their conditions, because the
participant is the unit of the repeated-measures design. A bootstrap whose
resampled statistic is degenerate (every resample alike, or NaN, as when
almost every value is 0) gives no interval rather than scipy's warning.

Every interval carries how it was computed, or, when there is none, why
(:class:`Interval`'s ``method`` starts with :data:`NO_CI`): a table never
prints a bare estimate without saying why its interval is missing. At
r = ±1 (or ρ = ±1) Fisher's z is infinite and effectsize's interval
collapses to [±1, ±1], a width of zero no sample supports; hcss gives no
interval and says so.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from scipy import stats

Z_975 = float(stats.norm.ppf(0.975))
SEED = 20_250_101
RESAMPLES = 2_000
BOOTSTRAP = f"percentile bootstrap, {RESAMPLES:,} resamples, seed {SEED}"
FISHER = "Fisher z"
SPEARMAN_FISHER = "Fisher z, Bonett-Wright SE"

#: How a missing interval's reason begins.
NO_CI = "no CI"


class Interval(NamedTuple):
    """A 95% interval and how it was computed, or NaN bounds and why there is none."""

    lower: float
    upper: float
    method: str

    @property
    def missing(self) -> bool:
        return math.isnan(self.lower) or math.isnan(self.upper)


def no_interval(reason: str) -> Interval:
    """NaN bounds with the reason, worded for a table cell (``no CI: …``)."""
    return Interval(math.nan, math.nan, f"{NO_CI}: {reason}")


def _fisher(estimate: float, error: float, name: str, method: str = FISHER) -> Interval:
    if not math.isfinite(estimate):
        return Interval(math.nan, math.nan, "")  # the estimate itself is undefined and says why
    if abs(estimate) >= 1:
        return no_interval(
            f"{name} = {estimate:+.0f}, Fisher's z is infinite "
            f"(effectsize gives the zero-width [{estimate:.0f}, {estimate:.0f}])"
        )
    if not math.isfinite(error):
        return no_interval("standard error undefined")
    centre = math.atanh(estimate)
    return Interval(math.tanh(centre - Z_975 * error), math.tanh(centre + Z_975 * error), method)


def rank_biserial_interval(r: float, n_first: int, n_second: int) -> Interval:
    """95% CI of the two-sample rank-biserial r (effectsize's Fisher-z interval)."""
    if n_first < 1 or n_second < 1:
        return no_interval("a sample is empty")
    return _fisher(r, math.sqrt((n_first + n_second + 1) / (3.0 * n_first * n_second)), "r")


def paired_rank_biserial_interval(r: float, n_nonzero: int) -> Interval:
    """95% CI of the matched-pairs rank-biserial r from ``n_nonzero`` non-zero differences.

    effectsize's ``rank_biserial(Pair(x, y) ~ 1)`` drops zero differences
    from r and from its standard error alike; counting every complete pair
    in the error made the interval too narrow whenever differences were 0.
    """
    if n_nonzero < 1:
        return no_interval("every difference is 0")
    n = n_nonzero
    error = math.sqrt((2 * n**3 + 3 * n**2 + n) / 6.0) / (n * (n + 1) / 2.0)
    return _fisher(r, error, "r")


def spearman_interval(rho: float, n: int) -> Interval:
    """95% CI of Spearman's ρ (Bonett & Wright's standard error); needs n ≥ 4."""
    if n < 4:
        return no_interval(f"n = {n}, the Bonett-Wright interval needs 4")
    return _fisher(rho, math.sqrt((1 + rho * rho / 2.0) / (n - 3)), "ρ", SPEARMAN_FISHER)


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
    degenerate = "bootstrap degenerate: the resampled statistic is constant or undefined"
    if caught:  # scipy: the resampled statistic is degenerate (e.g. almost every value 0)
        return no_interval(degenerate)
    lower, upper = float(result.confidence_interval.low), float(result.confidence_interval.high)
    if not (math.isfinite(lower) and math.isfinite(upper)) or lower == upper:
        return no_interval(degenerate)
    return Interval(lower, upper, BOOTSTRAP)


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
        return no_interval("a group has fewer than 2 values to resample")
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
        return no_interval("fewer than 3 participants to resample")
    return _percentile(tuple(matrix.T), _kendalls_w, paired=True)
