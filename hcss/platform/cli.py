"""`hcss serve`, `hcss db upgrade` and `hcss demo-trial`."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from hcss.platform.serving.connections import PER_CLIENT
from hcss.simulation.params import MODELS

if TYPE_CHECKING:
    from flask import Flask

    from hcss.platform.live.warmup import Warmup

#: The Alembic environment, package data (Alembic's "package:directory" form).
MIGRATIONS = "hcss.platform:migrations"
DEFAULT_PORT = 5000
#: Waitress threads `hcss serve` starts with: 200 concurrent trials' streams and a reserve for pages.
DEFAULT_THREADS = 256


def alembic_config(database_url: str | None = None):
    """The Alembic configuration of the migrations shipped in the package."""
    from alembic.config import Config

    from hcss.platform.config import database_url as default_url

    config = Config()
    config.set_main_option("script_location", MIGRATIONS)
    # '%' is interpolation syntax in Alembic's config parser.
    config.set_main_option("sqlalchemy.url", (database_url or default_url()).replace("%", "%%"))
    return config


def upgrade_database(database_url: str | None = None, revision: str = "head") -> None:
    from alembic import command

    command.upgrade(alembic_config(database_url), revision)


@click.group("db")
def db_group() -> None:
    """Create or migrate the database (SQLite in instance/, or DATABASE_URL)."""


@db_group.command("upgrade")
@click.option("--revision", default="head", show_default=True)
def db_upgrade(revision: str) -> None:
    """Apply every Alembic migration up to REVISION."""
    from hcss.platform.config import database_url

    upgrade_database(revision=revision)
    click.echo(f"database at {_redacted(database_url())} is at revision {revision}")


def _redacted(url: str) -> str:
    from sqlalchemy.engine import make_url

    return make_url(url).render_as_string(hide_password=True)


@click.command("serve")
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", default=DEFAULT_PORT, show_default=True, type=click.IntRange(1, 65535))
@click.option(
    "--study",
    default=None,
    envvar="HCSS_STUDY",
    help="Study (NAME.toml in --studies DIR or bundled) for new participants; default: original.",
)
@click.option(
    "--threads",
    default=DEFAULT_THREADS,
    show_default=True,
    type=int,
    help="Waitress worker threads; each open trial page holds one for its stream, "
    "and an eighth (at least 16) are kept for page loads and the console.",
)
@click.option(
    "--time-acceleration",
    type=float,
    default=None,
    help="Trial seconds per wall second for trials started by this server (tests, bots).",
)
@click.option(
    "--connections-per-client",
    default=PER_CLIENT,
    show_default=True,
    envvar="HCSS_CONNECTIONS_PER_CLIENT",
    type=click.IntRange(0),
    help="Open connections one address may hold (0: no cap); behind HCSS_PROXY_HOPS, "
    "requests in progress per forwarded address.",
)
@click.option(
    "--processes",
    default=1,
    show_default=True,
    type=click.IntRange(1, 64),
    help="Server processes on ports PORT, PORT+1, ... sharing the (PostgreSQL) database; "
    "put nginx in front (`hcss deploy nginx`).",
)
@click.option(
    "--cluster",
    is_flag=True,
    help="This process is one of several on one PostgreSQL database (on this or other "
    "hosts): it hosts live trials by lease. --processes sets it for its workers.",
)
def serve(
    host: str,
    port: int,
    study: str | None,
    threads: int,
    time_acceleration: float | None,
    connections_per_client: int,
    processes: int,
    cluster: bool,
) -> None:
    """Serve the study platform with waitress; one line per participant event on stderr."""
    from hcss.platform.app import create_app
    from hcss.platform.config import database_url
    from hcss.platform.console.accounts import ensure_first_login
    from hcss.platform.live.stream_slots import reserve_for_pages
    from hcss.platform.serving.announce import log_events_to_stderr, write_serving_file
    from hcss.platform.serving.connections import (
        RequestsPerClient,
        bounded_server,
        proxy_adjustments,
        say_untrusted_headers_once,
        serve_until_stopped,
    )
    from hcss.platform.serving.workers import (
        GroupRefused,
        hold_studies,
        process_name,
        require_shared_database,
        run_group,
    )

    if processes > 1 or cluster:
        try:
            require_shared_database(database_url())
        except GroupRefused as refused:
            raise click.UsageError(str(refused)) from refused
    if processes > 1:
        ensure_first_login(create_app({}))  # once, before the workers race to it
        worker_args = ["--threads", str(threads)]
        worker_args += ["--connections-per-client", str(connections_per_client)]
        if study is not None:
            worker_args += ["--study", study]
        if time_acceleration is not None:
            worker_args += ["--time-acceleration", str(time_acceleration)]
        click.echo(f"hcss: {processes} server processes on ports {port}-{port + processes - 1}")
        raise SystemExit(run_group(processes, host, port, worker_args))

    # Streams hold a thread each; the reserve keeps page loads and the console answering.
    config: dict[str, object] = {
        "MAX_STREAMS": threads - reserve_for_pages(threads),
        "LIVE_RUNNER": True,  # only a serving process keeps trials on time
    }
    if cluster:
        config["PROCESS_NAME"] = process_name(host, port)
        try:  # every process of a group serves the same study files
            hold_studies(database_url(), str(config["PROCESS_NAME"]))
        except GroupRefused as refused:
            raise click.UsageError(str(refused)) from refused
    if time_acceleration is not None:
        config["TIME_ACCELERATION"] = time_acceleration
    if study is not None:
        config["STUDY"] = _study_file(study).name
    app = create_app(config)
    _warn_if_the_database_takes_no_writes(app)
    from hcss.platform.live.warmup import Warmup

    # Compile the simulation's kernels now, not in the first participant's trial, but
    # while serving: pages that need no simulation answer meanwhile, trials wait for it.
    warmup = Warmup(_warm_up)
    warmup.install(app)
    warmup.start(_say_warm)
    click.echo(
        "hcss: preparing the simulation in the background (numba compiles its kernels "
        "after an install or upgrade: a minute or more; from its cache: seconds); "
        "pages are served meanwhile, trials start once it is ready"
    )
    ensure_first_login(app)  # prints a console login once, on a server with no experimenter
    _warn_about_study_files(app)
    url = f"http://{host}:{port}/"
    log_events_to_stderr()
    # A server on every interface is reached from this machine at 127.0.0.1.
    local = host if host not in ("0.0.0.0", "::", "") else "127.0.0.1"
    write_serving_file(f"http://{local}:{port}", study or "original")
    click.echo(
        f"hcss serving on {url}  (Ctrl-C stops); new participants: study {study or 'original'}"
    )
    click.echo(f"console: {url}console/   a demo trial:  hcss demo-trial --port {port}")
    hops = int(app.config.get("PROXY_HOPS") or 0)
    proxied = hops > 0
    say_untrusted_headers_once()
    ipv4_bits = int(app.config["CLIENT_PREFIX_V4"])
    served: Any = app
    if proxied and connections_per_client:  # the cap by the forwarded address, per request
        served = RequestsPerClient(app, connections_per_client, ipv4_bits)
    server = bounded_server(
        served,
        host=host,
        port=port,
        threads=threads,
        ident="hcss",
        max_request_body_size=int(app.config["MAX_CONTENT_LENGTH"]),
        # Every thread's stream plus as many short requests, and room for idle and
        # slow connections, which cost no thread (hcss.platform.serving.connections bounds
        # them); poll, not select, which stops at descriptor 1024.
        connection_limit=2 * threads + 1024,
        asyncore_use_poll=True,
        # Behind the proxy every connection is the proxy's: clients are capped above.
        per_client=0 if proxied else connections_per_client,
        ipv4_bits=ipv4_bits,
        # Waitress passes X-Forwarded-* on only from the proxy it is told of.
        **proxy_adjustments(hops, str(app.config["TRUSTED_PROXY"])),
    )
    # Ctrl-C and SIGTERM end the streams and wait for their threads before the
    # server's wake-up pipe closes (hcss.platform.serving.connections.close_server).
    if not serve_until_stopped(server):
        click.echo("hcss: stopped with requests still running", err=True)
    click.echo("hcss: stopped", err=True)


def _warm_up() -> None:
    """The simulation's kernels, then the MRT figures, before the first participants need them."""
    from hcss.platform.live.warmup import warm_simulation
    from hcss.questionnaires.mrt import item_bank, practice_items

    warm_simulation()
    for item in (*practice_items(), *item_bank()):
        item.target_svg()


