"""The simulation-only experiment's summary, computed by the analysis itself.

``hcss simulate experiment`` writes the decisions and asks this module for the
summary, so it and ``hcss analyze`` share the loading, the unit of analysis (a
scenario, its runs averaged), the descriptive statistics and the table writer,
and cannot disagree on the same decisions file.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from hcss.analysis.decision_measures import SPLITS, decision_measures
from hcss.analysis.descriptive import descriptive_frame
from hcss.analysis.load import load_inputs
from hcss.analysis.paper_units import paper_unit_tables
from hcss.analysis.tables import Table, format_number, to_markdown, write_paper_table

SUMMARY_MEASURES = ("success_rate", "decision_time_min")


def simulation_summary(decisions_path: Path) -> Table:
    """Per model and split: scenarios, success rate and decision time, mean (SD), median (range)."""
    decisions = load_inputs([decisions_path], include_pilot=True).decisions
    summary = descriptive_frame(decision_measures(decisions))
    summary = summary[summary["measure"].isin(SUMMARY_MEASURES)]
    rows, records = [], []
    for group in sorted(summary["group"].unique()):
        for split in SPLITS:
            cells = summary[(summary["group"] == group) & (summary["split"] == split)]
            if cells.empty:
                continue
            by_measure = cells.set_index("measure")
            row = [group.removesuffix("SIM"), split, str(int(cells["n"].max()))]
            for measure, digits in zip(SUMMARY_MEASURES, (3, 2), strict=True):
                cell = by_measure.loc[measure]
                row += [
                    f"{format_number(cell['mean'], digits)} ({format_number(cell['sd'], digits)})",
                    f"{format_number(cell['median'], digits)} "
                    f"({format_number(cell['minimum'], digits)}–"
                    f"{format_number(cell['maximum'], digits)})",
                ]
                records.append(
                    {"model": row[0], "split": split, "measure": measure}
                    | {
                        key: cell[key]
                        for key in ("n", "mean", "sd", "median", "minimum", "maximum")
                    }
                )
            rows.append(tuple(row))
    return Table(
        "summary",
        "Simulation-only experiment: per scenario (runs averaged), mean (SD) and median (min–max)",
        (
            "model",
            "split",
            "scenarios",
            "success mean (SD)",
            "success median (range)",
            "time (min) mean (SD)",
            "time median (range)",
        ),
        tuple(rows),
        pd.DataFrame(records),
    )


def write_simulation_summary(decisions_path: Path, directory: Path) -> Table:
    """Write summary.md, summary.tex and summary.csv beside the decisions table."""
    table = simulation_summary(decisions_path)
    write_paper_table(table, directory)
    return table


def summarise_decisions(decisions_path: Path) -> str:
    """The summary as Markdown, its tables also written beside the decisions file.

    The study's tables under its own unit (`paper_units`) follow the summary.
    """
    text = to_markdown(write_simulation_summary(decisions_path, decisions_path.parent))
    decisions = load_inputs([decisions_path], include_pilot=True).decisions
    for table in paper_unit_tables(decisions):
        write_paper_table(table, decisions_path.parent)
        text += "\n" + to_markdown(table)
    return text
