"""Power of the study's tests as a function of N, by resampling units from a simulated pool.

A pool is the analysis's own per-unit measures (`decision_measures`, the
`measures.csv` that `hcss analyze` writes) of many synthetic participants and
simulation-only scenarios. A replication at N draws N participants (each with
all its trials, so M1, M2 and M3 stay one person's) and N scenarios for each
simulation-only model, with replacement (the pool stands for the population:
drawn without replacement, N near the pool's size would leave no sampling
variation, and power would read 0 or 1), and runs the analysis's tests on them: Kruskal-Wallis across the five groups
(the p of `stats.kruskal_wallis`, scipy's tie-corrected H as R's
`kruskal.test`; its bootstrap interval is not needed for a p), Tukey-Kramer
on mean ranks (`posthoc.tukey_kramer_ranks`) and Mann-Whitney
(`stats.mann_whitney`, R's `wilcox.test` rule) for every pair. Power is the
share of replications with p < alpha; its Monte Carlo interval is the
Clopper-Pearson 95% interval of that share.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from scipy import stats as scipy_stats

from hcss.analysis import posthoc, stats

GROUPS = ("M1SIM", "M2SIM", "M1", "M2", "M3")
HUMAN = ("M1", "M2", "M3")
MEASURES = ("success_rate", "decision_time_min")
SPLITS = ("overall", "easy", "difficult")
PAIRS: tuple[tuple[str, str], ...] = tuple(combinations(GROUPS, 2))
TESTS = ("kruskal_wallis", "tukey_kramer", "mann_whitney")


@dataclass(frozen=True)
class Hypothesis:
    """One test of one measure on one split: the five groups, or a pair."""

    test: str
    measure: str
    split: str
    pair: tuple[str, str] | None = None  # None: Kruskal-Wallis across the five groups

    @property
    def label(self) -> str:
        who = "all five groups" if self.pair is None else f"{self.pair[0]} vs {self.pair[1]}"
        return f"{self.test} · {self.measure} · {self.split} · {who}"


def hypotheses(groups: Sequence[str] = GROUPS) -> list[Hypothesis]:
    out = []
    for measure in MEASURES:
        for split in SPLITS:
            out.append(Hypothesis("kruskal_wallis", measure, split))
            for test in ("tukey_kramer", "mann_whitney"):
                out += [Hypothesis(test, measure, split, pair) for pair in combinations(groups, 2)]
    return out


@dataclass(frozen=True)
class UnitPool:
    """Per group, a (units × cells) array of unit values (NaN: the unit has no value there).

    Human groups share their row order: row i of M1, M2 and M3 is one participant.
    """

    cells: tuple[tuple[str, str], ...]  # (measure, split) per column
    values: Mapping[str, np.ndarray]

    def size(self, group: str) -> int:
        return int(self.values[group].shape[0])


def unit_pool(measures: pd.DataFrame) -> UnitPool:
    """The pool from the analysis's measures table (columns measure, split, group, unit, value)."""
    cells = tuple((m, s) for m in MEASURES for s in SPLITS)
    chosen = measures[measures["measure"].isin(MEASURES)]
    wide = chosen.pivot_table(
        index=["group", "unit"], columns=["measure", "split"], values="value", aggfunc="mean"
    )
    wide = wide.reindex(columns=pd.MultiIndex.from_tuples(cells))
    people = sorted(
        set.intersection(
            *(set(wide.loc[g].index) for g in HUMAN if g in wide.index.get_level_values(0))
        )
    )
    values: dict[str, np.ndarray] = {}
    for group in GROUPS:
        if group not in wide.index.get_level_values(0):
            continue
        frame = wide.loc[group]
        if group in HUMAN:
            frame = frame.reindex(people)
        values[group] = frame.to_numpy(dtype=float)
    return UnitPool(cells, values)


def _draw(rng: np.random.Generator, size: int, n: int) -> np.ndarray:
    return np.asarray(rng.integers(size, size=n))


def rejections(
    pool: UnitPool, n: int, replications: int, seed: int, alpha: float = 0.05
) -> dict[Hypothesis, int]:
    """How many of `replications` resamples at N = n reject each hypothesis at `alpha`."""
    rng = np.random.default_rng(seed)
    groups = [g for g in GROUPS if g in pool.values]
    counted = {h: 0 for h in hypotheses(groups)}
    for _ in range(replications):
        people = _draw(rng, pool.size(HUMAN[0]), n) if HUMAN[0] in pool.values else None
        drawn = {
            g: pool.values[g][people if g in HUMAN else _draw(rng, pool.size(g), n)] for g in groups
        }
        for column, (measure, split) in enumerate(pool.cells):
            samples = {g: _clean(drawn[g][:, column]) for g in groups}
            samples = {g: v for g, v in samples.items() if len(v) >= 2}
            for h, p in _p_values(samples, measure, split):
                counted[h] += p < alpha
    return counted


