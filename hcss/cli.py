"""The `hcss` command.

Each part of the project owns the click commands for its own audience and
registers them here, so this module stays a short table of contents.
"""

from __future__ import annotations

import os

import click

from hcss.analysis.cli import analyze
from hcss.experiments import cli as experiments_cli
from hcss.plan_cli import plan_command
from hcss.platform.bots.command import bots_command
from hcss.platform.cli import db_group, demo_trial, deploy_group, serve
from hcss.platform.console.cli import admin_group
from hcss.platform.export.cli import export
from hcss.simulation import cli as model_cli


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


#: `hcss simulate ...`: the model's command and the experiments', one command line.
simulate = ByAudience(
    "simulate",
    sources=[model_cli.simulate, experiments_cli.simulate],
    help="Run the simulation: a live demo or the simulation-only experiment.",
)

COMMANDS = (
    simulate,
    analyze,
    serve,
    db_group,
    demo_trial,
    deploy_group,
    admin_group,
    export,
    bots_command,
    plan_command,
)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
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


for command in COMMANDS:
    main.add_command(command)


if __name__ == "__main__":  # pragma: no cover
    main()
