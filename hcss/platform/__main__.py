"""`python -m hcss.platform serve|db|demo-trial`: the platform's commands on their own.

The same commands as under `hcss`; this entry point does not need the other
parts' commands to import, which keeps the restart test and the benchmark
independent of them.
"""

import click

from hcss.platform.cli import db_group, demo_trial, deploy_group, serve


@click.group()
def platform() -> None:
    """The study platform's commands."""


platform.add_command(serve)
platform.add_command(db_group)
platform.add_command(demo_trial)
platform.add_command(deploy_group)

if __name__ == "__main__":
    platform()
