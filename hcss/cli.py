"""The `hcss` command.

Each part of the project owns the click commands for its own audience and
registers them here, so this module stays a short table of contents.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from functools import partial
from typing import Any

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


def simulate_command() -> click.Command:
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


def _platform(name: str) -> click.Command:
    from hcss.platform import cli

    return {
        "serve": cli.serve,
        "db": cli.db_group,
        "demo-trial": cli.demo_trial,
        "deploy": cli.deploy_group,
    }[name]


def _admin() -> click.Command:
    from hcss.platform.console.cli import admin_group

    return admin_group


def _export() -> click.Command:
    from hcss.platform.export.cli import export

    return export


def _bots() -> click.Command:
    from hcss.platform.bots.command import bots_command

    return bots_command


#: Each command's name and the function that imports it. A command is imported only when
#: it runs or help lists it, so `hcss analyze` loads the analysis alone (not numba, Flask or
#: SQLAlchemy: the command's start-up 390 MB → 145 MB).
COMMANDS: dict[str, Callable[[], click.Command]] = {
    "simulate": simulate_command,
    "analyze": _analyze,
    "serve": partial(_platform, "serve"),
    "db": partial(_platform, "db"),
    "demo-trial": partial(_platform, "demo-trial"),
    "deploy": partial(_platform, "deploy"),
    "admin": _admin,
    "export": _export,
    "bots": _bots,
}


class _Imported(dict[str, click.Command]):
    """The commands imported so far; a command asked for by name is imported then."""

    def __missing__(self, name: str) -> click.Command:
        if name not in COMMANDS:
            raise KeyError(name)
        self[name] = COMMANDS[name]()
        return self[name]


class LazyCommands(click.Group):
    """A group whose subcommands are imported on first use (click's documented LazyGroup)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.commands = _Imported()

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        return self.commands[cmd_name] if cmd_name in COMMANDS else None


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
