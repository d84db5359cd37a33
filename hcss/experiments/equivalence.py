"""Do two engines give the same outcomes?  Distributions, not bits.

A faster engine draws its random numbers differently, so its runs are not
bit-identical to the old engine's. What must agree are the outcome
distributions of the simulation-only experiment: per model and split
(overall, easy, difficult), each trial's success rate and its mean decision
time. `write_reference` saves them from one engine as a small CSV (one row per
decision); `compare` tests another engine's runs against it, cell by cell.

The test of a cell is a two-sided Mann-Whitney U on the per-trial values
(trials are the independent units: decisions of one trial are not), with
alpha = 0.01 shared over all cells (Bonferroni). A cell agrees when the test
does not reject AND the means are within a stated tolerance: 0.10 in success
rate, 15 % of the reference mean in decision time.

Everything runs at PRE_CHANGE_PARAMS, the parameter values in force when the
reference was written, pinned here so that a later change of the defaults
(which legitimately changes outcomes) cannot break or fake the comparison.

    python -m hcss.experiments.equivalence write tests/experiments/data/reference_outcomes.csv
    python -m hcss.experiments.equivalence compare tests/experiments/data/reference_outcomes.csv --runs 10
"""

from __future__ import annotations

import argparse
import csv
import math
import statistics
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from scipy.stats import mannwhitneyu

from hcss.experiments import experiment as exp
from hcss.simulation.params import Params
from hcss.tablespec import EQUIVALENCE_REFERENCE
from hcss.tidy_csv import write_rows

# Every Params value as it was on 2026-11-26 (commit 5718869), when the
# reference outcomes were written.  Do not follow the defaults.
PRE_CHANGE_PARAMS: dict[str, object] = {
    "arena_side_m": 1414.0,
    "hub_offset_m": 300.0,
    "n_agents": 200,
    "speed_mps": 60.0 / 3.6,
    "exploration_range_m": 500.0,
    "comm_range_m": 30.0,
    "hub_radius_m": 50.0,
    "sensing_radius_m": 20.0,
    "value_error": 0.1,
    "dt_s": 1.0,
    "turn_sd_rad": 0.5,
    "target_values": (0.7, 0.8, 0.9, 1.0),
    "target_distances_m": (150.0, 250.0, 350.0),
    "min_separation_m": 50.0,
    "decisions_per_section": 6,
    "decision_timeout_s": 30 * 60.0,
    "resume_factor": 9.0,
    "message_rate": 1.0,
    "abandon_alpha": 0.05,
    "abandon_unit_m": 100.0,
    "neighbour_draws": 8,
    "discovery_mu": 0.058,
    "discovery_xi": -0.29,
    "discovery_unit_m": 100.0,
    "site_d_min_m": 150.0,
    "site_d_max_m": 350.0,
    "quorum_k": 15,
    "investigate_agents": 10,
    "abandon_min_supporters": 2,
    "decide_min_support": 0.30,
    "decide_agents": 2,
    "intervention_support": 0.10,
    "outline_support": 0.30,
    "visible_reports": 1,
    "drawn_reports": 2,
    # The readings the reference engine used, pinned so later defaults cannot move them.
    "discovery": "spatial",
    "m2_distance_bounds": "site_distances",
    "m2_beyond_dmax": "guard",
    "foreign_targets": "eligible",
    "m2_mechanisms": ("discovery_delay", "reassessment_delay", "modulation"),
    # Readings and values named with the study calibration: the pre-change rules.
    "abandon_scale": 1.0,
    "abandonment": "per_visit",
    "m2_g_reading": "distance_only",
    "fitted_d_max_m": 500.0,
    "preset": "literal",
    # The readings of issue 28 (layout, label, F_D wait): the pre-change rules.
    "m2_discovery_wait_scale": 1.0,
    "easy_layout_others": "anywhere",
    "difficulty_label": "best_nearest",
    "label_distances": "exact",
    "label_ring_m": 100.0,
    # The readings of issue 39 (M_i's uses, M1's queue, d_min): the pre-change rules.
    "m2_modulation_uses": ("queue", "recruitment", "inhibition"),
    "m1_queue_modulation": "unmodulated",
    "m2_d_min": "search_space",
}

REFERENCE_SCENARIOS = 28
REFERENCE_RUNS = 4
REFERENCE_MODELS = ("M1", "M2")
OUTCOME_COLUMNS = EQUIVALENCE_REFERENCE.names

FAMILY_ALPHA = 0.01
SUCCESS_TOLERANCE = 0.10  # absolute difference of mean per-trial success rates
TIME_TOLERANCE = 0.15  # relative difference of mean per-trial decision times


def pinned_params() -> Params:
    known = {k: v for k, v in PRE_CHANGE_PARAMS.items() if k in Params.__dataclass_fields__}
    return Params().with_changes(**known)


