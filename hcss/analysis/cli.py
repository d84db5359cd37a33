"""`hcss analyze`: the analyst's command, from exports to a report directory."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, cast

import click

from hcss.analysis.load import AnalysisInputError, load_inputs

if TYPE_CHECKING:  # stats imports scipy; the command checks its inputs before that
    from hcss.analysis.stats import MannWhitneyMethod


@click.command("analyze")
@click.argument(
    "inputs",
    metavar="INPUT...",
    nargs=-1,
    required=True,
    type=click.Path(exists=True, path_type=Path),
)
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(file_okay=False, path_type=Path),
    help="Report directory to write tables/, figures/ and report.html into.",
)
@click.option(
    "--include-pilot",
    is_flag=True,
    help="Keep bot, pilot and demo participants (excluded by default).",
)
@click.option(
    "--mw-method",
    type=click.Choice(["auto", "exact", "asymptotic"]),
    default="auto",
    show_default=True,
    help="Mann-Whitney p: auto is R's wilcox.test rule (exact below 50 per group without ties).",
)
@click.option(
    "--continuity/--no-continuity",
    default=True,
    show_default=True,
    help="Continuity correction for the asymptotic Mann-Whitney p.",
)
@click.option(
    "--study",
    default=None,
    help="Analyse only this study's participants (its file's name, e.g. original).",
)
@click.option(
    "--pool-studies",
    is_flag=True,
    help="Analyse participants of different study files together (refused by default).",
)
@click.option(
    "--pool-synthetic",
    is_flag=True,
    help="Analyse synthetic participants (`hcss plan`) together with real ones (refused by default).",
)
@click.option(
    "--completers-only",
    is_flag=True,
    help="Analyse only participants who completed (default: the partial trials of those "
    "who stopped or are in progress count too, and the report says how many).",
)
@click.option(
    "--drop-exact-duplicates",
    is_flag=True,
    help="Drop decision rows identical in every column to one read before (counted); "
    "by default a decision given twice is refused.",
)
@click.option("--quiet", is_flag=True, help="No progress bar.")
def analyze(
    inputs: tuple[Path, ...],
    out: Path,
    include_pilot: bool,
    mw_method: str,
    continuity: bool,
    study: str | None,
    pool_studies: bool,
    pool_synthetic: bool,
    completers_only: bool,
    drop_exact_duplicates: bool,
    quiet: bool,
) -> None:
    """Analyse study exports and simulation decision tables.

    Each INPUT is the console's export zip as downloaded, an export
    directory (decisions and, for a study, the other export tables, as CSV
    or Parquet), or a decisions CSV or Parquet file from the simulation-only
    experiment. Writes tables, figures and report.html; an INPUT left with no
    rows after exclusions is named in a warning. Participants of different
    study files (a demo beside the protocol) are refused unless --study picks
    one or --pool-studies is given; the report names each study file it used.
    Every input check runs before the statistics libraries are imported, so a
    refused input is refused in seconds.
    """
    from hcss.analysis.sweeps import SweepInputError, analyse_sweep, is_sweep

    if any(is_sweep(path) for path in inputs):  # `hcss simulate sweep` output
        if len(inputs) != 1:
            raise click.ClickException("analyse one sweep directory at a time")
        try:
            swept = analyse_sweep(inputs[0], out)
        except SweepInputError as error:
            raise click.ClickException(str(error)) from error
        click.echo(
            f"Wrote {len(swept.tables)} tables and {len(swept.figures)} heat map figures to {out}"
        )
        return

    try:
        tables = load_inputs(
            list(inputs),
            include_pilot=include_pilot,
            study=study,
            pool_studies=pool_studies,
            pool_synthetic=pool_synthetic,
            completers_only=completers_only,
            drop_exact_duplicates=drop_exact_duplicates,
        )
        # Imported only now: the analysis pulls in scipy, statsmodels and matplotlib.
        from hcss.analysis.report import analyse_tables

        report = analyse_tables(
            tables,
            out,
            include_pilot=include_pilot,
            progress=not quiet,
            mann_whitney_method=cast("MannWhitneyMethod", mw_method),  # a click.Choice of them
            continuity=continuity,
        )
    except AnalysisInputError as error:
        raise click.ClickException(str(error)) from error
    for warning in report.warnings:
        click.echo(f"Warning: {warning}", err=True)
    click.echo(
        f"Wrote {len(report.tables)} tables and {len(report.figures)} figures; "
        f"open {report.html_path}"
    )
