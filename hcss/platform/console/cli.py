"""`hcss admin create`, `unlock` and `second-factor`: console accounts from the command line."""

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


@admin_group.command("unlock")
@click.argument("username")
def admin_unlock(username: str) -> None:
    """Lift the sign-in lockouts of USERNAME from every address, at once.

    For an experimenter locked out while someone guesses from their address;
    the guesser's next failures count afresh.
    """
    from hcss.platform.config import database_url
    from hcss.platform.console.lockout import LoginThrottle
    from hcss.platform.db import Database

    database = Database(database_url())
    with database.command_scope():
        cleared = LoginThrottle(database).unlock(username)
    click.echo(f"{username.strip()!r} unlocked ({cleared} failed sign-ins cleared)")


@admin_group.command("second-factor")
@click.argument("username")
@click.option("--remove", is_flag=True, help="Take the second factor off the account.")
def admin_second_factor(username: str, remove: bool) -> None:
    """Give USERNAME a second factor for console sign-in (a new one replaces the old).

    Prints, once, the secret for an authenticator app (and its otpauth:// link, which
    some apps take pasted in) and ten recovery codes, each good for
    one sign-in without the app. From then on the console asks for a code.
    A valid code also signs in through a lockout of the experimenter's address.
    """
    from sqlalchemy import select

    from hcss.platform.config import database_url
    from hcss.platform.console.second_factor import enrol
    from hcss.platform.console.second_factor import remove as remove_factor
    from hcss.platform.db import Database
    from hcss.platform.models import Experimenter

    database = Database(database_url())
    with database.command_scope() as session:
        account = session.scalars(
            select(Experimenter).where(Experimenter.username == username.strip())
        ).first()
        if account is None:
            raise click.ClickException(f"no experimenter named {username.strip()!r}")
        if remove:
            remove_factor(account)
            click.echo(f"{account.username!r} signs in with the password alone now")
            return
        enrolment = enrol(account)
    click.echo(f"second factor for {username.strip()!r} (shown once; keep it safe):")
    click.echo(f"  secret for the authenticator app: {enrolment.secret}")
    click.echo(f"  or its otpauth:// link:           {enrolment.uri}")
    click.echo("  recovery codes, each good once:")
    for code in enrolment.recovery_codes:
        click.echo(f"    {code}")
