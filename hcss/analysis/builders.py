"""Table builders: arrange descriptive summaries and test results, compute nothing.

Descriptive tables follow the study's layout: per model, the mean with the
SD beneath it (in parentheses) and the median with the min–max beneath it,
for Overall, Easy and Difficult side by side.
"""

from __future__ import annotations

import math
import re

import pandas as pd

from hcss.analysis.comparisons import Correlation, OmnibusComparison, TwoSampleComparison
from hcss.analysis.decision_measures import SPLITS
from hcss.analysis.load import GROUP_ORDER
from hcss.analysis.measures import measure_label, measure_order
from hcss.analysis.stats import mann_whitney_u
from hcss.analysis.tables import (
    Table,
    effect_cell,
    effect_record,
    format_effect,
    format_number,
    format_p,
)
from hcss.tablespec.analysis import KRUSKAL_WALLIS

SPLIT_LABELS = {"overall": "Overall", "easy": "Easy", "difficult": "Difficult"}
POSTHOC_TITLES = {
    "tukey_kramer_ranks": "Tukey-Kramer comparisons of Kruskal-Wallis mean ranks "
    "(studentized range on ranks, large-sample, tie-corrected variance)",
    "dunn_holm": "Dunn's test (normal approximation, tie-corrected) with Holm correction",
    "tukey_hsd": "Tukey HSD on raw values (studentized range, pooled variance)",
}


def _file_name(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.lower()).strip("_")


def group_key(group: str) -> tuple[int, str]:
    """Sort key: simulation models, then M1–M3, then anything else (e.g. "All")."""
    return (GROUP_ORDER.index(group), group) if group in GROUP_ORDER else (len(GROUP_ORDER), group)


def descriptive_tables(summary: pd.DataFrame) -> list[Table]:
    """One table per measure from :func:`hcss.analysis.descriptive.descriptive_frame`."""
    tables = []
    for measure in sorted(summary["measure"].unique(), key=measure_order):
        rows_of_measure = summary[summary["measure"] == measure]
        splits = [split for split in SPLITS if split in set(rows_of_measure["split"])]
        header = ["Model"]
        for split in splits:
            header += [
                f"{SPLIT_LABELS[split]} mean (SD)",
                f"{SPLIT_LABELS[split]} median (min–max)",
            ]
        rows = []
        for group in sorted(rows_of_measure["group"].unique(), key=group_key):
            top, bottom = [f"{group}"], [""]
            for split in splits:
                found = rows_of_measure[
                    (rows_of_measure["group"] == group) & (rows_of_measure["split"] == split)
                ]
                if found.empty:
                    top += ["–", "–"]
                    bottom += ["", ""]
                    continue
                cell = found.iloc[0]
                top += [format_number(cell["mean"]), format_number(cell["median"])]
                bottom += [
                    f"({format_number(cell['sd'])})",
                    f"({format_number(cell['minimum'])}–{format_number(cell['maximum'])})",
                ]
            group_n = int(rows_of_measure.loc[rows_of_measure["group"] == group, "n"].max())
            top[0] = f"{group} (n = {group_n})"
            rows += [tuple(top), tuple(bottom)]
        order = sorted(
            rows_of_measure.index,
            key=lambda index: (
                group_key(rows_of_measure.at[index, "group"]),
                SPLITS.index(rows_of_measure.at[index, "split"]),
            ),
        )
        frame = rows_of_measure.loc[order].reset_index(drop=True)
        tables.append(
            Table(
                f"descriptive_{_file_name(measure)}",
                f"{measure_label(measure)}: mean (SD) and median (min–max) per model",
                tuple(header),
                tuple(rows),
                frame,
            )
        )
    return tables


def kruskal_table(comparisons: list[OmnibusComparison]) -> Table:
    """Kruskal-Wallis results as χ²(df, N = n) = H, p, ε²."""
    rows, records = [], []
    for comparison in comparisons:
        result = comparison.kruskal
        if result is None or math.isnan(result.statistic):
            text, p, effect, variant = "–", "–", "–", ""
        else:
            text = f"χ²({result.df:g}, N = {result.n}) = {format_number(result.statistic)}"
            p = format_p(result.p)
            effect = effect_cell(result)
            variant = result.method
        rows.append(
            (
                measure_label(comparison.measure),
                SPLIT_LABELS[comparison.split],
                ", ".join(comparison.groups),
                text,
                p,
                effect,
                variant,
                comparison.note,
            )
        )
        records.append(
            {
                "measure": comparison.measure,
                "split": comparison.split,
                "family": comparison.family,
                "groups": ",".join(comparison.groups),
                "H": result.statistic if result else None,
                "df": result.df if result else None,
                "n": result.n if result else None,
                "p": result.p if result else None,
                **effect_record(result, "epsilon_squared"),
                "method": result.method if result else "",
                "note": comparison.note,
            }
        )
    header = ("Measure", "Split", "Models", "χ²(df, N)", "p", "ε² [95% CI]", "Test", "Note")
    return Table(
        "kruskal_wallis",
        "Kruskal-Wallis tests across models; ε² = H/(n − 1) with a percentile bootstrap "
        "interval (2,000 resamples within groups, seeded). Not rstatix's kruskal_effsize, "
        "which reports η²[H] = (H − k + 1)/(n − k): a different effect size, smaller at few "
        "units, not a disagreement",
        header,
        tuple(rows),
        pd.DataFrame(records, columns=list(KRUSKAL_WALLIS.names)),
    )