def _say_warm(warmup: Warmup) -> None:
    if warmup.error is not None:
        click.echo(
            f"hcss: preparing the simulation failed ({warmup.error!r}); "
            "each trial compiles what it needs when it starts",
            err=True,
        )
        return
    click.echo(f"hcss: simulation ready ({warmup.seconds:.1f} s); trials can start")


@click.group("deploy")
def deploy_group() -> None:
    """Configuration for running the platform behind a reverse proxy."""


@deploy_group.command("nginx")
@click.option(
    "--server",
    "servers",
    multiple=True,
    metavar="HOST:PORT",
    help="An hcss process (repeat for each; on several hosts too). "
    "Default: --processes ports from --port on --host.",
)
@click.option("--host", default="127.0.0.1", show_default=True)
@click.option("--port", default=DEFAULT_PORT, show_default=True, type=click.IntRange(1, 65535))
@click.option("--processes", default=2, show_default=True, type=click.IntRange(1, 64))
@click.option("--listen", default="8080", show_default=True, help="nginx's listen address.")
@click.option(
    "--standalone",
    type=click.Path(file_okay=False),
    default=None,
    help="Write a whole nginx.conf that runs unprivileged with its files in this folder "
    "(nginx -p DIR -c nginx.conf); default: the http-level part for /etc/nginx/conf.d/.",
)
@click.option("--output", "-o", type=click.Path(dir_okay=False), default=None)
def deploy_nginx(
    servers: tuple[str, ...],
    host: str,
    port: int,
    processes: int,
    listen: str,
    standalone: str | None,
    output: str | None,
) -> None:
    """Write the nginx configuration that routes each participant to one hcss process."""
    from pathlib import Path

    from hcss.platform.serving.nginx import site_config, standalone_config

    members = list(servers) or [f"{host}:{port + index}" for index in range(processes)]
    if standalone is None:
        text = site_config(members, listen=listen)
    else:
        prefix = Path(standalone).resolve()
        for folder in ("body", "proxy", "fastcgi", "uwsgi", "scgi"):
            (prefix / "temp" / folder).mkdir(parents=True, exist_ok=True)
        text = standalone_config(members, listen=listen, prefix=prefix)
    if output is None:
        click.echo(text, nl=False)
    else:
        Path(output).write_text(text)
        click.echo(f"nginx configuration for {len(members)} process(es) in {output}", err=True)


