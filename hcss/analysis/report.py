"""Run the whole analysis and write every table, figure and report.html.

This is the one place that knows the order of the steps; each step is a
function from the modules beside it, so the command and the tests share one
code path and the report can never disagree with the tables.
"""

from __future__ import annotations

import html
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd
from tqdm import tqdm

from hcss.analysis.builders import (
    descriptive_tables,
    kruskal_table,
    mann_whitney_table,
    posthoc_tables,
    spearman_table,
)
from hcss.analysis.comparisons import correlations, omnibus_comparisons, simulation_comparisons
from hcss.analysis.descriptive import descriptive_frame
from hcss.analysis.figures import comparison_figure, write_figure
from hcss.analysis.load import AnalysisInputError, StudyTables, load_inputs
from hcss.analysis.measures import all_measures
from hcss.analysis.stats import MannWhitneyMethod
from hcss.analysis.tables import Table, to_html, write_table

#: Measures drawn in the study's comparison figure.
FIGURE_MEASURES = ("success_rate", "decision_time_min")


@dataclass(frozen=True)
class Report:
    """What was written: the tables, figure stems and the report page."""

    directory: Path
    tables: tuple[Table, ...]
    figures: tuple[str, ...]
    html_path: Path


def build_tables(
    measures: pd.DataFrame, mann_whitney_method: MannWhitneyMethod = "auto", continuity: bool = True
) -> list[Table]:
    """Every table, in report order."""
    tables = descriptive_tables(descriptive_frame(measures))
    omnibus = omnibus_comparisons(measures)
    if omnibus:
        tables.append(kruskal_table(omnibus))
        tables += [table for table in posthoc_tables(omnibus) if table.rows]
    two_sample = simulation_comparisons(measures, mann_whitney_method, continuity)
    if two_sample:
        tables.append(mann_whitney_table(two_sample))
    correlation_results = correlations(measures)
    if correlation_results:
        tables.append(spearman_table(correlation_results))
    return tables


def _inputs_summary(tables: StudyTables) -> str:
    decisions = tables.decisions
    counts = decisions.groupby("group").size()
    units = ", ".join(f"{group}: {counts.get(group, 0)} decisions" for group in tables.groups)
    inputs = ", ".join(sorted(set(decisions["input"])))
    return f"Inputs: {html.escape(inputs)}. {html.escape(units)}."


def write_html(
    directory: Path, tables: list[Table], figures: list[str], summary: str, include_pilot: bool
) -> Path:
    """One self-contained page linking the figures and holding every table."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    pilot = (
        "Bot, pilot and demo participants are <strong>included</strong>."
        if include_pilot
        else "Bot, pilot and demo participants are excluded."
    )
    figure_html = "".join(
        f'<figure><img src="figures/{name}.svg" alt="{html.escape(name)}">'
        f"<figcaption>{html.escape(name)} (<a href='figures/{name}.png'>PNG</a>)</figcaption>"
        "</figure>"
        for name in figures
    )
    table_html = "".join(
        f"<section>{to_html(table)}<p class='files'>"
        f"<a href='tables/{table.name}.csv'>CSV</a> · <a href='tables/{table.name}.tex'>LaTeX</a>"
        f" · <a href='tables/{table.name}.md'>Markdown</a></p></section>"
        for table in tables
    )
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>hcss analysis report</title>
<style>
body {{ font-family: sans-serif; margin: 2em; max-width: 75em; }}
table {{ border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }}
caption {{ text-align: left; font-weight: bold; padding: 0.3em 0; }}
th, td {{ border-bottom: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }}
th:first-child, td:first-child {{ text-align: left; }}
figure {{ display: inline-block; margin: 0.5em; }}
img {{ max-width: 40em; }}
.files {{ font-size: 0.8em; }}
</style></head><body>
<h1>hcss analysis report</h1>
<p>Generated {stamp}. {summary} {pilot}</p>
<h2>Figures</h2>{figure_html}
<h2>Tables</h2>{table_html}
</body></html>
"""
    path = directory / "report.html"
    path.write_text(page, encoding="utf-8")
    return path


def run_analysis(
    inputs: list[str | Path],
    out: str | Path,
    include_pilot: bool = False,
    progress: bool = True,
    mann_whitney_method: MannWhitneyMethod = "auto",
    continuity: bool = True,
) -> Report:
    """Load INPUTs, compute measures and tests, write tables, figures and report.html."""
    directory = Path(out)
    steps = tqdm(total=5, desc="hcss analyze", unit="step", disable=not progress)
    steps.set_postfix_str("loading")
    tables = load_inputs(inputs, include_pilot=include_pilot)
    steps.update()
    steps.set_postfix_str("measures")
    measures = all_measures(tables)
    if measures.empty:
        raise AnalysisInputError("the inputs hold no decisions or answers to analyse")
    directory.mkdir(parents=True, exist_ok=True)
    measures.to_csv(directory / "measures.csv", index=False)
    steps.update()
    steps.set_postfix_str("tests")
    built = build_tables(measures, mann_whitney_method, continuity)
    steps.update()
    steps.set_postfix_str("writing tables")
    for table in built:
        write_table(table, directory / "tables")
    steps.update()
    steps.set_postfix_str("figures")
    figures = []
    for measure in FIGURE_MEASURES:
        if (measures["measure"] == measure).any():
            write_figure(comparison_figure(measures, measure), directory / "figures", measure)
            figures.append(measure)
    html_path = write_html(directory, built, figures, _inputs_summary(tables), include_pilot)
    steps.update()
    steps.close()
    return Report(directory, tuple(built), tuple(figures), html_path)