def run_outcomes(
    scenarios: int = REFERENCE_SCENARIOS,
    runs: int = REFERENCE_RUNS,
    models: tuple[str, ...] = REFERENCE_MODELS,
    workers: int = 1,
) -> list[dict[str, Any]]:
    """The reduced experiment at the pinned parameters: one outcome row per decision."""
    jobs = exp.jobs_for(exp.experiment_scenarios(scenarios), models, runs)
    rows = exp.run_jobs(jobs, workers=workers, params=pinned_params())
    return [{column: row[column] for column in OUTCOME_COLUMNS} for row in rows]


def write_reference(rows: list[dict[str, Any]], path: Path) -> None:
    write_rows(
        path,
        OUTCOME_COLUMNS,
        (
            row | {"correct": bool(row["correct"]), "timed_out": bool(row["timed_out"])}
            for row in rows
        ),
    )


#: A true cell: `true` as hcss.tidy_csv writes it, `1` in references written before it.
TRUE = ("true", "1")


def read_reference(path: Path) -> list[dict[str, Any]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return [
            {
                "model": r["model"],
                "trial_id": r["trial_id"],
                "difficulty": r["difficulty"],
                "correct": r["correct"] in TRUE,
                "decision_time_s": float(r["decision_time_s"]),
                "timed_out": r["timed_out"] in TRUE,
            }
            for r in csv.DictReader(handle)
        ]


@dataclass(frozen=True)
class CellComparison:
    """One model × split × measure: reference against new, per-trial values."""

    model: str
    split: str
    measure: str  # "success_rate" or "decision_time_min"
    n_reference: int
    n_new: int
    reference_mean: float
    new_mean: float
    p_value: float
    threshold: float
    within_tolerance: bool

    @property
    def agrees(self) -> bool:
        return self.p_value >= self.threshold and self.within_tolerance

    def line(self) -> str:
        verdict = "agrees" if self.agrees else "DIFFERS"
        return (
            f"{self.model} {self.split:<9} {self.measure:<17} ref {self.reference_mean:7.3f} "
            f"(n={self.n_reference})  new {self.new_mean:7.3f} (n={self.n_new})  "
            f"Mann-Whitney p={self.p_value:.3g}  {verdict}"
        )


def per_trial(
    rows: list[dict[str, Any]], model: str, split: str
) -> tuple[list[float], list[float]]:
    """Each trial's success rate and mean decision time (minutes) within a split."""
    by_trial: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        if r["model"] == model and (split == "overall" or r["difficulty"] == split):
            by_trial.setdefault(r["trial_id"], []).append(r)
    success = [sum(bool(d["correct"]) for d in ds) / len(ds) for ds in by_trial.values()]
    minutes = [
        statistics.fmean(d["decision_time_s"] for d in ds) / 60.0 for ds in by_trial.values()
    ]
    return success, minutes


def compare(reference: list[dict[str, Any]], new: list[dict[str, Any]]) -> list[CellComparison]:
    models = sorted({r["model"] for r in reference})
    cells = [(m, s) for m in models for s in exp.SPLITS]
    threshold = FAMILY_ALPHA / (2 * len(cells))
    results = []
    for model, split in cells:
        ref_success, ref_minutes = per_trial(reference, model, split)
        new_success, new_minutes = per_trial(new, model, split)
        for measure, a, b in (
            ("success_rate", ref_success, new_success),
            ("decision_time_min", ref_minutes, new_minutes),
        ):
            if not a or not b:
                raise ValueError(f"no {model} {split} trials to compare")
            mean_a, mean_b = statistics.fmean(a), statistics.fmean(b)
            p = 1.0 if a == b else float(mannwhitneyu(a, b, alternative="two-sided").pvalue)
            if math.isnan(p):  # every value identical in both samples
                p = 1.0
            if measure == "success_rate":
                close = abs(mean_b - mean_a) <= SUCCESS_TOLERANCE
            else:
                close = abs(mean_b - mean_a) <= TIME_TOLERANCE * mean_a
            results.append(
                CellComparison(
                    model, split, measure, len(a), len(b), mean_a, mean_b, p, threshold, close
                )
            )
    return results


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("action", choices=("write", "compare"))
    parser.add_argument("reference", type=Path)
    parser.add_argument("--scenarios", type=int, default=REFERENCE_SCENARIOS)
    parser.add_argument("--runs", type=int, default=REFERENCE_RUNS)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    rows = run_outcomes(args.scenarios, args.runs, workers=args.workers)
    if args.action == "write":
        write_reference(rows, args.reference)
        print(f"{len(rows)} decisions written to {args.reference}")
        return
    results = compare(read_reference(args.reference), rows)
    for result in results:
        print(result.line())
    failed = [r for r in results if not r.agrees]
    print(f"{len(results) - len(failed)} of {len(results)} cells agree")
    if failed:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
