"""The study's own unit of its simulation-only tables, and its tables in full (spec §10).

The study's simulation tables are not per-decision statistics. Their unit is
(trial scenario, decision slot): within each run the decisions are numbered
1..12 in order of completion (section first, then end time), and a unit's
value is its mean over the scenario's runs. A unit enters the easy
(difficult) column when at least one of its runs had an easy (difficult)
decision in that slot, with the mean over those decisions only. The printed
test sizes fix it: 336 units per model overall (28 × 12), and, both models
together, 578 units with an easy decision and 456 with a difficult one.

This module computes those tables from decisions-table rows and holds the
published numbers; `hcss.analysis.paper_units` lays them out beside the
study's rows, and the calibration (`hcss.experiments.fit_study`) fits them. It
imports nothing from hcss, so both packages may use it (the simulation may
not import the analysis).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np

SPLITS: tuple[str, ...] = ("overall", "easy", "difficult")
MEASURES: tuple[str, ...] = ("success_pct", "time_min")
MEASURE_LABELS = {"success_pct": "success rate (%)", "time_min": "decision time (min)"}

UNIT_RULE = (
    "Unit: (trial scenario, decision slot 1..12 in order of completion within a run: "
    "section first, then end time), its value the mean over the scenario's runs. A unit "
    "is in the easy (difficult) column when at least one run had an easy (difficult) "
    "decision in that slot, averaged over those decisions only (spec §10)."
)

# Bands of the loss: one band's miss costs 1 (docs/simulation-notes.md).
BANDS = {"success_pct": 10.0, "time_min": 1.0, "units": 30.0}
FITTED_STATISTICS: tuple[str, ...] = ("mean", "sd", "median")


@dataclass(frozen=True)
class Summary:
    """A set of unit values: how many, mean, SD (n − 1), median, minimum and maximum; the
    analysis's descriptive tables use it too (`hcss.analysis.descriptive.summarise`)."""

    n: int
    mean: float
    sd: float
    median: float
    minimum: float
    maximum: float

    @classmethod
    def of(cls, values: list[float]) -> Summary:
        if not values:
            return cls(0, math.nan, math.nan, math.nan, math.nan, math.nan)
        a = np.asarray(values, dtype=float)
        sd = float(a.std(ddof=1)) if a.size > 1 else math.nan
        return cls(
            int(a.size),
            float(a.mean()),
            sd,
            float(np.median(a)),
            float(a.min()),
            float(a.max()),
        )

    def statistic(self, name: str) -> float:
        return float(getattr(self, name))


def _published(mean: float, sd: float, median: float, minimum: float, maximum: float) -> Summary:
    return Summary(0, mean, sd, median, minimum, maximum)


# (model, split, measure) -> the study's mean (SD), median (min/max), spec §10.
PUBLISHED: dict[tuple[str, str, str], Summary] = {
    ("M1", "overall", "success_pct"): _published(52.11, 39.41, 60, 0, 100),
    ("M1", "easy", "success_pct"): _published(70.49, 35.29, 87.5, 0, 100),
    ("M1", "difficult", "success_pct"): _published(6.8, 17.85, 0, 0, 100),
    ("M2", "overall", "success_pct"): _published(74.58, 18.39, 70, 20, 100),
    ("M2", "easy", "success_pct"): _published(76.7, 26.87, 83.33, 0, 100),
    ("M2", "difficult", "success_pct"): _published(64.04, 26.38, 66.67, 0, 100),
    ("M1", "overall", "time_min"): _published(2.46, 0.66, 2.44, 1.36, 4.46),
    ("M1", "easy", "time_min"): _published(2.18, 0.53, 2.14, 1.36, 3.89),
    ("M1", "difficult", "time_min"): _published(3.2, 0.96, 3.05, 1.83, 7.08),
    ("M2", "overall", "time_min"): _published(4.79, 1.11, 4.79, 2.49, 7.7),
    ("M2", "easy", "time_min"): _published(4.17, 0.93, 4.1, 2.49, 7.55),
    ("M2", "difficult", "time_min"): _published(5.77, 1.38, 5.62, 3.67, 10.25),
}
# Units per split, both models together (the paper's test sizes); per model overall 28 × 12.
PUBLISHED_UNITS: dict[str, int] = {"overall": 672, "easy": 578, "difficult": 456}
PUBLISHED_UNITS_PER_MODEL_OVERALL = 336
STUDY_SCENARIOS = 28
STUDY_RUNS = 10  # a unit's value is its mean over this many runs


