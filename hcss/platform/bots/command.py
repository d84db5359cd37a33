"""`hcss bots`: participant bots in process, or against a running server over HTTP."""

from __future__ import annotations

import click
from tqdm import tqdm

from hcss.platform.bots.http_load import run_http_bots
from hcss.platform.bots.participant import bot_app, run_bots
from hcss.platform.cli import upgrade_database
from hcss.platform.config import database_url as default_url
from hcss.platform.study.studyfile import StudyFileError, load_study


@click.command("bots")
@click.option("--n", "count", default=8, show_default=True, type=click.IntRange(min=1))
@click.option(
    "--study", default="original", show_default=True, help="Study name (see hcss --studies)."
)
@click.option("--seed", default=0, show_default=True, type=int, help="First bot's seed.")
@click.option("--database-url", default=None, help="Default: DATABASE_URL, else instance/.")
@click.option(
    "--base-url",
    default=None,
    help="Drive this running server over HTTP (e.g. http://127.0.0.1:5000) instead of "
    "an in-process app. Start it with the same study and a time acceleration: "
    "HCSS_STUDY=demo hcss serve --time-acceleration 20.",
)
@click.option(
    "--concurrency",
    default=1,
    show_default=True,
    type=click.IntRange(min=1, max=256),
    help="Bots walking at once (with --base-url).",
)
def bots_command(
    count: int,
    study: str,
    seed: int,
    database_url: str | None,
    base_url: str | None,
    concurrency: int,
) -> None:
    """Walk N participant bots through the whole study, filling a pilot database.

    Bots are flagged is_bot and balanced apart from real participants. In
    process, their trials run on a clock the bots move, so a full protocol
    takes seconds; with --base-url they drive a real server over HTTP,
    CONCURRENCY at a time, and the command reports errors and page latencies
    (the load tool; `make bench` uses it).
    """
    url = database_url or default_url()
    try:
        load_study(study)
    except StudyFileError as error:
        raise click.BadParameter(str(error), param_hint="--study") from error
    upgrade_database(url)
    if base_url is not None:
        with tqdm(total=count, unit="bot") as bar:
            figures = run_http_bots(
                base_url, url, study, count, concurrency=concurrency, seed=seed, progress=bar.update
            )
        for failure in figures.errors:
            click.echo(f"failed: {failure}", err=True)
        click.echo(figures.summary())
        if figures.errors:
            raise SystemExit(1)
        return
    app = bot_app(url, study)
    try:
        with tqdm(total=count, unit="bot") as bar:
            reports = run_bots(app, count, seed=seed, progress=lambda _report: bar.update())
    finally:
        app.extensions["hcss_db"].engine.dispose()
    for report in reports:
        click.echo(
            f"{report.code}: {report.pages} pages, {len(report.trials)} trials, "
            f"{report.accepted}/{report.requests} requests accepted, "
            f"{report.probes_answered} probes answered"
        )
