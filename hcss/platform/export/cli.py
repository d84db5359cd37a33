"""`hcss export OUTDIR`: the study's tidy tables for the analysis."""

from __future__ import annotations

from pathlib import Path

import click


@click.command("export")
@click.argument("outdir", type=click.Path(file_okay=False, path_type=Path))
@click.option("--replace", is_flag=True, help="Overwrite OUTDIR if it already holds files.")
@click.option(
    "--database-url",
    default=None,
    help="Database to export (default: DATABASE_URL, else instance/).",
)
@click.option(
    "--study",
    default=None,
    help="Only this study's participants (the study file's name, e.g. original); default: all.",
)
def export(outdir: Path, replace: bool, database_url: str | None, study: str | None) -> None:
    """Write every table (CSV, and Parquet with pyarrow) and the data dictionary to OUTDIR.

    Participants appear by code only. Pilot, bot and demo participants are
    flagged in participants.csv; `hcss analyze` leaves them out unless asked.
    participants.csv names each participant's study and its file's digest;
    `hcss analyze` refuses to pool different study files unless asked.
    """

    from hcss.platform.config import database_url as default_url
    from hcss.platform.db import Database
    from hcss.platform.export.selection import UnknownStudy
    from hcss.platform.export.writer import ExportError, write_export
    from hcss.platform.models import AuditRecord

    database = Database(database_url or default_url())
    try:
        with database.command_scope() as session:
            counts = write_export(session, outdir, replace=replace, study=study)
            session.add(
                AuditRecord(
                    action="export", experimenter="cli", participant_code=None, row_counts=counts
                )
            )
    except (ExportError, UnknownStudy) as error:
        raise click.ClickException(str(error)) from error
    participants = counts.get("participants", 0)
    decisions = counts.get("decisions", 0)
    which = f" of study {study}" if study else ""
    click.echo(f"exported {participants} participants{which}, {decisions} decisions to {outdir}")
    problems = counts.get("export_problems", 0)
    if problems:
        click.echo(
            f"warning: {problems} record(s) could not be read and were skipped; "
            f"see {outdir / 'export_problems.csv'}",
            err=True,
        )