def _clean(values: np.ndarray) -> np.ndarray:
    return np.asarray(values[np.isfinite(values)], dtype=float)


def _p_values(
    samples: Mapping[str, np.ndarray], measure: str, split: str
) -> Iterable[tuple[Hypothesis, float]]:
    """The p of every test on one resample; an undefined p (every value tied) is 1."""
    if len(samples) < 2:
        return
    pooled = np.concatenate(list(samples.values()))
    if stats.all_equal(pooled):
        return
    if len(samples) == len(GROUPS):
        yield (
            Hypothesis("kruskal_wallis", measure, split),
            _finite(scipy_stats.kruskal(*samples.values()).pvalue),
        )
    lists = {g: v.tolist() for g, v in samples.items()}
    for row in posthoc.tukey_kramer_ranks(lists).rows:
        yield Hypothesis("tukey_kramer", measure, split, (row.group_a, row.group_b)), _finite(row.p)
    for a, b in combinations(samples, 2):
        if stats.all_equal(np.concatenate([samples[a], samples[b]])):
            continue
        p = stats.mann_whitney(lists[a], lists[b]).p
        yield Hypothesis("mann_whitney", measure, split, (a, b)), _finite(p)


def _finite(p: float) -> float:
    return float(p) if math.isfinite(p) else 1.0


@dataclass(frozen=True)
class PowerPoint:
    hypothesis: Hypothesis
    n: int
    rejected: int
    replications: int

    @property
    def power(self) -> float:
        return self.rejected / self.replications

    @property
    def interval(self) -> tuple[float, float]:
        """Clopper-Pearson 95% interval of the power (its Monte Carlo error)."""
        ci = scipy_stats.binomtest(self.rejected, self.replications).proportion_ci(0.95, "exact")
        return float(ci.low), float(ci.high)


def power_points(
    counts: Mapping[int, Mapping[Hypothesis, int]], replications: Mapping[int, int]
) -> list[PowerPoint]:
    return [
        PowerPoint(h, n, int(k), int(replications[n]))
        for n, by_hypothesis in sorted(counts.items())
        for h, k in by_hypothesis.items()
    ]


def n_for_power(points: Sequence[PowerPoint], target: float = 0.8) -> dict[Hypothesis, int | None]:
    """The smallest N of the grid whose power reaches `target`, per hypothesis (None: none)."""
    out: dict[Hypothesis, int | None] = {}
    for point in sorted(points, key=lambda p: p.n):
        out.setdefault(point.hypothesis, None)
        if out[point.hypothesis] is None and point.power >= target:
            out[point.hypothesis] = point.n
    return out


def power_table(points: Sequence[PowerPoint], target: float = 0.8) -> pd.DataFrame:
    """One row per hypothesis: power (interval) at each N and the N that reaches `target`."""
    reached = n_for_power(points, target)
    rows: dict[Hypothesis, dict[str, object]] = {}
    for p in points:
        low, high = p.interval
        row = rows.setdefault(
            p.hypothesis,
            {
                "test": p.hypothesis.test,
                "measure": p.hypothesis.measure,
                "split": p.hypothesis.split,
                "groups": "all five"
                if p.hypothesis.pair is None
                else " vs ".join(p.hypothesis.pair),
            },
        )
        row[f"N={p.n}"] = f"{p.power:.2f} [{low:.2f}, {high:.2f}]"
    for h, row in rows.items():
        n = reached.get(h)
        row[f"N for {target:.0%}"] = "beyond the grid" if n is None else str(n)
    return pd.DataFrame(list(rows.values()))


def power_figure(points: Sequence[PowerPoint], chosen: Sequence[Hypothesis]) -> Figure:
    """Power against N for the chosen hypotheses, with Monte Carlo intervals."""
    figure = Figure(figsize=(9, 5.5))
    axes = figure.subplots()
    for h in chosen:
        mine = sorted((p for p in points if p.hypothesis == h), key=lambda p: p.n)
        if not mine:
            continue
        ns = [p.n for p in mine]
        power = np.array([p.power for p in mine])
        lows, highs = zip(*(p.interval for p in mine), strict=True)
        line = axes.plot(ns, power, marker="o", label=h.label)[0]
        axes.fill_between(ns, lows, highs, color=line.get_color(), alpha=0.15)
    axes.axhline(0.8, color="grey", linestyle="--", linewidth=1)
    axes.set_xlabel("N (participants; scenarios per simulation-only model)")
    axes.set_ylabel("power (share of replications with p < .05)")
    axes.set_ylim(0, 1.02)
    axes.legend(fontsize=7, loc="lower right")
    figure.tight_layout()
    return figure
