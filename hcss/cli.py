"""The `hcss` command.

Each part of the project owns the click commands for its own audience and
registers them here, so this module stays a short table of contents.
"""

from __future__ import annotations

import os
from collections.abc import Callable

import click


class ByAudience(click.CommandCollection):
    """One command whose subcommands come from several groups, each group's listed
    under its own heading (its help up to the colon) in `--help`."""

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        groups = [source for source in self.sources if isinstance(source, click.Group)]
        limit = formatter.width - 6 - max(len(name) for group in groups for name in group.commands)
        for group in groups:
            rows = [
                (name, command.get_short_help_str(limit))
                for name, command in sorted(group.commands.items())
            ]
            with formatter.section((group.help or "").partition(":")[0]):
                formatter.write_dl(rows)


def _simulate() -> click.Command:
    """`hcss simulate ...`: the model's command and the experiments', one command line."""
    from hcss.experiments import cli as experiments_cli
    from hcss.simulation import cli as model_cli

    return ByAudience(
        "simulate",
        sources=[model_cli.simulate, experiments_cli.simulate],
        help="Run the simulation: a live demo or the simulation-only experiment.",
    )


def _analyze() -> click.Command:
    from hcss.analysis.cli import analyze

    return analyze


def _serve() -> click.Command:
    from hcss.platform.cli import serve

    return serve


def _db() -> click.Command:
    from hcss.platform.cli import db_group

    return db_group


def _demo_trial() -> click.Command:
    from hcss.platform.cli import demo_trial

    return demo_trial


def _deploy() -> click.Command:
    from hcss.platform.cli import deploy_group

    return deploy_group


def _study() -> click.Command:
    from hcss.platform.cli import study_group

    return study_group


def _admin() -> click.Command:
    from hcss.platform.console.cli import admin_group

    return admin_group


def _export() -> click.Command:
    from hcss.platform.export.cli import export

    return export


def _bots() -> click.Command:
    from hcss.platform.bots.command import bots_command

    return bots_command


def _plan() -> click.Command:
    from hcss.plan_cli import plan_command

    return plan_command


#: Each command by name, and the function that imports it. A command's module is imported
#: only when that command runs (or `--help` lists them): importing them all (numba,
#: pandas, scipy, SQLAlchemy's models) made `hcss --version` take 9.5 s under load.
COMMANDS: dict[str, Callable[[], click.Command]] = {
    "simulate": _simulate,
    "analyze": _analyze,
    "serve": _serve,
    "db": _db,
    "demo-trial": _demo_trial,
    "deploy": _deploy,
    "study": _study,
    "admin": _admin,
    "export": _export,
    "bots": _bots,
    "plan": _plan,
}


class LazyCommands(click.Group):
    """A group whose commands are imported when asked for (click's documented pattern)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *COMMANDS})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return super().get_command(ctx, cmd_name)
        command = COMMANDS[cmd_name]()
        if command.name != cmd_name:
            raise RuntimeError(f"{cmd_name!r} loaded the command {command.name!r}")
        return command


@click.group(cls=LazyCommands, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="hcss")
@click.option(
    "--studies",
    envvar="HCSS_STUDIES",
    type=click.Path(exists=True, file_okay=False),
    help="Directory of your own study files (NAME.toml), searched before the bundled "
    "ones [env: HCSS_STUDIES].",
)
def main(studies: str | None) -> None:
    """Run, serve and analyse the human-collective site-selection study."""
    if studies:
        # The environment, not a global: `hcss serve` and the bots' servers inherit it.
        os.environ["HCSS_STUDIES"] = os.path.abspath(studies)


if __name__ == "__main__":  # pragma: no cover
    main()
