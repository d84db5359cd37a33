"""The data dictionary, rendered from the table specs.

docs/data-dictionary.md (a link to hcss/platform/export/data-dictionary.md, which every
export carries) is this module's output, committed; tests/test_tablespec.py fails
when the two differ. After changing a spec, write it again:

    python -m hcss.tablespec.dictionary hcss/platform/export/data-dictionary.md
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

from hcss.tablespec.analysis import ANALYSIS_TABLES
from hcss.tablespec.decisions import DECISIONS
from hcss.tablespec.export import EXPORT_TABLES
from hcss.tablespec.simulation import SIMULATION_TABLES
from hcss.tablespec.spec import TableSpec

PREAMBLE = """\
# Data dictionary

<!-- Generated from hcss/tablespec by `python -m hcss.tablespec.dictionary`: edit the specs, not this file. -->

Every table is tidy and long: one row per event, one column per variable.
Tables are written as CSV (UTF-8, header row, CRLF line ends, `.` decimal
point, empty cell for a missing value) and, where pyarrow is installed, also as
Parquet with the same name (a missing value is null). Booleans are written
`true`/`false`. One writer (`hcss/tidy_csv.py`) writes every CSV table of hcss
with this rule: the study export, the simulation's decisions
(`hcss simulate experiment`), a sweep's cells and combined `decisions.csv`,
the equivalence reference, the calibration's trials and the tables of
`hcss analyze`; a missing value, `None` or a float NaN, is always an
empty cell, never `nan`. Times are seconds unless the column
name says otherwise. Collectives are named by their Roman numerals `I`–`IV`.
The `missing` column says whether a cell may be empty.

Identifiers never name a person: `participant` is the study's participant code.
"""

STUDY_EXPORT = """\
## Study export

`hcss export OUTDIR` writes the tables below beside `decisions.csv`. Every row
carries `participant` and, for anything that happens in a trial, `trial_id`,
`model` and `sim_time_s` (simulation time). `wall_time` is the server's UTC
clock in ISO 8601.
"""

SIMULATION_OUTPUTS = """\
## Simulation outputs

Tables the simulation writes besides an experiment's `decisions.csv`. A column
written `<name>` stands for several columns, named when the table is written.
"""

ANALYSIS_OUTPUTS = """\
## Analysis outputs

Tables the analysis writes (`hcss analyze`, and the summary of `hcss simulate
experiment`), each checked against its contract as it is written: a column
the contract does not name, a missing column whose `missing` is `never`, or
a cell of another type stops the write. A column whose `missing` is
`allowed` may be left out when the inputs lack it. A name written
`descriptive_<measure>` stands for one table per measure (or per family of
measures); a column written `<name>` stands for several, named when the
table is written. The report's tables are written as `tables/<name>.csv`
beside their Markdown and LaTeX.
"""

NOT_EXPORTED = """\
## Not exported: operational tables

`participant_presence` holds one row per participant, overwritten by every
heartbeat of the participant's open page (every 10 s): the time of the last
heartbeat, the kind of page (`study` or `trial`) and whether its tab was
hidden. The console shows it as connected/disconnected and "last seen". It is
operational state, not a record of behaviour: it is never exported, and a
withdrawal deletes it with the participant's other rows.
"""


def columns_table(spec: TableSpec) -> str:
    """The spec's columns as a Markdown table: name, type, missing-value rule, meaning.

    Neighbouring columns alike in all three (the demographics answers, say) share a row.
    """
    lines = ["| column | type | missing | meaning |", "|---|---|---|---|"]
    for (dtype, nullable, description), group in itertools.groupby(
        spec.columns, key=lambda column: (column.dtype, column.nullable, column.description)
    ):
        names = ", ".join(column.name.replace("<", "&lt;").replace(">", "&gt;") for column in group)
        missing = "allowed" if nullable else "never"
        lines.append(f"| {names} | {dtype} | {missing} | {description} |")
    return "\n".join(lines) + "\n"


def section(spec: TableSpec, level: str) -> str:
    prose = f"{spec.description}\n\n" if spec.description else ""
    return f"{level} {spec.title}\n\n{prose}{columns_table(spec)}"


def render() -> str:
    """The whole dictionary, as committed and as every export carries it."""
    parts = [PREAMBLE, section(DECISIONS, "##"), STUDY_EXPORT]
    parts += [section(spec, "###") for spec in EXPORT_TABLES.values() if spec is not DECISIONS]
    parts += [SIMULATION_OUTPUTS]
    parts += [section(spec, "###") for spec in SIMULATION_TABLES]
    parts += [ANALYSIS_OUTPUTS]
    parts += [section(spec, "###") for spec in ANALYSIS_TABLES]
    parts += [NOT_EXPORTED]
    return "\n".join(parts)


def main(argv: list[str]) -> int:
    """Write the dictionary to the path given, or print it."""
    text = render()
    if argv:
        Path(argv[0]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
