"""The study's published simulation-only results, and how far a run is from them.

The study (spec §10) ran 28 trial scenarios × 10 runs per model with no human
in the loop and printed, per model and split, the success rate per decision (%)
and the mean decision time (minutes). Those eight split cells are the
calibration targets of the `study-calibrated` preset; nothing else the study
published is fitted (the rest is held back to validate the fit).

A cell is "met" within a band: ±10 points of success rate and ±1 minute of
decision time. The loss of a run is the sum of squared distances in units of
those bands, so one band's miss costs 1 in either quantity.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

SPLITS: tuple[str, ...] = ("easy", "difficult")
SR_BAND_POINTS = 10.0
DT_BAND_MIN = 1.0


@dataclass(frozen=True)
class Target:
    """One model's published success rate (%) and mean decision time (min) on one split."""

    model: str
    split: str
    success_pct: float
    time_min: float


STUDY_TARGETS: tuple[Target, ...] = (
    Target("M1", "easy", 70.49, 2.18),
    Target("M1", "difficult", 6.8, 3.2),
    Target("M2", "easy", 76.7, 4.17),
    Target("M2", "difficult", 64.04, 5.77),
)


@dataclass(frozen=True)
class Measured:
    """A run's success rate (%) and mean decision time (min) on one model and split.

    Standard errors are over trials (a trial's decisions are not independent):
    the per-trial means' spread over the number of trials.
    """

    model: str
    split: str
    decisions: int
    success_pct: float
    success_se: float
    time_min: float
    time_se: float


def measure(rows: Iterable[Mapping[str, object]]) -> dict[tuple[str, str], Measured]:
    """Per (model, split): success per decision and mean decision time, as the study reports."""
    grouped: dict[tuple[str, str], dict[str, list[tuple[bool, float]]]] = {}
    for row in rows:
        key = (str(row["model"]), str(row["difficulty"]))
        trial = grouped.setdefault(key, {}).setdefault(str(row["trial_id"]), [])
        trial.append((bool(row["correct"]), float(str(row["decision_time_s"])) / 60.0))
    out = {}
    for (model, split), trials in grouped.items():
        pooled = [d for decisions in trials.values() for d in decisions]
        success = 100.0 * float(np.mean([c for c, _ in pooled]))
        time = float(np.mean([t for _, t in pooled]))
        out[(model, split)] = Measured(
            model,
            split,
            len(pooled),
            success,
            _trial_se([[100.0 * c for c, _ in d] for d in trials.values()]),
            time,
            _trial_se([[t for _, t in d] for d in trials.values()]),
        )
    return out


def _trial_se(per_trial: list[list[float]]) -> float:
    means = np.array([np.mean(v) for v in per_trial if v])
    if means.size < 2:
        return math.nan
    return float(means.std(ddof=1) / math.sqrt(means.size))


@dataclass(frozen=True)
class CellDistance:
    """How far one measured cell is from its target, in bands."""

    target: Target
    measured: Measured | None

    @property
    def success_bands(self) -> float:
        if self.measured is None:
            return math.inf
        return (self.measured.success_pct - self.target.success_pct) / SR_BAND_POINTS

    @property
    def time_bands(self) -> float:
        if self.measured is None:
            return math.inf
        return (self.measured.time_min - self.target.time_min) / DT_BAND_MIN

    @property
    def met(self) -> int:
        """How many of this split's two published numbers lie within their band (0 to 2)."""
        return int(abs(self.success_bands) <= 1.0) + int(abs(self.time_bands) <= 1.0)


def distances(measured: Mapping[tuple[str, str], Measured]) -> list[CellDistance]:
    return [CellDistance(t, measured.get((t.model, t.split))) for t in STUDY_TARGETS]


def loss(measured: Mapping[tuple[str, str], Measured]) -> float:
    """Sum of squared distances in band units over the eight published numbers."""
    return float(sum(d.success_bands**2 + d.time_bands**2 for d in distances(measured)))


def cells_met(measured: Mapping[tuple[str, str], Measured]) -> int:
    """How many of the eight published numbers lie within their band."""
    return sum(d.met for d in distances(measured))


