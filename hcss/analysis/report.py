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

from tqdm import tqdm

from hcss.analysis.banner import SampleBanner, sample_banner
from hcss.analysis.figures import write_figure
from hcss.analysis.load import AnalysisInputError, StudyTables, load_inputs
from hcss.analysis.measures import all_measures
from hcss.analysis.rscript import write_r_script
from hcss.analysis.sections import Section, build_sections
from hcss.analysis.stats import MannWhitneyMethod
from hcss.analysis.studies import studies_line
from hcss.analysis.tables import Table, to_html, write_checked, write_paper_table
from hcss.tablespec.analysis import MEASURES

STYLE = """
body { font-family: sans-serif; margin: 2em; max-width: 80em; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.88em; }
caption { text-align: left; font-weight: bold; padding: 0.3em 0; }
th, td { border-bottom: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
figure { display: inline-block; margin: 0.5em; }
img { max-width: 46em; }
.files { font-size: 0.8em; }
.banner { background: #eef4fb; border-left: 4px solid #3182bd; padding: 0.2em 1em; }
.warning { background: #fff3cd; border-left: 4px solid #e0a800; padding: 0.4em 0.8em; }
nav ol { columns: 2; }
"""


@dataclass(frozen=True)
class Report:
    """What was written: the tables, figure stems and the report page."""

    directory: Path
    tables: tuple[Table, ...]
    figures: tuple[str, ...]
    html_path: Path
    sections: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()


def _inputs_html(tables: StudyTables) -> str:
    """The inputs actually read (by file name: a report travels without its paths)."""
    items = []
    for summary in tables.inputs:
        counts = ", ".join(f"{table} {rows}" for table, rows in summary.table_rows if rows)
        name = Path(summary.path).name
        items.append(
            f"<li><code>{html.escape(name)}</code>: {html.escape(counts or 'no rows')}</li>"
        )
    warnings = "".join(
        f"<p class='warning'>Warning: {html.escape(_without_paths(text, tables))}</p>"
        for text in tables.warnings
    )
    studies = studies_line(tables.studies, tables.never_opened)
    if studies:
        warnings += f"<p id='studies'>{html.escape(studies)}</p>"
    groups = tables.decisions.groupby("group").size()
    decided = ", ".join(
        f"{group}: {groups[group]} decision{'' if groups[group] == 1 else 's'}"
        for group in tables.groups
    )
    return (
        f"<ul>{''.join(items)}</ul>{warnings}"
        f"<p>{html.escape(decided or 'No completed decisions in the inputs.')}</p>"
    )


def _without_paths(text: str, tables: StudyTables) -> str:
    for summary in tables.inputs:
        text = text.replace(summary.path, Path(summary.path).name)
    return text


def _banner_html(banner: SampleBanner, excluded: str) -> str:
    """The sample first: counts, what was left out, and the tests too small to run."""
    counts = "".join(f"<li>{html.escape(line)}</li>" for line in banner.counts)
    parts = [f"<section id='banner' class='banner'><h2>Sample at a glance</h2><ul>{counts}"]
    parts.append(f"<li>{html.escape(excluded)}</li></ul>")
    if banner.not_run:
        items = "".join(f"<li>{html.escape(reason)}</li>" for reason in banner.not_run)
        parts.append(f"<p><strong>Not run: the sample is too small</strong></p><ul>{items}</ul>")
    parts.append("</section>")
    return "".join(parts)


def _excluded_text(tables: StudyTables, include_pilot: bool) -> str:
    """What --include-pilot would change, counted."""
    everyone = tables.all_participants
    kinds = {"is_bot": "bot", "is_pilot": "pilot", "is_demo": "demo"}
    counts = []
    for column, word in kinds.items():
        if column in everyone.columns:
            count = int(everyone[column].fillna(False).astype(bool).sum())
            counts.append(f"{count} {word}{'' if count == 1 else 's'}")
    listed = ", ".join(counts) or "none flagged"
    if include_pilot:
        text = f"Bot, pilot and demo participants are included (--include-pilot): {listed}."
    else:
        text = f"Left out (bot, pilot and demo participants; --include-pilot keeps them): {listed}."
    return f"{text} {_partial_text(tables)}".strip()


def _partial_text(tables: StudyTables) -> str:
    """Whether participants who did not complete contribute their partial trials."""
    if tables.completers_only:
        n = tables.left_out_partial
        return (
            f"Completers only (--completers-only): {n} participant{'' if n == 1 else 's'} "
            "who did not complete left out."
        )
    if not tables.partial:
        return ""
    n = tables.partial
    who = "participant who did" if n == 1 else "participants who did"
    return (
        f"{n} analysed {who} not complete (aborted, timed out, declined or in progress): "
        "their partial trials and answers enter the per-model measures; "
        "--completers-only leaves them out."
    )