def _warn_if_the_database_takes_no_writes(app: Flask) -> None:
    """Say at start, loudly, that the database refuses writes (read-only, full, unreachable).

    The server starts all the same: its pool uses the database as soon as it
    takes writes again, and meanwhile participants get a "please wait" page
    (503) and live trials stand still, losing nothing. Exiting instead would
    leave the lab without a server over a fault that may last seconds (a
    remount, a failover), and without the pages that tell participants to wait.
    """
    from sqlalchemy import make_url

    database = app.extensions["hcss_db"]
    refusal = database.write_refusal()
    if refusal is None:
        return
    where = make_url(database.url).render_as_string(hide_password=True)
    click.echo(
        f"hcss: WARNING: the database takes no writes ({refusal}): {where}\n"
        "hcss: WARNING: participants get a 'please wait' page and live trials stand still "
        "until it does; make it writable (file permissions, free space, a PostgreSQL "
        "primary rather than a standby) and the server uses it without a restart.",
        err=True,
    )


def _warn_about_study_files(app: Flask) -> None:
    """Say at start which study files cannot be loaded or changed under enrolled participants."""
    from sqlalchemy.exc import SQLAlchemyError

    from hcss.platform.study.versions import study_problems

    try:
        with app.extensions["hcss_db"].session_scope() as session:
            problems = study_problems(session)
    except SQLAlchemyError:
        return  # the database is not ready; the runner says so
    for problem in problems:
        click.echo(f"hcss: warning: {problem}", err=True)