def posthoc_tables(comparisons: list[OmnibusComparison]) -> list[Table]:
    """One table per post-hoc flavour, every pair of every Kruskal-Wallis family."""
    tables = []
    for test, title in POSTHOC_TITLES.items():
        rows, records = [], []
        for comparison in comparisons:
            for pairwise in comparison.posthoc:
                if pairwise.test != test:
                    continue
                for row in pairwise.rows:
                    rows.append(
                        (
                            measure_label(comparison.measure),
                            SPLIT_LABELS[comparison.split],
                            comparison.family,
                            f"{row.group_a} − {row.group_b}",
                            format_number(row.difference, 3),
                            f"[{format_number(row.lower, 3)}, {format_number(row.upper, 3)}]",
                            format_number(row.statistic),
                            format_p(row.p),
                        )
                    )
                    records.append(
                        {
                            "measure": comparison.measure,
                            "split": comparison.split,
                            "family": comparison.family,
                            "group_a": row.group_a,
                            "group_b": row.group_b,
                            "difference": row.difference,
                            "lower": row.lower,
                            "upper": row.upper,
                            pairwise.statistic_name: row.statistic,
                            "p": row.p,
                        }
                    )
        statistic = "z" if test == "dunn_holm" else "q"
        header = (
            "Measure",
            "Split",
            "Family",
            "Pair",
            "Difference",
            "95% interval",
            statistic,
            "p",
        )
        tables.append(Table(test, title, header, tuple(rows), pd.DataFrame(records)))
    return tables


def mann_whitney_table(comparisons: list[TwoSampleComparison]) -> Table:
    """Mann-Whitney M1SIM vs M2SIM as the paper prints it: n₁, n₂, U, R's W, p, r.

    U = min(U₁, U₂) is the paper's statistic; W = U₁ is what R's
    ``wilcox.test`` prints, so both are given.
    """
    rows, records = [], []
    for comparison in comparisons:
        result = comparison.result
        n1, n2 = comparison.sizes
        u = mann_whitney_u(result, n1, n2) if result else None
        rows.append(
            (
                measure_label(comparison.measure),
                SPLIT_LABELS[comparison.split],
                str(n1),
                str(n2),
                format_number(u, 1) if result else "–",
                format_number(result.statistic, 1) if result else "–",
                format_p(result.p) if result else "–",
                effect_cell(result) if result else "–",
                result.method if result else "",
                comparison.note,
            )
        )
        records.append(
            {
                "measure": comparison.measure,
                "split": comparison.split,
                "group_a": comparison.groups[0],
                "group_b": comparison.groups[1],
                "n_a": n1,
                "n_b": n2,
                "U": u,
                "W": result.statistic if result else None,
                "p": result.p if result else None,
                **effect_record(result, "rank_biserial_r"),
                "method": result.method if result else "",
                "note": comparison.note,
            }
        )
    a, b = comparisons[0].groups if comparisons else ("M1SIM", "M2SIM")
    header = (
        "Measure",
        "Split",
        f"n {a}",
        f"n {b}",
        "U",
        "W (R)",
        "p",
        "Rank-biserial r [95% CI]",
        "Test",
        "Note",
    )
    return Table(
        "mann_whitney",
        f"Mann-Whitney-Wilcoxon tests per scenario (runs averaged), {a} vs {b} "
        "(U = min(U₁, U₂); W as R prints it); rank-biserial r with its Fisher-z interval. "
        "Scenarios are the independent units; the study's own test over its units is in "
        '"The study\'s own tests"',
        header,
        tuple(rows),
        pd.DataFrame(records),
    )


def spearman_table(results: list[Correlation]) -> Table:
    """Spearman correlations: ρ, df, p and n per group."""
    rows, records = [], []
    for correlation in results:
        result = correlation.result
        rows.append(
            (
                f"{measure_label(correlation.x)} vs {measure_label(correlation.y)}",
                correlation.group,
                format_effect(
                    result.statistic,
                    result.effect_lower,
                    result.effect_upper,
                    result.interval_method,
                )
                if result
                else "–",
                f"{result.df:g}" if result else "–",
                format_p(result.p) if result else "–",
                str(result.n) if result else "–",
                result.method if result else "",
                correlation.note,
            )
        )
        records.append(
            {
                "x": correlation.x,
                "y": correlation.y,
                "group": correlation.group,
                "rho": result.statistic if result else None,
                "rho_lower": result.effect_lower if result else None,
                "rho_upper": result.effect_upper if result else None,
                "df": result.df if result else None,
                "p": result.p if result else None,
                "n": result.n if result else None,
                "method": result.method if result else "",
                "note": correlation.note,
            }
        )
    header = ("Correlation", "Models", "ρ [95% CI]", "df", "p", "N", "p method", "Note")
    return Table(
        "spearman",
        "Spearman correlations with success rate; 95% CI by Fisher z with Bonett-Wright SE",
        header,
        tuple(rows),
        pd.DataFrame(records),
    )
