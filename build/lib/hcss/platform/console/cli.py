"""`hcss admin create`: console accounts from the command line."""

from __future__ import annotations

import click


@click.group("admin")
def admin_group() -> None:
    """Manage experimenter accounts for the console (/console/)."""


@admin_group.command("create")
@click.option("--username", prompt=True, help="The new experimenter's login name.")
@click.option(
    "--password",
    prompt=True,
    hide_input=True,
    confirmation_prompt=True,
    help="Asked for (hidden, twice) when not given.",
)
def admin_create(username: str, password: str) -> None:
    """Create an experimenter account in the database (DATABASE_URL, else instance/)."""

    from hcss.platform.config import database_url
    from hcss.platform.console.accounts import AccountError, create_experimenter
    from hcss.platform.db import Database

    database = Database(database_url())
    try:
        with database.command_scope() as session:
            create_experimenter(session, username, password)
    except AccountError as error:
        raise click.ClickException(str(error)) from error
    click.echo(f"experimenter {username.strip()!r} created; sign in at /console/")
