"""The distributions and adjustments whose R implementation the analysis reproduces.

Each is written out (no library gives R's values to rounding, or fast
enough), so a table here agrees with the analysis a reviewer would run in R:

- **Studentized range** (``ptukey``/``qtukey``, for Tukey HSD);
- **Spearman's p** (R's ``cor.test(method = "spearman")``: ``prho``);
- **Holm's adjustment** (R's ``p.adjust(method = "holm")``).

## Studentized range

The studentized range distribution as R computes it (``ptukey``/``qtukey``).

R's ``TukeyHSD`` takes its p from ``ptukey`` and its intervals from
``qtukey``: Copenhaver & Holland's (1988) Gauss-Legendre integration of
Hartley's form, and a secant search for the quantile. scipy's
``studentized_range`` integrates more finely, so its p differs from R's in
the fifth significant digit for small p, and it costs ~50 ms per call with
finite df (a report asks for hundreds). This module implements R's algorithm
(R's ``src/nmath/ptukey.c``, ``qtukey.c``), vectorised over the quadrature
nodes with numpy, so Tukey HSD agrees with R to rounding and runs in
microseconds. Only one range (R's ``nranges = 1``) is needed here.

## Spearman's p

The p-value of Spearman's ρ as R's ``cor.test(method = "spearman")`` computes it.

R's default (``exact = NULL``) is *not* the t approximation scipy uses:

- without ties and with n ≤ 1290, R calls its C routine ``prho`` (Best &
  Roberts 1975, algorithm AS 89) for the null distribution of
  S = Σ(rank differences)²: the exact permutation distribution for n ≤ 9,
  an Edgeworth series expansion beyond;
- with ties (or n > 1290) R uses the t approximation with n − 2 df.

This module is a transcription of that logic (R's ``cor.test.default`` and
``src/library/stats/src/prho.c``), so a small study's p agrees with the
analysis a reviewer would run in R. The method is named in the result.

## Holm

statsmodels' ``multipletests(method="holm")`` runs a full ``gc.collect()`` on
every call; a report with a hundred comparisons would spend most of its time
in the garbage collector.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from itertools import permutations

import numpy as np
from scipy import stats
from scipy.special import gammaln, ndtr

# Gauss-Legendre, 12 points (half, with weights) for the range integral ...
_X12 = np.array(
    [
        0.981560634246719250690549090149,
        0.904117256370474856678465866119,
        0.769902674194304687036893833213,
        0.587317954286617447296702418941,
        0.367831498998180193752691536644,
        0.125233408511468915472441369464,
    ]
)
_W12 = np.array(
    [
        0.047175336386511827194615961485,
        0.106939325995318430960254718194,
        0.160078328543346226334652529543,
        0.203167426723065921749064455810,
        0.233492536538354808760849898925,
        0.249147045813402785000562436043,
    ]
)
# ... and 16 points for the integral over the chi distribution of the SD.
_X16 = np.array(
    [
        0.989400934991649932596154173450,
        0.944575023073232576077988415535,
        0.865631202387831743880467897712,
        0.755404408355003033895101194847,
        0.617876244402643748446671764049,
        0.458016777657227386342419442984,
        0.281603550779258913230460501460,
        0.950125098376374401853193354250e-1,
    ]
)
_W16 = np.array(
    [
        0.271524594117540948517805724560e-1,
        0.622535239386478928628438369944e-1,
        0.951585116824927848099251076022e-1,
        0.124628971255533872052476282192,
        0.149595988816576732081501730547,
        0.169156519395002538189312079030,
        0.182603415044923588866763667969,
        0.189450610455068496285396723208,
    ]
)
# Node order of R's loops: the negative half from -x[0] up, then +x[5] .. +x[0].
_NODES12 = np.concatenate([-_X12, _X12[::-1]])
_WEIGHTS12 = np.concatenate([_W12, _W12[::-1]])
_NODES16 = np.concatenate([-_X16, _X16])
_WEIGHTS16 = np.concatenate([_W16, _W16])


def _range_probability(w: np.ndarray, groups: float) -> np.ndarray:
    """P(range of ``groups`` standard normals < w), R's ``wprob`` with one range."""
    w = np.asarray(w, dtype=float)
    half = w * 0.5
    first = 2.0 * ndtr(half) - 1.0
    first = np.where(first >= math.exp(-50.0 / groups), np.abs(first) ** groups, 0.0)
    intervals = np.where(w > 3.0, 2, 3)
    step = (8.0 - half) / intervals
    lower, upper = half.copy(), half + step
    total = np.zeros_like(w)
    minus_one = groups - 1.0
    for interval in range(3):
        middle, radius = 0.5 * (upper + lower), 0.5 * (upper - lower)
        points = middle[:, None] + radius[:, None] * _NODES12[None, :]
        squared = points * points
        inside = np.logical_and.accumulate(squared <= 60.0, axis=1)  # R breaks out here
        spread = ndtr(points) - ndtr(points - w[:, None])
        useful = inside & (spread >= math.exp(-30.0 / minus_one))
        terms = np.where(
            useful,
            _WEIGHTS12 * np.exp(-0.5 * squared) * np.where(useful, spread, 1.0) ** minus_one,
            0.0,
        )
        sums = terms.sum(axis=1) * (2.0 * radius * groups / math.sqrt(2.0 * math.pi))
        total += np.where(interval < intervals, sums, 0.0)
        lower, upper = upper, upper + step
    probability = first + total
    probability = np.where(probability <= math.exp(-30.0), 0.0, np.minimum(probability, 1.0))
    return np.where(half >= 8.0, 1.0, probability)