def overall_time(rows: Iterable[Mapping[str, object]], model: str) -> float:
    """A model's mean decision time over every decision (minutes)."""
    times = [float(str(r["decision_time_s"])) / 60.0 for r in rows if r["model"] == model]
    return float(np.mean(times)) if times else math.nan


def comparison_table(measured: Mapping[tuple[str, str], Measured]) -> str:
    """Markdown: each published cell beside the run's, with standard errors and whether met."""
    lines = [
        "| model | split | study SR % | SR % ± SE | study DT min | DT min ± SE | within band |",
        "|---|---|---|---|---|---|---|",
    ]
    for d in distances(measured):
        t, m = d.target, d.measured
        if m is None:
            lines.append(f"| {t.model} | {t.split} | {t.success_pct} | – | {t.time_min} | – | – |")
            continue
        within = (
            f"{'SR' if abs(d.success_bands) <= 1 else ''}"
            f"{' ' if d.met == 2 else ''}{'DT' if abs(d.time_bands) <= 1 else ''}"
        ) or "neither"
        lines.append(
            f"| {t.model} | {t.split} | {t.success_pct} | {m.success_pct:.1f} ± {m.success_se:.1f} "
            f"| {t.time_min} | {m.time_min:.2f} ± {m.time_se:.2f} | {within} |"
        )
    return "\n".join(lines)


@dataclass(frozen=True)
class DecisionShape:
    """Which decisions of one model and split are slow, and whether the slow ones fail.

    The study: "longer decision times tended to result in poor easy decisions by both
    models". Per decision: the mean time of right and of wrong decisions, and the
    success of the fastest and the slowest quarter (by decision time within the model
    and split). `slow_fail_more` is the study's direction: the slowest quarter right
    less often than the fastest.
    """

    model: str
    split: str
    decisions: int
    right_time_min: float
    wrong_time_min: float
    fastest_quarter_pct: float
    slowest_quarter_pct: float

    @property
    def slow_fail_more(self) -> bool:
        return self.slowest_quarter_pct < self.fastest_quarter_pct


def decision_shape(rows: Iterable[Mapping[str, object]]) -> dict[tuple[str, str], DecisionShape]:
    """Per (model, split), from a run's decisions (timed-out ones count as wrong and slow)."""
    grouped: dict[tuple[str, str], list[tuple[float, bool]]] = {}
    for row in rows:
        key = (str(row["model"]), str(row["difficulty"]))
        grouped.setdefault(key, []).append(
            (float(str(row["decision_time_s"])) / 60.0, _truth(row["correct"]))
        )
    out = {}
    for (model, split), decisions in sorted(grouped.items()):
        times = np.array([t for t, _ in decisions])
        right = np.array([c for _, c in decisions])
        order = np.argsort(times, kind="stable")
        quarter = max(1, len(order) // 4)

        def mean(values: np.ndarray) -> float:
            return float(values.mean()) if values.size else math.nan

        out[(model, split)] = DecisionShape(
            model,
            split,
            len(decisions),
            mean(times[right]),
            mean(times[~right]),
            100.0 * mean(right[order[:quarter]].astype(float)),
            100.0 * mean(right[order[-quarter:]].astype(float)),
        )
    return out


def _truth(value: object) -> bool:
    """A decisions.csv cell or a row's bool as a bool."""
    if isinstance(value, str):
        return value.strip().lower() in ("true", "1", "yes")
    return bool(value)


def shape_table(shapes: Mapping[tuple[str, str], DecisionShape]) -> str:
    """Markdown: per model and split, right and wrong decisions' times, and the success of
    the fastest and slowest quarter."""
    lines = [
        "| model | split | decisions | right: DT min | wrong: DT min | fastest quarter SR % "
        "| slowest quarter SR % | slow fail more (study: yes on easy) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in shapes.values():
        lines.append(
            f"| {s.model} | {s.split} | {s.decisions} | {s.right_time_min:.2f} "
            f"| {s.wrong_time_min:.2f} | {s.fastest_quarter_pct:.1f} "
            f"| {s.slowest_quarter_pct:.1f} | {'yes' if s.slow_fail_more else 'no'} |"
        )
    return "\n".join(lines)
