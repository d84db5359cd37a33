"""A table as displayed cells plus its numbers, written as Markdown, LaTeX and CSV.

Display and numbers are kept apart on purpose: the Markdown/LaTeX/HTML show
the study's layout (mean above its SD, a χ² in APA style), while the CSV
keeps full-precision numbers in tidy columns, ready for re-analysis.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from hcss.analysis.stats import TestResult
from hcss.tablespec import TableSpec
from hcss.tablespec.analysis import NO_ROWS, analysis_table
from hcss.tablespec.frames import conform
from hcss.tidy_csv import write_frame


@dataclass(frozen=True)
class Table:
    """A titled table: ``header`` and ``rows`` are display strings, ``frame`` the numbers."""

    name: str
    caption: str
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    frame: pd.DataFrame


def format_number(value: float | None, digits: int = 2) -> str:
    """Fixed decimals, an en dash for a missing value."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    return f"{value:.{digits}f}"


def format_p(p: float) -> str:
    """p as the study writes it: three decimals, ``< .001`` below that."""
    if p is None or math.isnan(p):
        return "–"
    if p < 0.001:
        return "< .001"
    return f"{p:.3f}".replace("0.", ".", 1) if p < 1 else "1.000"


def format_effect(estimate: float, lower: float, upper: float, method: str = "") -> str:
    """An effect size with its 95% interval, ``0.42 [0.10, 0.66]``.

    Without an interval the estimate is followed by why there is none
    (``method``, e.g. ``1.00 (no CI: r = +1, …)``), never printed bare.
    """
    if estimate is None or math.isnan(estimate):
        return "–"
    if lower is None or upper is None or math.isnan(lower) or math.isnan(upper):
        return f"{format_number(estimate)} ({method or 'no CI'})"
    return f"{format_number(estimate)} [{format_number(lower)}, {format_number(upper)}]"


def effect_cell(result: TestResult) -> str:
    """The effect size cell of a test: estimate, interval or the reason it has none."""
    return format_effect(
        result.effect_size, result.effect_lower, result.effect_upper, result.interval_method
    )


def effect_record(result: TestResult | None, column: str) -> dict[str, object]:
    """The effect, its interval and how it was computed, as CSV columns named after it."""
    if result is None:
        return {column: None, f"{column}_lower": None, f"{column}_upper": None}
    return {
        column: result.effect_size,
        f"{column}_lower": result.effect_lower,
        f"{column}_upper": result.effect_upper,
        "interval_method": result.interval_method,
    }


def to_markdown(table: Table) -> str:
    """GitHub-flavoured Markdown with the caption as a heading."""

    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |"

    lines = [f"### {table.caption}", "", line(table.header)]
    lines.append("|" + "|".join(" --- " for _ in table.header) + "|")
    lines += [line(row) for row in table.rows]
    return "\n".join(lines) + "\n"


_LATEX_SPECIAL = {
    "\\": r"\textbackslash{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
    "χ²": r"$\chi^2$",
    "ε²": r"$\varepsilon^2$",
    "ρ": r"$\rho$",
    "−": "--",
    "–": "--",
    "<": r"$<$",
}


def latex_escape(text: str) -> str:
    """Escape LaTeX specials and spell the Greek the tables use."""
    out, index = [], 0
    while index < len(text):
        for token, replacement in _LATEX_SPECIAL.items():
            if text.startswith(token, index):
                out.append(replacement)
                index += len(token)
                break
        else:
            out.append(text[index])
            index += 1
    return "".join(out)


def to_latex(table: Table) -> str:
    """A booktabs table environment (needs ``\\usepackage{booktabs}``)."""
    columns = "l" + "r" * (len(table.header) - 1)
    lines = [
        r"\begin{table}[htbp]",
        r"\centering",
        rf"\caption{{{latex_escape(table.caption)}}}",
        rf"\label{{tab:{table.name}}}",
        rf"\begin{{tabular}}{{{columns}}}",
        r"\toprule",
        " & ".join(latex_escape(cell) for cell in table.header) + r" \\",
        r"\midrule",
    ]
    lines += [" & ".join(latex_escape(cell) for cell in row) + r" \\" for row in table.rows]
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"


def to_html(table: Table) -> str:
    """An HTML table for report.html."""
    head = "".join(f"<th>{html.escape(cell)}</th>" for cell in table.header)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(cell)}</td>" for cell in row) + "</tr>"
        for row in table.rows
    )
    return (
        f'<table id="{html.escape(table.name)}"><caption>{html.escape(table.caption)}</caption>'
        f"<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
    )


def write_checked(
    path: Path, frame: pd.DataFrame, spec: TableSpec, name: str | None = None
) -> None:
    """The frame as the table `spec` describes, checked first (hcss.tablespec.frames.conform).

    A frame that breaks its contract raises ContractError and writes nothing.
    """
    write_frame(path, conform(frame, spec, name))


def write_paper_table(table: Table, directory: Path) -> list[Path]:
    """Write ``name.md``, ``name.tex`` and ``name.csv`` into ``directory``.

    The CSV keeps the contract of its name (hcss.tablespec.analysis), checked
    before any of the three files is written.
    """
    frame, spec = table.frame, analysis_table(table.name)
    if frame.columns.empty:  # never a file without a header: say why there are no rows
        frame, spec = pd.DataFrame({"note": [f"no rows: {table.caption}"]}), NO_ROWS
    written = conform(frame, spec, table.name)
    directory.mkdir(parents=True, exist_ok=True)
    paths = [directory / f"{table.name}.{suffix}" for suffix in ("md", "tex", "csv")]
    paths[0].write_text(to_markdown(table), encoding="utf-8")
    paths[1].write_text(to_latex(table), encoding="utf-8")
    write_frame(paths[2], written)
    return paths