@dataclass(frozen=True)
class Unit:
    """One (model, scenario, slot) unit on one split: its value per measure and its runs."""

    model: str
    scenario_id: str
    slot: int
    split: str
    decisions: int  # runs that contribute to this split's mean
    success_pct: float
    time_min: float


def units(rows: Iterable[Mapping[str, object]]) -> list[Unit]:
    """Every unit of the rows, under the study's rule (the module docstring).

    Rows are decisions-table rows of the simulation (model, scenario_id, run,
    section, end_s, difficulty, correct, decision_time_s).
    """
    runs: dict[tuple[str, str, int], list[tuple[int, float, str, str, bool, float]]] = {}
    for row in rows:
        key = (str(row["model"]), str(row["scenario_id"]), int(float(str(row["run"]))))
        runs.setdefault(key, []).append(
            (
                int(float(str(row["section"]))),
                float(str(row["end_s"])),
                str(row["collective"]),
                str(row["difficulty"]),
                _truth(row["correct"]),
                float(str(row["decision_time_s"])) / 60.0,
            )
        )
    slots: dict[tuple[str, str, int], list[tuple[str, bool, float]]] = {}
    for (model, scenario, _run), decisions in runs.items():
        for slot, (_s, _e, _c, kind, correct, minutes) in enumerate(sorted(decisions), start=1):
            slots.setdefault((model, scenario, slot), []).append((kind, correct, minutes))
    out = []
    for (model, scenario, slot), in_slot in sorted(slots.items()):
        for split in SPLITS:
            chosen = [d for d in in_slot if split == "overall" or d[0] == split]
            if chosen:
                out.append(
                    Unit(
                        model,
                        scenario,
                        slot,
                        split,
                        len(chosen),
                        100.0 * float(np.mean([c for _, c, _ in chosen])),
                        float(np.mean([t for _, _, t in chosen])),
                    )
                )
    return out


def _truth(value: object) -> bool:
    if isinstance(value, str):
        return value.strip().lower() in ("true", "1", "yes")
    return bool(value)


def summarise(all_units: Iterable[Unit]) -> dict[tuple[str, str, str], Summary]:
    """(model, split, measure) -> the column's summary over its units."""
    grouped: dict[tuple[str, str], list[Unit]] = {}
    for unit in all_units:
        grouped.setdefault((unit.model, unit.split), []).append(unit)
    return {
        (model, split, measure): Summary.of([getattr(u, measure) for u in group])
        for (model, split), group in grouped.items()
        for measure in MEASURES
    }


def unit_counts(summaries: Mapping[tuple[str, str, str], Summary]) -> dict[str, int]:
    """Units per split, both models together (the paper's N)."""
    return {
        split: sum(s.n for (_, sp, m), s in summaries.items() if sp == split and m == MEASURES[0])
        for split in SPLITS
    }


@dataclass(frozen=True)
class NumberDistance:
    """One published number, the run's, and the distance in bands."""

    name: str
    published: float
    measured: float
    band: float

    @property
    def bands(self) -> float:
        if not math.isfinite(self.measured):
            return math.inf
        return (self.measured - self.published) / self.band

    @property
    def met(self) -> bool:
        return abs(self.bands) <= 1.0