def _table_html(table: Table) -> str:
    return (
        f"{to_html(table)}<p class='files'><a href='tables/{table.name}.csv'>CSV</a> · "
        f"<a href='tables/{table.name}.tex'>LaTeX</a> · "
        f"<a href='tables/{table.name}.md'>Markdown</a></p>"
    )


def _section_html(section: Section, figures: list[str]) -> str:
    parts = [f"<section id='{section.key}'><h2>{html.escape(section.title)}</h2>"]
    if section.intro:
        parts.append(f"<p>{html.escape(section.intro)}</p>")
    for name in figures:
        parts.append(
            f'<figure><img src="figures/{name}.svg" alt="{html.escape(name)}">'
            f"<figcaption>{html.escape(name)} (<a href='figures/{name}.svg'>SVG</a> · "
            f"<a href='figures/{name}.png'>PNG</a>)</figcaption></figure>"
        )
    parts += [_table_html(table) for table in section.tables]
    if section.details:
        parts.append(
            f"<details><summary>{html.escape(section.details_label)} "
            f"({len(section.details)})</summary>"
            + "".join(_table_html(table) for table in section.details)
            + "</details>"
        )
    parts.append("</section>")
    return "".join(parts)


def write_html(
    directory: Path,
    sections: list[Section],
    figures: dict[str, list[str]],
    tables: StudyTables,
    include_pilot: bool,
) -> Path:
    """One page: contents, inputs, then every section with its figures and tables."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    banner = _banner_html(sample_banner(tables), _excluded_text(tables, include_pilot))
    contents = "".join(
        f"<li><a href='#{section.key}'>{html.escape(section.title)}</a></li>"
        for section in sections
    )
    body = "".join(_section_html(section, figures.get(section.key, [])) for section in sections)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>hcss analysis report</title>
<style>{STYLE}</style></head><body>
<h1>hcss analysis report</h1>
<p>Generated {stamp}. R code for every test is in <a href="analysis.R">analysis.R</a>.</p>
{banner}
<nav id="contents"><h2>Contents</h2><ol><li><a href="#inputs">Inputs read</a></li>{contents}</ol></nav>
<section id="inputs"><h2>Inputs read</h2>{_inputs_html(tables)}</section>
{body}
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
    study: str | None = None,
    pool_studies: bool = False,
    pool_synthetic: bool = False,
    completers_only: bool = False,
    drop_exact_duplicates: bool = False,
) -> Report:
    """Load INPUTs (one study's participants, or several study files only when pooled),
    compute measures and tests, write tables, figures and report.html."""
    tables = load_inputs(
        inputs,
        include_pilot=include_pilot,
        study=study,
        pool_studies=pool_studies,
        pool_synthetic=pool_synthetic,
        completers_only=completers_only,
        drop_exact_duplicates=drop_exact_duplicates,
    )
    return analyse_tables(tables, out, include_pilot, progress, mann_whitney_method, continuity)


def analyse_tables(
    tables: StudyTables,
    out: str | Path,
    include_pilot: bool = False,
    progress: bool = True,
    mann_whitney_method: MannWhitneyMethod = "auto",
    continuity: bool = True,
) -> Report:
    """Measures, tests, tables, figures and report.html from inputs already loaded and
    checked (:func:`hcss.analysis.load.load_inputs`): the command loads first, so a refused
    input never waits for the statistics libraries to import."""
    directory = Path(out)
    steps = tqdm(total=4, desc="hcss analyze", unit="step", disable=not progress)
    steps.set_postfix_str("measures")
    measures = all_measures(tables)
    if measures.empty and tables.all_participants.empty:
        raise AnalysisInputError("the inputs hold no decisions, answers or participants to analyse")
    directory.mkdir(parents=True, exist_ok=True)
    write_checked(directory / "measures.csv", measures, MEASURES)
    steps.update()
    steps.set_postfix_str("tests")
    sections = build_sections(tables, measures, include_pilot, mann_whitney_method, continuity)
    built = [table for section in sections for table in (*section.tables, *section.details)]
    steps.update()
    steps.set_postfix_str("writing tables")
    for table in built:
        write_paper_table(table, directory / "tables")
    steps.update()
    steps.set_postfix_str("figures")
    figures: dict[str, list[str]] = {}
    for section in sections:
        for name, draw in section.figures:
            write_figure(draw(), directory / "figures", name)
            figures.setdefault(section.key, []).append(name)
    write_r_script(directory, tables.decisions, tables.participants, tables.scores)
    html_path = write_html(directory, sections, figures, tables, include_pilot)
    steps.update()
    steps.close()
    return Report(
        directory,
        tuple(built),
        tuple(name for names in figures.values() for name in names),
        html_path,
        tuple(section.key for section in sections),
        tables.warnings,
    )
