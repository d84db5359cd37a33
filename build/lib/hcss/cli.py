"""The `hcss` command.

Each part of the project owns the click commands for its own audience and
registers them here, so this module stays a short table of contents.
"""

from __future__ import annotations

import importlib
import os

import click

# (module, attribute) pairs: each attribute is a click command or group.
COMMANDS: list[tuple[str, str]] = [
    ("hcss.simulation.cli", "simulate"),
    ("hcss.analysis.cli", "analyze"),
    ("hcss.platform.cli", "serve"),
    ("hcss.platform.cli", "db_group"),
    ("hcss.platform.cli", "demo_trial"),
    ("hcss.platform.console.cli", "admin_group"),
    ("hcss.platform.export.cli", "export"),
    ("hcss.platform.bots", "bots_command"),
]


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


for module_name, attribute in COMMANDS:
    main.add_command(getattr(importlib.import_module(module_name), attribute))


if __name__ == "__main__":  # pragma: no cover
    main()
