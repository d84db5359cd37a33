"""Experimenter accounts: argon2 password hashes, sign-in, and the first login.

Participants have no account (their link is their key); only experimenters
sign in, and only to the console.
"""

from __future__ import annotations

import functools
import secrets

import click
from argon2 import PasswordHasher
from argon2.exceptions import InvalidHashError, VerificationError
from flask import Flask
from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError, InternalError, OperationalError, ProgrammingError
from sqlalchemy.orm import Session

from hcss.platform.db import hand_back_connection
from hcss.platform.models import Experimenter

FIRST_USERNAME = "experimenter"
MIN_PASSWORD_LENGTH = 8
_hasher = PasswordHasher()


@functools.cache
def _dummy_hash() -> str:
    """Verified against when the username is unknown, so a wrong username costs the same
    time as a wrong password and does not reveal which accounts exist. Made at the first
    sign-in, not at import: every `hcss` command and server start paid its 0.2-0.4 s."""
    return _hasher.hash(secrets.token_hex(16))


class AccountError(ValueError):
    """An account that cannot be created as asked; the message says why."""


def hash_password(password: str) -> str:
    return _hasher.hash(password)


def password_matches(password_hash: str, password: str) -> bool:
    try:
        return _hasher.verify(password_hash, password)
    except (VerificationError, InvalidHashError):
        return False


def create_experimenter(session: Session, username: str, password: str) -> Experimenter:
    """A new account; refuses an empty or taken username and a short password.

    The password is hashed before the session's first query, so no transaction idles
    across the hash (a fifth of a second idle, seconds on a loaded machine: PostgreSQL
    ends a transaction idle that long, 25P03); call it with a session that has none open.
    """
    username = username.strip()
    if not username or len(username) > 64:
        raise AccountError("the username must have 1 to 64 characters")
    if len(password) < MIN_PASSWORD_LENGTH:
        raise AccountError(f"the password must have at least {MIN_PASSWORD_LENGTH} characters")
    password_hash = hash_password(password)
    taken = session.scalar(select(Experimenter.id).where(Experimenter.username == username))
    if taken is not None:
        raise AccountError(f"an experimenter named {username!r} already exists")
    account = Experimenter(username=username, password_hash=password_hash)
    session.add(account)
    session.flush()
    return account


def authenticate(session: Session, username: str, password: str) -> Experimenter | None:
    account = session.scalars(
        select(Experimenter).where(Experimenter.username == username.strip())
    ).first()
    # The hash takes a fifth of a second idle, seconds on a loaded machine: not inside the
    # read (PostgreSQL ends a transaction idle that long, and the sign-in answered 500).
    hand_back_connection()
    if account is None:
        password_matches(_dummy_hash(), password)
        return None
    return account if password_matches(account.password_hash, password) else None


def ensure_first_login(app: Flask) -> tuple[str, str] | None:
    """On a server with no experimenter yet, make one and print its login once.

    The password is random and printed only here; nothing stores it in clear.
    Returns the (username, password) made, or None when accounts already exist,
    another process starting at the same time made the first one, or the
    database has not been migrated (which `hcss db upgrade` fixes).
    """
    database = app.extensions["hcss_db"]
    try:
        with database.session_scope() as session:
            if session.scalar(select(func.count()).select_from(Experimenter)):
                return None
        # A unit of work of its own, which hashes before it reads: the count's transaction
        # is over. Two processes that both counted none: the second's insert is refused.
        password = secrets.token_urlsafe(12)
        with database.session_scope() as session:
            create_experimenter(session, FIRST_USERNAME, password)
    except (IntegrityError, AccountError):
        # Processes of a group (on one host or several) starting together on a new
        # database all counted none; the first to commit made the login and printed it
        # (a later one finds its name taken, or its insert is refused).
        return None
    except (OperationalError, ProgrammingError, InternalError) as error:
        refusal = database.write_refusal()
        if refusal is not None:  # read-only, full or away: migrating would not help
            click.echo(
                f"no console login created: the database takes no writes ({refusal}); "
                "one is made at the next start on a database that takes writes",
                err=True,
            )
        else:
            click.echo(
                f"no console login created ({error.orig}); run `hcss db upgrade`, then restart",
                err=True,
            )
        return None
    click.echo(
        f"first console login (shown once): {FIRST_USERNAME} / {password}  "
        "-> /console/  (more: hcss admin create)"
    )
    return FIRST_USERNAME, password