@click.command("demo-trial")
@click.option(
    "--port",
    type=click.IntRange(1, 65535),
    default=None,
    help="The server's port; default: the port `hcss serve` (make run) last started on.",
)
@click.option("--base-url", default=None, help="The server's address (overrides --port).")
@click.option(
    "--study",
    default=None,
    envvar="HCSS_STUDY",
    help="The study whose trial length is used; default: the study of the server on --port "
    "(or of the last one started).",
)
@click.option("--model", type=click.Choice(MODELS), default="M1", show_default=True)
@click.option("--training", is_flag=True, help="A training trial (two collectives).")
@click.option("--seed", type=int, default=None, help="Scenario seed (random when omitted).")
@click.option("--minutes", type=float, default=None, help="Trial length (default: the study's).")
def demo_trial(
    port: int | None,
    base_url: str | None,
    study: str | None,
    model: str,
    training: bool,
    seed: int | None,
    minutes: float | None,
) -> None:
    """Create a demo participant with a live, recorded trial and print its link.

    The trial's clock starts now and runs on the server (`hcss serve`), whether
    or not the page is open. Its data are flagged demo. The link points at the
    server `make run` started (its port and study), unless told otherwise.
    """
    from hcss.platform.config import database_url
    from hcss.platform.db import Database
    from hcss.platform.live.trials import start_trial
    from hcss.platform.models import Participant
    from hcss.platform.serving.announce import read_serving_file

    serving = read_serving_file(port)  # the server on --port, else the last one started
    if base_url is None:
        base_url = (
            f"http://127.0.0.1:{port}"
            if port is not None
            else serving.get("url", f"http://127.0.0.1:{DEFAULT_PORT}")
        )
    study_file = _study_file(study or serving.get("study") or "original")
    length_s = study_file.timing.training_s if training else study_file.timing.trial_s
    database = Database(database_url())
    with database.command_scope() as session:
        participant = Participant(is_demo=True, study=study_file.name)
        session.add(participant)
        session.flush()
        trial = start_trial(
            session,
            participant,
            kind="training" if training else "trial",
            model=model,
            seed=seed,
            duration_s=length_s if minutes is None else minutes * 60.0,
            time_acceleration=float(os.environ.get("HCSS_TIME_ACCELERATION", "1.0")),
            probe_counts=study_file.probes.per_level,
            preset=study_file.simulation.preset,
        )
        link = f"{base_url.rstrip('/')}/live/{participant.token}"
        click.echo(
            f"demo participant {participant.code}, {trial.kind} {trial.id} ({model}, "
            f"{trial.duration_s / 60:g} min, study {study_file.name})"
        )
    click.echo(link)


@click.group("study")
def study_group() -> None:
    """Study files: check one before serving it."""


@study_group.command("check")
@click.argument("file", type=click.Path(dir_okay=False, path_type=Path))
def study_check(file: Path) -> None:
    """Check the study file FILE as the server reads it: one line per problem
    (FILE:LINE: the setting, and the known ones for a misspelt key); exit 1 if any."""
    from hcss.platform.study.check import study_file_problems

    study, problems = study_file_problems(file)
    for problem in problems:
        click.echo(problem)
    if study is None:
        raise SystemExit(1)
    click.echo(
        f"{file}: ok (study {study.name}, {len(study.cells)} counterbalancing cells, "
        f"digest {study.digest[:12]}…)"
    )


def _study_file(name: str):
    from hcss.platform.study.studyfile import StudyFileError, load_study

    try:
        return load_study(name)
    except StudyFileError as error:
        raise click.BadParameter(str(error), param_hint="--study / STUDY") from error