def ptukey(q: float, groups: int, df: float) -> float:
    """P(Q < q) for the studentized range of ``groups`` means with ``df`` error df."""
    if q <= 0:
        return 0.0
    if df < 2 or groups < 2:
        return float("nan")
    if math.isinf(q):
        return 1.0
    if df > 25000:
        return float(_range_probability(np.array([q]), groups)[0])
    half_df = df * 0.5
    unit = 1.0 if df <= 100 else 0.5 if df <= 800 else 0.25 if df <= 5000 else 0.125
    constant = half_df * math.log(df) - df * math.log(2.0) - gammaln(half_df) + math.log(unit)
    centres = (2 * np.arange(1, 51) - 1) * unit
    points = centres[:, None] + _NODES16[None, :] * unit  # 50 intervals × 16 nodes
    log_density = constant + (half_df - 1.0) * np.log(points) - points * df * 0.25
    useful = log_density >= -30.0
    probability = np.zeros_like(points)
    probability[useful] = _range_probability(q * np.sqrt(points[useful] * 0.5), groups)
    per_interval = (np.where(useful, probability * np.exp(log_density), 0.0) * _WEIGHTS16).sum(
        axis=1
    )
    # R stops at the first interval (after 1/unit of them) adding less than 1e-14.
    index = np.arange(1, 51)
    stop = np.flatnonzero((index * unit >= 1.0) & (per_interval <= 1e-14))
    answer = per_interval[: stop[0]].sum() if len(stop) else per_interval.sum()
    return float(min(answer, 1.0))


def tukey_sf(q: float, groups: int, df: float) -> float:
    """P(Q > q), R's ``ptukey(q, groups, df, lower.tail = FALSE)``."""
    return 1.0 - ptukey(q, groups, df)


def _initial_quantile(p: float, groups: int, df: float) -> float:
    """R's ``qinv``: a starting value for the secant search."""
    ps = 0.5 - 0.5 * p
    yi = math.sqrt(math.log(1.0 / (ps * ps)))
    t = yi + (
        (((yi * -0.453642210148e-04 + -0.204231210125) * yi + -0.342242088547) * yi + -1.0) * yi
        + 0.322232421088
    ) / (
        (((yi * 0.38560700634e-02 + 0.103537752850) * yi + 0.531103462366) * yi + 0.588581570495)
        * yi
        + 0.993484626060e-01
    )
    if df < 120.0:
        t += (t * t * t + t) / df / 4.0
    q = 0.8832 - 0.2368 * t
    if df < 120.0:
        q += -1.214 / df + 1.208 * t / df
    return t * (q * math.log(groups - 1.0) + 1.4142)


@lru_cache(maxsize=256)
def qtukey(p: float, groups: int, df: float) -> float:
    """The ``p`` quantile of the studentized range, by R's secant search (eps 1e-4)."""
    if df < 2 or groups < 2 or not 0 <= p <= 1:
        return float("nan")
    if p == 0:
        return 0.0
    if p == 1:
        return math.inf
    x0 = _initial_quantile(p, groups, df)
    value0 = ptukey(x0, groups, df) - p
    x1 = max(0.0, x0 - 1.0) if value0 > 0 else x0 + 1.0
    value1 = ptukey(x1, groups, df) - p
    answer = x1
    for _ in range(1, 50):
        answer = x1 - value1 * (x1 - x0) / (value1 - value0)
        value0 = value1
        x0 = x1
        if answer < 0.0:
            answer = 0.0
        value1 = ptukey(answer, groups, df) - p
        x1 = answer
        if abs(x1 - x0) < 1e-4:
            return answer
    return answer