def distances(
    summaries: Mapping[tuple[str, str, str], Summary], scenarios: int = 28
) -> list[NumberDistance]:
    """The fitted published numbers: means, SDs and medians of both tables, N per split.

    Minima and maxima are shown, not fitted; N overall is 336 per model by
    construction and so carries no information. A run of fewer (or more)
    scenarios than the study's 28 has its N scaled to 28.
    """
    out = []
    for key, published in PUBLISHED.items():
        model, split, measure = key
        measured = summaries.get(key)
        for statistic in FITTED_STATISTICS:
            out.append(
                NumberDistance(
                    f"{model} {split} {measure} {statistic}",
                    published.statistic(statistic),
                    measured.statistic(statistic) if measured else math.nan,
                    BANDS[measure],
                )
            )
    counts = unit_counts(summaries)
    for split in ("easy", "difficult"):
        out.append(
            NumberDistance(
                f"units {split}",
                PUBLISHED_UNITS[split],
                counts[split] * STUDY_SCENARIOS / scenarios,
                BANDS["units"],
            )
        )
    return out


def loss(summaries: Mapping[tuple[str, str, str], Summary], scenarios: int = 28) -> float:
    """Sum of squared distances in bands over every fitted published number (38)."""
    return float(sum(d.bands**2 for d in distances(summaries, scenarios)))


def numbers_met(summaries: Mapping[tuple[str, str, str], Summary], scenarios: int = 28) -> int:
    """How many of the fitted published numbers lie within their band."""
    return sum(d.met for d in distances(summaries, scenarios))


def cell_text(summary: Summary | None, digits: int) -> str:
    """The paper's cell: ``mean (SD), median (min/max)``."""
    if summary is None or summary.n == 0 and not math.isfinite(summary.mean):
        return "–"

    def f(x: float) -> str:
        return "–" if not math.isfinite(x) else f"{x:.{digits}f}"

    return (
        f"{f(summary.mean)} ({f(summary.sd)}), "
        f"{f(summary.median)} ({f(summary.minimum)}/{f(summary.maximum)})"
    )


def comparison_markdown(
    summaries: Mapping[tuple[str, str, str], Summary], scenarios: int = STUDY_SCENARIOS
) -> str:
    """Both tables as Markdown, the study's row beside each model's, and N per split
    (also scaled to the study's 28 scenarios when the run had another number)."""
    lines = [UNIT_RULE, ""]
    models = sorted({m for m, _, _ in summaries} | {m for m, _, _ in PUBLISHED})
    for measure, digits in (("success_pct", 1), ("time_min", 2)):
        lines += [
            f"{MEASURE_LABELS[measure].capitalize()} per unit: mean (SD), median (min/max)",
            "",
            "| model | | N units | overall | easy | difficult |",
            "|---|---|---|---|---|---|",
        ]
        for model in models:
            ours = [summaries.get((model, s, measure)) for s in SPLITS]
            n = " / ".join(str(o.n) if o else "0" for o in ours)
            lines.append(
                f"| {model} | this run | {n} | "
                + " | ".join(cell_text(o, digits) for o in ours)
                + " |"
            )
            study = [PUBLISHED.get((model, s, measure)) for s in SPLITS]
            if any(study):
                lines.append(
                    f"| {model} | study | {PUBLISHED_UNITS_PER_MODEL_OVERALL} / – / – | "
                    + " | ".join(cell_text(p, digits) for p in study)
                    + " |"
                )
        lines.append("")
    counts = unit_counts(summaries)
    lines.append(
        "Units with an easy / a difficult decision, both models: "
        f"{counts['easy']} / {counts['difficult']} (study "
        f"{PUBLISHED_UNITS['easy']} / {PUBLISHED_UNITS['difficult']})"
        + (
            f"; scaled to {STUDY_SCENARIOS} scenarios: "
            f"{counts['easy'] * STUDY_SCENARIOS / scenarios:.0f} / "
            f"{counts['difficult'] * STUDY_SCENARIOS / scenarios:.0f}."
            if scenarios != STUDY_SCENARIOS
            else "."
        )
    )
    return "\n".join(lines)
