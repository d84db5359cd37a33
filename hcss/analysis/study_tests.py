"""The study's own tests, over the study's own units, labelled as the study's.

The study tested its simulation-only models over (trial scenario, decision
slot) units (`hcss.study_units`): Mann-Whitney M1 vs M2 printed as N = n₁ + n₂,
DOF, U and p, and Spearman correlations of decision time with success per
model and split. Its human-team tables are per decision, and its five-group
Kruskal-Wallis (M1 SIM, M2 SIM, M1, M2, M3) with Tukey-Kramer pairs pools
both kinds of value. These tables reproduce those tests so a run can be put
beside the paper's numbers. The units are not independent (twelve slots share
a scenario, ten runs share its layout), so their p-values are the study's
description, not inference on scenarios: the per-scenario tests stay the
report's primary ones.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from hcss import study_units as su
from hcss.analysis.paper_units import simulation_units
from hcss.analysis.posthoc import tukey_kramer_ranks
from hcss.analysis.shift import hodges_lehmann
from hcss.analysis.stats import TestResult, kruskal_wallis, mann_whitney, mann_whitney_u, spearman
from hcss.analysis.tables import (
    Table,
    effect_cell,
    effect_record,
    format_effect,
    format_number,
    format_p,
)

#: Said in every caption of these tables.
NOT_INDEPENDENT = (
    "The study's test over its units: units share scenarios and runs, so they are not "
    "independent and p describes the study's test, not inference on scenarios (the "
    "per-scenario tests are the primary ones)."
)
UNIT_WORDS = {"success_pct": "points", "time_min": "min"}
FIVE_GROUPS = ("M1SIM", "M2SIM", "M1", "M2", "M3")


def unit_values(units: Sequence[su.Unit]) -> dict[tuple[str, str, str], list[float]]:
    """(model, split, measure) -> the values of the study's units, in unit order."""
    values: dict[tuple[str, str, str], list[float]] = {}
    for unit in units:
        for measure in su.MEASURES:
            values.setdefault((unit.model, unit.split, measure), []).append(
                float(getattr(unit, measure))
            )
    return values


def human_decision_values(decisions: pd.DataFrame) -> dict[tuple[str, str, str], list[float]]:
    """(model, split, measure) -> the study's per-decision values of human-collective teams:
    success 0 or 100, decision time in minutes (a decision without a time left out)."""
    chosen = decisions[decisions["source"] == "study"]
    values: dict[tuple[str, str, str], list[float]] = {}
    for split in su.SPLITS:
        part = chosen if split == "overall" else chosen[chosen["difficulty"] == split]
        for model, rows in part.groupby("model", observed=True):
            success = 100.0 * rows["correct"].astype(float).to_numpy()
            minutes = rows["decision_time_s"].astype(float).to_numpy() / 60.0
            values[(str(model), split, "success_pct")] = list(success)
            values[(str(model), split, "time_min")] = list(minutes[~np.isnan(minutes)])
    return values


def _mann_whitney_rows(
    values: Mapping[tuple[str, str, str], list[float]],
) -> tuple[list[tuple[str, ...]], list[dict[str, object]]]:
    rows: list[tuple[str, ...]] = []
    records: list[dict[str, object]] = []
    for measure in su.MEASURES:
        for split in su.SPLITS:
            m1, m2 = values.get(("M1", split, measure)), values.get(("M2", split, measure))
            if not m1 or not m2:
                continue
            result = mann_whitney(m2, m1)
            shift = hodges_lehmann(m2, m1)
            u = mann_whitney_u(result, len(m2), len(m1))
            shift_text = format_effect(shift.estimate, shift.lower, shift.upper, shift.method)
            rows.append(
                (
                    su.MEASURE_LABELS[measure],
                    split,
                    f"{len(m1) + len(m2)} ({len(m1)} + {len(m2)})",
                    "1",
                    format_number(u, 1),
                    format_p(result.p),
                    effect_cell(result),
                    f"{shift_text} {UNIT_WORDS[measure]}",
                    result.method,
                )
            )
            records.append(
                {
                    "measure": measure,
                    "split": split,
                    "n_m1": len(m1),
                    "n_m2": len(m2),
                    "N": len(m1) + len(m2),
                    "dof": 1,
                    "U": u,
                    "W": result.statistic,
                    "p": result.p,
                    **effect_record(result, "rank_biserial_r"),
                    "shift": shift.estimate,
                    "shift_lower": shift.lower,
                    "shift_upper": shift.upper,
                    "shift_method": shift.method,
                    "method": result.method,
                }
            )
    return rows, records


def study_mann_whitney_table(units: Sequence[su.Unit]) -> Table | None:
    """Mann-Whitney M2 vs M1 over the study's units, as the study prints it (N, DOF, U, p),
    with the rank-biserial r and the Hodges–Lehmann shift M2 − M1 in the measure's unit."""
    rows, records = _mann_whitney_rows(unit_values(units))
    if not rows:
        return None
    return Table(
        "study_units_mann_whitney",
        "Simulation-only M2 vs M1, Mann-Whitney over the study's units as the study prints "
        "it: N = n₁ + n₂ (M1 + M2), DOF = groups − 1, U = min(U₁, U₂); rank-biserial r "
        "(positive: M2 larger) and the Hodges–Lehmann shift M2 − M1 with R's 95% interval. "
        + NOT_INDEPENDENT,
        ("Measure", "Split", "N (M1 + M2)", "DOF", "U", "p", "r [95% CI]", "Shift M2 − M1", "Test"),
        tuple(rows),
        pd.DataFrame(records),
    )


