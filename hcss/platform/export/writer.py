"""Write the export directory: every table as CSV (and Parquet), plus the dictionary.

Everything is written to a fresh directory next to OUTDIR and renamed into
place at the end, so a failed export leaves no half-written tables behind.
Training trials are practice: their trial tables go to ``training/`` with the
same columns, kept but out of the analysis's way.
"""

from __future__ import annotations

import shutil
import tempfile
from collections import defaultdict
from importlib import resources
from pathlib import Path
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.export.problems import ProblemLog
from hcss.platform.export.recruitment_rows import (
    recruitment_rows,
    return_visit_rows,
    screen_out_rows,
)
from hcss.platform.export.rows import TRIAL_ROW_BUILDERS, interruption_rows
from hcss.platform.export.selection import participants_of
from hcss.platform.export.study_rows import participant_rows, study_flow_rows
from hcss.platform.export.tables import PROBLEMS_TABLE, TABLES, TRIAL_TABLES, columns
from hcss.platform.models import Participant, Trial
from hcss.tidy_csv import is_missing, write_rows

#: The data dictionary, package data (docs/data-dictionary.md links to it).
DICTIONARY = resources.files("hcss.platform.export") / "data-dictionary.md"
TRAINING_DIR = "training"

EXPORT_NOTES = """

## Notes on this export

- `observations` holds the study's observation actions: a click that filled
  the request form of a committed request is part of that request, not an
  observation.
- Training trials are practice and are not analysed. Their `decisions`,
  `requests`, `observations` and `probes` are in `training/`, with the same
  columns as the tables above.
- `status` is `aborted` when the experimenter aborted the session.
"""


class ExportError(ValueError):
    """An export that cannot be written where asked; nothing was written."""


def collect(session: Session, study: str | None = None) -> dict[str, list[dict[str, Any]]]:
    """Every table's rows, keyed by file name relative to the export directory.

    With `study`, only that study's participants, their trials, and the
    study link's recruitment and screen-out rows (UnknownStudy when the study
    has no participant). Total: a record that cannot be read is skipped and
    listed in `export_problems` (see `hcss.platform.export.problems`), so one
    bad row never stops the export of any other.
    """
    problems = ProblemLog()
    participants = participants_of(session, study)
    codes = {p.id: p.code for p in participants}
    tables: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for table, rows in _participant_tables(session, participants, problems).items():
        tables[table].extend(rows)
    in_study = (lambda row: True) if study is None else (lambda row: row["study"] == study)
    with problems.guard("recruitment", "recruitment table"):
        tables["recruitment"] = [r for r in recruitment_rows(session) if in_study(r)]
    with problems.guard("return_visits", "return_visits table"):
        tables["return_visits"] = [r for r in return_visit_rows(session) if in_study(r)]
    with problems.guard("screen_outs", "screen_outs table"):
        tables["screen_outs"] = [r for r in screen_out_rows(session) if in_study(r)]
    trials = select(Trial).order_by(Trial.id)
    if study is not None:
        trials = trials.where(Trial.participant_id.in_(list(codes)))
    for trial in session.scalars(trials):
        prefix = f"{TRAINING_DIR}/" if trial.kind == "training" else ""
        code = codes.get(trial.participant_id, "")
        for table, build in TRIAL_ROW_BUILDERS.items():
            with problems.guard(table, f"trial {trial.id}", participant=code, trial_id=trial.id):
                tables[prefix + table].extend(build(session, trial, code, problems))
        with problems.guard(
            "interruptions", f"trial {trial.id}", participant=code, trial_id=trial.id
        ):
            tables["interruptions"].extend(interruption_rows(session, trial, code, problems))
    for name in list(tables):
        table = name.rsplit("/", 1)[-1]
        tables[name] = problems.typed(table, TABLES[table], tables[name])
    tables[PROBLEMS_TABLE] = problems.rows
    for table in (*TABLES, *(f"{TRAINING_DIR}/{t}" for t in TRIAL_TABLES)):
        tables.setdefault(table, [])
    return dict(tables)


def _participant_tables(
    session: Session, participants: list[Participant], problems: ProblemLog
) -> dict[str, list[dict[str, Any]]]:
    """The per-participant tables in one pass; participant by participant if that fails."""
    try:
        return {
            "participants": participant_rows(session, participants),
            **study_flow_rows(session, participants),
        }
    except Exception:  # noqa: BLE001 - find the participant whose records cannot be read
        tables: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for participant in participants:
            with problems.guard(
                "participants", f"participant {participant.id}", participant=participant.code
            ):
                one = {
                    "participants": participant_rows(session, [participant]),
                    **study_flow_rows(session, [participant]),
                }
                for table, rows in one.items():
                    tables[table].extend(rows)
        return tables


def write_csv(path: Path, table: str, rows: list[dict[str, Any]]) -> None:
    write_rows(path, columns(table), rows)


def write_parquet(path: Path, table: str, rows: list[dict[str, Any]]) -> bool:
    """Parquet with the dictionary's types; skipped (False) without pyarrow."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        return False
    types = {"str": pa.string(), "int": pa.int64(), "float": pa.float64(), "bool": pa.bool_()}
    schema = pa.schema([(name, types[kind]) for name, kind in TABLES[table]])
    cleaned = [
        {name: None if is_missing(row.get(name)) else row[name] for name in schema.names}
        for row in rows
    ]
    pq.write_table(pa.Table.from_pylist(cleaned, schema=schema), path)
    return True


def write_export(
    session: Session, outdir: Path, *, replace: bool = False, study: str | None = None
) -> dict[str, int]:
    """Write every table (or one study's rows of each) into OUTDIR; the row count of each file."""
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise ExportError(f"{outdir} exists and is not a directory")
    if outdir.is_dir() and any(outdir.iterdir()) and not replace:
        raise ExportError(f"{outdir} is not empty; choose a new directory or pass --replace")
    tables = collect(session, study)
    outdir.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{outdir.name}-", dir=outdir.parent))
    try:
        (staging / TRAINING_DIR).mkdir()
        for name, rows in tables.items():
            table = name.rsplit("/", 1)[-1]
            write_csv(staging / f"{name}.csv", table, rows)
            write_parquet(staging / f"{name}.parquet", table, rows)
        dictionary = DICTIONARY.read_text(encoding="utf-8").rstrip("\n") + EXPORT_NOTES
        (staging / "data-dictionary.md").write_text(dictionary, encoding="utf-8")
        if outdir.exists():
            shutil.rmtree(outdir)
        staging.rename(outdir)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return {name: len(rows) for name, rows in tables.items()}
