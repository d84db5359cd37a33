"""The `hcss` command.

Each part of the project owns the click commands for its own audience and
registers them here, so this module stays a short table of contents.
"""

from __future__ import annotations

import importlib
import os

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


#: Each command, by name, as ``module:attribute`` (a callable making it when the attribute
#: is a function ending in ``_command`` of this module). A command's module is imported
#: only when that command runs (or `--help` lists them): importing them all (numba,
#: pandas, scipy, SQLAlchemy's models) made `hcss --version` take 9.5 s under load.
COMMANDS = {
    "simulate": "hcss.cli:simulate_command",
    "analyze": "hcss.analysis.cli:analyze",
    "serve": "hcss.platform.cli:serve",
    "db": "hcss.platform.cli:db_group",
    "demo-trial": "hcss.platform.cli:demo_trial",
    "deploy": "hcss.platform.cli:deploy_group",
    "admin": "hcss.platform.console.cli:admin_group",
    "export": "hcss.platform.export.cli:export",
    "bots": "hcss.platform.bots.command:bots_command",
}


class LazyCommands(click.Group):
    """A group whose commands are imported when asked for (click's documented pattern)."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return sorted({*super().list_commands(ctx), *COMMANDS})

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in COMMANDS:
            return super().get_command(ctx, cmd_name)
        module, _, attribute = COMMANDS[cmd_name].partition(":")
        found = getattr(importlib.import_module(module), attribute)
        command = found() if attribute.endswith("_command") and module == __name__ else found
        if not isinstance(command, click.Command) or command.name != cmd_name:
            raise RuntimeError(f"{COMMANDS[cmd_name]} is not the command {cmd_name!r}")
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