# --- Spearman's p ------------------------------------------------------------------

#: n up to which ``prho`` enumerates every permutation (R's ``n_small``).
EXACT_MAX_N = 9
#: The largest n R gives to ``prho`` (beyond it n³ would overflow in C).
EDGEWORTH_MAX_N = 1290

EXACT = "exact (permutation distribution of S, as R's prho)"
EDGEWORTH = "Edgeworth series for S (R's prho, AS 89)"
T_APPROXIMATION = "t approximation, n − 2 df"

# Edgeworth coefficients of AS 89.
_C = (
    0.2274,
    0.2531,
    0.1745,
    0.0758,
    0.1033,
    0.3932,
    0.0879,
    0.0151,
    0.0072,
    0.0831,
    0.0131,
    4.6e-4,
)


@lru_cache(maxsize=EXACT_MAX_N)
def _null_s(n: int) -> np.ndarray:
    """S = Σ(i − πᵢ)² for every permutation π of 1..n (n! values, n ≤ 9)."""
    ranks = np.arange(n)
    every = np.fromiter(
        (value for order in permutations(range(n)) for value in order), dtype=np.int8
    ).reshape(-1, n)
    return np.asarray(((every - ranks) ** 2).sum(axis=1))


def _prho(n: int, s: float, lower_tail: bool) -> float:
    """P(S ≥ s) (upper) or P(S < s) (lower), as R's C ``prho``."""
    p = 0.0 if lower_tail else 1.0
    if s <= 0:
        return p
    maximum = n * (n * n - 1) / 3.0
    if s > maximum:
        return 1.0 - p
    if n <= EXACT_MAX_N:
        null = _null_s(n)
        at_least = int(np.count_nonzero(null >= s))
        total = len(null)
        return (total - at_least) / total if lower_tail else at_least / total
    c1, c2, c3, c4, c5, c6, c7, c8, c9, c10, c11, c12 = _C
    b = 1.0 / n
    x = (6.0 * (s - 1) * b / (n * n - 1) - 1) * math.sqrt(1 / b - 1)
    y = x * x
    u = (
        x
        * b
        * (
            c1
            + b * (c2 + c3 * b)
            + y
            * (
                -c4
                + b * (c5 + c6 * b)
                - y * b * (c7 + c8 * b - y * (c9 - c10 * b + y * b * (c11 - c12 * y)))
            )
        )
    )
    p = u / math.exp(y / 2) + float(stats.norm.sf(x))
    p = min(max(p, 0.0), 1.0)
    return 1.0 - p if lower_tail else p


def spearman_p(rho: float, n: int, ties: bool) -> tuple[float, str]:
    """Two-sided p of ρ with n pairs, and the method used, as R's default."""
    if ties or n > EDGEWORTH_MAX_N:
        t = (
            rho * math.sqrt((n - 2) / (1 - rho * rho))
            if abs(rho) < 1
            else math.copysign(math.inf, rho)
        )
        return float(min(2 * stats.t.sf(abs(t), n - 2), 1.0)), T_APPROXIMATION
    s = (n**3 - n) * (1 - rho) / 6
    upper = s > (n**3 - n) / 6
    # R: .Call(C_pRho, round(q) + 2*lower.tail, n, lower.tail); S is always even,
    # so P(S < round(q) + 2) = P(S ≤ q).
    one_sided = _prho(n, round(s) + (0 if upper else 2), lower_tail=not upper)
    method = EXACT if n <= EXACT_MAX_N else EDGEWORTH
    return min(2 * one_sided, 1.0), method


# --- Holm ------------------------------------------------------------------------------


def holm(p_values: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjustment: p₍ᵢ₎·(m − i + 1), made monotone, capped at 1.

    Checked against statsmodels and R in the tests. A NaN p (a degenerate pair)
    stays NaN and does not count in m, as in R's ``p.adjust``.
    """
    p = np.asarray(p_values, dtype=float)
    adjusted = np.full_like(p, np.nan)
    present = ~np.isnan(p)  # as R's p.adjust: a missing p is no comparison
    kept = p[present]
    order = np.argsort(kept, kind="stable")
    scaled = kept[order] * np.arange(len(kept), 0, -1)
    result = np.empty_like(kept)
    result[order] = np.minimum(np.maximum.accumulate(scaled), 1.0)
    adjusted[present] = result
    return adjusted
