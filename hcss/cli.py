"""The `hcss` command.

Each part of the project owns the click commands for its own audience and
registers them here, so this module stays a short table of contents.
"""

from __future__ import annotations

import os

import click

from hcss.analysis.cli import analyze
from hcss.experiments.cli import simulate
from hcss.platform.bot_command import bots_command
from hcss.platform.cli import db_group, demo_trial, deploy_group, serve
from hcss.platform.console.cli import admin_group
from hcss.platform.export.cli import export

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
