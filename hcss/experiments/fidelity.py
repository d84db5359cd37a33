"""How faithful is the model? The reduced experiment, M2's ablations, Markdown tables.

`hcss simulate fidelity` runs the simulation-only experiment at reduced size
(28 scenarios × a few runs) for M1 and M2 under the current parameters, and
M2 with each of its mechanisms removed in turn (no F_D, no F_R, no M_i), and
prints success and decision time per split with standard errors. The study's
qualitative claims (spec §10) are checked on the same rows.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from hcss.experiments import experiment as exp
from hcss.experiments import study_targets as st
from hcss.experiments.calibrate import STUDY_M1_DECISION_MIN
from hcss.simulation.params import M2_MECHANISMS, Params

ABLATIONS: dict[str, str] = {
    "discovery_delay": "M2 without F_D",
    "reassessment_delay": "M2 without F_R",
    "modulation": "M2 without M_i",
}


@dataclass(frozen=True)
class Cell:
    """Success (per trial) and decision time (per decision, minutes) of one variant and split."""

    variant: str
    split: str
    trials: int
    success: float
    success_se: float
    decisions: int
    time_min: float
    time_se: float
    timed_out: float  # share of decisions that timed out


def _mean_se(values: list[float]) -> tuple[float, float]:
    if not values:
        return math.nan, math.nan
    a = np.asarray(values, dtype=float)
    se = float(a.std(ddof=1) / math.sqrt(a.size)) if a.size > 1 else math.nan
    return float(a.mean()), se


def cells(variant: str, rows: list[dict[str, Any]]) -> list[Cell]:
    """The three splits of one variant's decisions."""
    out = []
    for split in exp.SPLITS:
        chosen = [r for r in rows if split == "overall" or r["difficulty"] == split]
        by_trial: dict[str, list[bool]] = {}
        for r in chosen:
            by_trial.setdefault(r["trial_id"], []).append(bool(r["correct"]))
        success, success_se = _mean_se([sum(v) / len(v) for v in by_trial.values()])
        time_min, time_se = _mean_se([r["decision_time_s"] / 60.0 for r in chosen])
        timed_out = float(np.mean([bool(r["timed_out"]) for r in chosen])) if chosen else math.nan
        out.append(
            Cell(
                variant,
                split,
                len(by_trial),
                success,
                success_se,
                len(chosen),
                time_min,
                time_se,
                timed_out,
            )
        )
    return out


def variants(params: Params, ablations: bool = True) -> list[tuple[str, str, Params]]:
    """(label, model, params) of each run: M1, M2 and M2's ablations."""
    runs = [("M1", "M1", params), ("M2", "M2", params)]
    if ablations:
        for mechanism, label in ABLATIONS.items():
            kept = tuple(m for m in M2_MECHANISMS if m != mechanism and m in params.m2_mechanisms)
            runs.append((label, "M2", params.with_changes(m2_mechanisms=kept)))
    return runs


def variant_rows(
    params: Params,
    scenarios: int = 28,
    runs: int = 2,
    workers: int = 2,
    ablations: bool = True,
    on_variant: Callable[[str], None] | None = None,
    seed: int = exp.DEFAULT_SCENARIO_SEED,
) -> list[tuple[str, list[dict[str, Any]]]]:
    """(label, decision rows) of every variant, on the same scenarios and runs."""
    out = []
    for label, model, variant_params in variants(params, ablations):
        if on_variant is not None:
            on_variant(label)
        jobs = exp.jobs_for(
            exp.experiment_scenarios(scenarios, seed, variant_params), [model], runs
        )
        out.append((label, exp.run_jobs(jobs, workers, params=variant_params)))
    return out


def variant_cells(rows: list[tuple[str, list[dict[str, Any]]]]) -> list[Cell]:
    """Every variant's three splits (`cells`), in the order `variant_rows` ran them."""
    return [cell for label, variant in rows for cell in cells(label, variant)]


def study_comparison(rows: list[tuple[str, list[dict[str, Any]]]]) -> str:
    """M1's and M2's split cells beside the study's published ones (study_targets)."""
    measured = st.measure(r for label, variant in rows if label in ("M1", "M2") for r in variant)
    return (
        f"{st.comparison_table(measured)}\n\n{st.cells_met(measured)} of 8 published numbers "
        f"within their band (±{st.SR_BAND_POINTS:g} points, ±{st.DT_BAND_MIN:g} min); "
        f"loss {st.loss(measured):.2f}."
    )


def fidelity_table(table: list[Cell]) -> str:
    lines = [
        "| variant | split | trials | success ± SE | decisions | time (min) ± SE | timed out |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in table:
        lines.append(
            f"| {c.variant} | {c.split} | {c.trials} | {c.success:.3f} ± {c.success_se:.3f} "
            f"| {c.decisions} | {c.time_min:.2f} ± {c.time_se:.2f} | {c.timed_out:.3f} |"
        )
    return "\n".join(lines)


def claims(table: list[Cell]) -> list[tuple[str, bool, str]]:
    """The study's qualitative claims (spec §10), each with whether these rows meet it."""
    get = {(c.variant, c.split): c for c in table}
    m1e, m1d, m2e, m2d = (get[(m, s)] for m in ("M1", "M2") for s in ("easy", "difficult"))
    m1o, m2o = get[("M1", "overall")], get[("M2", "overall")]
    extra = m2o.time_min - m1o.time_min
    return [
        (
            "M2 about as accurate as M1 on easy decisions (within 0.10)",
            m2e.success >= m1e.success - 0.10,
            f"M2 {m2e.success:.2f} vs M1 {m1e.success:.2f}",
        ),
        (
            "M2 much more accurate than M1 on difficult decisions",
            m2d.success >= m1d.success + 0.25,
            f"M2 {m2d.success:.2f} vs M1 {m1d.success:.2f}",
        ),
        ("M2 slower by one to three minutes", 1.0 <= extra <= 3.0, f"{extra:+.2f} min"),
        (
            f"M1's mean decision time near the study's {STUDY_M1_DECISION_MIN} min (±0.3)",
            abs(m1o.time_min - STUDY_M1_DECISION_MIN) <= 0.3,
            f"{m1o.time_min:.2f} min",
        ),
    ]


def claims_table(table: list[Cell]) -> str:
    lines = ["| study's claim | met | measured |", "|---|---|---|"]
    for claim, met, measured in claims(table):
        lines.append(f"| {claim} | {'yes' if met else 'no'} | {measured} |")
    return "\n".join(lines)
