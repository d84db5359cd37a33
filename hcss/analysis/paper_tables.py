"""Tables as the paper prints them: one per measure family, and p-value matrices.

A family table has one row per measure and split and one column per model
(mean with SD), then the independent-groups Kruskal-Wallis p (the paper's
test) and the repeated-measures Friedman p beside it, so the reader sees
both without hunting through the long lists.
"""

from __future__ import annotations

import pandas as pd

from hcss.analysis.builders import SPLIT_LABELS, group_key
from hcss.analysis.comparisons import HUMAN_GROUPS, OmnibusComparison
from hcss.analysis.decision_measures import SPLITS
from hcss.analysis.families import Family
from hcss.analysis.measures import measure_label
from hcss.analysis.paired import RepeatedComparison
from hcss.analysis.tables import Table, format_number, format_p

Key = tuple[str, str]


def _mean_sd(row: pd.Series | None) -> str:
    if row is None:
        return "–"
    return f"{format_number(row['mean'])} ({format_number(row['sd'])})"


def _sizes(cells: pd.DataFrame, groups: list[str]) -> str:
    """Units per model, once when every model has the same number (e.g. ``28``, ``28/27/28``)."""
    counts = cells.set_index("group")["n"].reindex(groups).dropna().astype(int)
    return str(counts.iloc[0]) if counts.nunique() == 1 else "/".join(map(str, counts))


def family_table(
    family: Family,
    summary: pd.DataFrame,
    kruskal: dict[Key, OmnibusComparison],
    friedman: dict[Key, RepeatedComparison],
) -> Table | None:
    """The family's measures × splits against models, with both omnibus p."""
    members = family.members(summary)
    if not members:
        return None
    chosen = summary[summary["measure"].isin(members)]
    groups = sorted(chosen["group"].unique(), key=group_key)
    header = (
        "Measure",
        "Split",
        *(f"{group} M (SD)" for group in groups),
        f"n ({'/'.join(groups)})",
        "KW p",
        "Friedman p",
    )
    rows, records = [], []
    for measure in members:
        for split in SPLITS:
            cells = chosen[(chosen["measure"] == measure) & (chosen["split"] == split)]
            if cells.empty:
                continue
            by_group = {row["group"]: row for _, row in cells.iterrows()}
            omnibus = kruskal.get((measure, split))
            repeated = friedman.get((measure, split))
            kw_p = omnibus.kruskal.p if omnibus and omnibus.kruskal else float("nan")
            fr_p = repeated.friedman.p if repeated and repeated.friedman else float("nan")
            rows.append(
                (
                    measure_label(measure),
                    SPLIT_LABELS[split],
                    *(_mean_sd(by_group.get(group)) for group in groups),
                    _sizes(cells, groups),
                    format_p(kw_p),
                    format_p(fr_p),
                )
            )
            for group, row in by_group.items():
                records.append(
                    {
                        "measure": measure,
                        "split": split,
                        "group": group,
                        "n": row["n"],
                        "mean": row["mean"],
                        "sd": row["sd"],
                        "median": row["median"],
                        "kruskal_p": kw_p,
                        "friedman_p": fr_p,
                    }
                )
    header, rows = _without_untested(header, rows)
    return Table(
        f"family_{family.key}",
        f"{family.title}: mean (SD) per "
        + (
            "model (All: measured once per participant, not per model)"
            if "All" in groups
            else "model"
        )
        + ". n: participants (simulation scenarios for "
        "simulated rows) with a value in that split, one number when every model has the same, "
        "else one per model in the order of the header; a split has fewer when some trials had "
        "no decision of that kind.",
        header,
        tuple(rows),
        pd.DataFrame(records),
    )


def _without_untested(
    header: tuple[str, ...], rows: list[tuple[str, ...]]
) -> tuple[tuple[str, ...], list[tuple[str, ...]]]:
    """Drop the KW/Friedman p columns when no row has that test (a sample too small for it)."""
    keep = [
        index
        for index, name in enumerate(header)
        if name not in ("KW p", "Friedman p") or any(row[index] != "–" for row in rows)
    ]
    return tuple(header[i] for i in keep), [tuple(row[i] for i in keep) for row in rows]


def pvalue_matrix(
    family: Family,
    measures: list[str],
    omnibus: list[OmnibusComparison],
    repeated: list[RepeatedComparison],
) -> Table | None:
    """Pairwise p matrices of a family's measures, one M1–M3 block per measure and split.

    Above the diagonal: the paper's Tukey-Kramer comparisons of mean ranks
    (independent groups); below: paired Wilcoxon signed-rank, Holm-adjusted
    (the repeated-measures design).
    """
    upper = {
        (c.measure, c.split, row.group_a, row.group_b): row.p
        for c in omnibus
        if c.family == "human-collective models"
        for flavour in c.posthoc
        if flavour.test == "tukey_kramer_ranks"
        for row in flavour.rows
    }
    lower = {
        (c.measure, c.split, pair.group_a, pair.group_b): pair.p_holm
        for c in repeated
        for pair in c.pairs
    }
    rows, records = [], []
    for measure in measures:
        for split in SPLITS:
            if not any(key[:2] == (measure, split) for key in (*upper, *lower)):
                continue
            for i, row_group in enumerate(HUMAN_GROUPS):
                cells = []
                for j, column_group in enumerate(HUMAN_GROUPS):
                    if i == j:
                        cells.append("—")
                        continue
                    first, second = sorted((row_group, column_group), key=HUMAN_GROUPS.index)
                    source = upper if j > i else lower
                    p = source.get((measure, split, first, second), float("nan"))
                    cells.append(format_p(p))
                    records.append(
                        {
                            "measure": measure,
                            "split": split,
                            "row": row_group,
                            "column": column_group,
                            "test": "tukey_kramer_ranks" if j > i else "wilcoxon_holm",
                            "p": p,
                        }
                    )
                label = measure_label(measure) if i == 0 else ""
                rows.append((label, SPLIT_LABELS[split] if i == 0 else "", row_group, *cells))
    if not rows:
        return None
    return Table(
        f"pmatrix_{family.key}",
        f"{family.title}: pairwise p per measure (above the diagonal Tukey-Kramer on mean "
        "ranks, independent groups; below, paired Wilcoxon with Holm)",
        ("Measure", "Split", "Model", *HUMAN_GROUPS),
        tuple(rows),
        pd.DataFrame(records),
    )