def study_spearman_table(units: Sequence[su.Unit]) -> Table | None:
    """Spearman ρ of decision time with success over the study's units, per model and split."""
    values = unit_values(units)
    rows, records = [], []
    for model in ("M1", "M2"):
        for split in su.SPLITS:
            success = values.get((model, split, "success_pct"), [])
            minutes = values.get((model, split, "time_min"), [])
            if len(success) < 4:
                continue
            result = spearman(minutes, success)
            rows.append(
                (
                    f"{model}SIM",
                    split,
                    str(result.n),
                    format_number(result.statistic),
                    format_p(result.p),
                    effect_cell(result),
                    result.method or result.note,
                )
            )
            records.append(
                {
                    "group": f"{model}SIM",
                    "split": split,
                    "n": result.n,
                    "rho": result.statistic,
                    "rho_lower": result.effect_lower,
                    "rho_upper": result.effect_upper,
                    "p": result.p,
                    "method": result.method,
                    "note": result.note,
                }
            )
    if not rows:
        return None
    return Table(
        "study_units_spearman",
        "Simulation-only: Spearman ρ of decision time (min) with success rate (%) over the "
        "study's units, per model and split; p as R's cor.test. " + NOT_INDEPENDENT,
        ("Group", "Split", "Units", "ρ", "p", "ρ [95% CI]", "p from"),
        tuple(rows),
        pd.DataFrame(records),
    )


def _five_group_values(
    decisions: pd.DataFrame, units: Sequence[su.Unit]
) -> dict[tuple[str, str, str], list[float]]:
    values = {
        (f"{model}SIM", split, measure): cells
        for (model, split, measure), cells in unit_values(units).items()
    }
    values.update(human_decision_values(decisions))
    return values


def five_group_tables(
    decisions: pd.DataFrame, units: Sequence[su.Unit] | None = None
) -> list[Table]:
    """Kruskal-Wallis over M1 SIM, M2 SIM (units) and M1–M3 (decisions), and its Tukey-Kramer
    pairs on mean ranks, when the inputs hold both simulation and human decisions."""
    sources = set(decisions["source"]) if not decisions.empty else set()
    if not {"simulation", "study"} <= sources:
        return []
    units = simulation_units(decisions) if units is None else units
    values = _five_group_values(decisions, units)
    omnibus_rows, omnibus_records, pair_rows, pair_records = [], [], [], []
    for measure in su.MEASURES:
        for split in su.SPLITS:
            groups = {
                g: values[(g, split, measure)]
                for g in FIVE_GROUPS
                if values.get((g, split, measure))
            }
            if len(groups) < 2:
                continue
            result: TestResult = kruskal_wallis(groups)
            omnibus_rows.append(
                (
                    su.MEASURE_LABELS[measure],
                    split,
                    " / ".join(f"{g} {len(v)}" for g, v in groups.items()),
                    str(result.n),
                    format_number(result.df, 0),
                    format_number(result.statistic),
                    format_p(result.p),
                )
            )
            omnibus_records.append(
                {
                    "measure": measure,
                    "split": split,
                    "groups": " ".join(groups),
                    "n": result.n,
                    "df": result.df,
                    "chi2": result.statistic,
                    "p": result.p,
                    "method": result.method,
                    "note": result.note,
                }
            )
            pairs = tukey_kramer_ranks(groups)
            for row in pairs.rows:
                pair_rows.append(
                    (
                        su.MEASURE_LABELS[measure],
                        split,
                        f"{row.group_a} − {row.group_b}",
                        format_number(row.difference, 1),
                        f"[{format_number(row.lower, 1)}, {format_number(row.upper, 1)}]",
                        format_number(row.statistic),
                        format_p(row.p),
                    )
                )
                pair_records.append(
                    {
                        "measure": measure,
                        "split": split,
                        "family": "study five groups",
                        "group_a": row.group_a,
                        "group_b": row.group_b,
                        "difference": row.difference,
                        "lower": row.lower,
                        "upper": row.upper,
                        "q": row.statistic,
                        "p": row.p,
                    }
                )
    if not omnibus_rows:
        return []
    values_note = (
        "Simulation values are the study's units (runs averaged), human values are single "
        "decisions (success 0 or 100), as the study's tables are. "
    )
    return [
        Table(
            "study_five_groups_kruskal",
            "The study's five-group Kruskal-Wallis (M1 SIM, M2 SIM, M1, M2, M3). "
            + values_note
            + NOT_INDEPENDENT.replace(
                "units share scenarios and runs",
                "units share scenarios and runs, decisions share participants",
            ),
            ("Measure", "Split", "n per group", "N", "DOF", "χ²", "p"),
            tuple(omnibus_rows),
            pd.DataFrame(omnibus_records),
        ),
        Table(
            "study_five_groups_tukey_kramer",
            "Tukey-Kramer pairs on the five groups' Kruskal-Wallis mean ranks (differences of "
            "mean ranks, 95% simultaneous intervals, studentized range with infinite df). "
            + values_note,
            ("Measure", "Split", "Pair", "Mean-rank difference", "95% CI", "q", "p"),
            tuple(pair_rows),
            pd.DataFrame(pair_records),
        ),
    ]


def study_tables(decisions: pd.DataFrame, units: Sequence[su.Unit] | None = None) -> list[Table]:
    """Every table of the study's own tests over the simulation's units, in the paper's order
    (``units``: :func:`hcss.analysis.paper_units.simulation_units`, when already computed)."""
    units = simulation_units(decisions) if units is None else units
    tables: Sequence[Table | None] = (
        study_mann_whitney_table(units),
        study_spearman_table(units),
    )
    return [table for table in tables if table is not None]
