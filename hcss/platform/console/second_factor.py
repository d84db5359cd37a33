"""A second factor for console sign-in: TOTP codes (RFC 6238, via pyotp) and recovery codes.

An account with a second factor signs in with its password and a code: the
six digits an authenticator app shows, or one of ten recovery codes printed
once at enrolment (each works once; only argon2 hashes are kept). A TOTP code
is taken once: the step it belongs to is stored, and a code of that step or an
earlier one is refused, so a code seen over a shoulder or in a log cannot be
replayed.

Taking a code is one conditional UPDATE in a unit of work of its own, checked
by its rowcount: the step only moves forward (``totp_last_step < step``), and
the recovery list is replaced only while it is still the list the code was
found in. Ten sign-ins sent at once with one code therefore give one session
(the read-then-commit of before gave eight), on SQLite and PostgreSQL alike.

Checking a code costs the same whether the password was right: a wrong
password (or an account without a second factor) checks the code against a
dummy factor with as many recovery hashes (`check_nothing`), so the time of
an answer does not tell a guesser that their password was right.

Wrong TOTP codes are limited per account, from every address together and on
every process (`CODE_FAILURES` in `CODE_WINDOW_S`, counted in the database):
someone who has the password cannot try the six digits from many addresses. A
recovery code (40 bits) is not capped, so that person cannot lock the lab out
from anywhere (hcss.platform.console.signin says what the lab is shown).
Enrolling, replacing or removing a factor ends the account's sessions.

The second factor is also the lab's way in while a guesser has locked the
experimenter's address out: the right password with a valid code signs in
through a lockout (hcss.platform.console.views.login). Codes tried through a
lockout are limited per account (`CODES_PER_LOCKOUT` in `CODE_WINDOW_S`), so
the six digits cannot be guessed there.
"""

from __future__ import annotations

import functools
import json
import secrets
import time
from dataclasses import dataclass

import pyotp
from argon2 import PasswordHasher
from sqlalchemy import String, cast, or_, select, update

from hcss.platform.console.accounts import password_matches
from hcss.platform.db import Database
from hcss.platform.models import Experimenter

ISSUER = "hcss console"
RECOVERY_CODES = 10
#: Steps either side of now a TOTP code may belong to (clock drift of the phone).
DRIFT_STEPS = 1
#: Codes one account may try through a lockout in any `CODE_WINDOW_S`.
CODES_PER_LOCKOUT = 5
CODE_WINDOW_S = 900.0
#: Wrong codes one account may be sent in any `CODE_WINDOW_S`, from all addresses.
CODE_FAILURES = 10
#: The database counts (hcss.platform.console.lockout.LoginThrottle.take) of the two limits.
FAILURE_SCOPE, LOCKOUT_SCOPE = "code", "lockcode"
#: Recovery codes are 40 random bits, not chosen words: a light argon2 (about a
#: millisecond) still makes trying them all from a stolen database take centuries,
#: and checking ten of them at a sign-in stays quick.
_recovery_hasher = PasswordHasher(time_cost=1, memory_cost=8192, parallelism=1)


@dataclass(frozen=True)
class Enrolment:
    """What the experimenter is shown once: the secret, its otpauth URI, the recovery codes."""

    secret: str
    uri: str
    recovery_codes: tuple[str, ...]


def enrol(account: Experimenter) -> Enrolment:
    """Give the account a new second factor (replacing any earlier one); show it once.

    Every session of the account ends (its sign-in generation moves on): one
    signed in with the password alone, or with the factor being replaced,
    signs in again with the new one.
    """
    secret = pyotp.random_base32()
    codes = tuple(_recovery_code() for _ in range(RECOVERY_CODES))
    account.totp_secret = secret
    account.totp_last_step = None
    account.recovery_hashes = [_recovery_hasher.hash(code.replace("-", "")) for code in codes]
    account.login_generation = (account.login_generation or 0) + 1
    uri = pyotp.TOTP(secret).provisioning_uri(name=account.username, issuer_name=ISSUER)
    return Enrolment(secret, uri, codes)


def remove(account: Experimenter) -> None:
    account.totp_secret = None
    account.totp_last_step = None
    account.recovery_hashes = None
    account.login_generation = (account.login_generation or 0) + 1


def has_second_factor(account: Experimenter) -> bool:
    return bool(account.totp_secret)


def verify(database: Database, account: Experimenter, code: str, now: float | None = None) -> bool:
    """Whether `code` is a TOTP code of a step not used before or an unused recovery code;
    a match is spent at once, in its own unit of work, by at most one caller."""
    if not account.totp_secret:
        check_nothing(code)
        return False
    typed = _typed(code)
    if typed.isascii() and typed.isdigit() and len(typed) == 6:
        return _take_totp(database, account, typed, time.time() if now is None else now)
    return _take_recovery(database, account.id, typed)


def is_totp_shaped(code: str) -> bool:
    """Whether `code` reads as an authenticator app's six digits (else a recovery code):
    the guessable kind, which the account's cap on wrong codes is for."""
    typed = _typed(code)
    return typed.isascii() and typed.isdigit() and len(typed) == 6


def check_nothing(code: str) -> None:
    """The work of checking `code` against a factor, for a sign-in that has none to check.

    A recovery-shaped code costs `RECOVERY_CODES` light argon2 checks on every
    path, so a wrong password answers in the time a right one does.
    """
    typed = _typed(code)
    if typed.isascii() and typed.isdigit() and len(typed) == 6:
        pyotp.TOTP(_DUMMY_SECRET).verify(typed, valid_window=DRIFT_STEPS)
        return
    _matching(_dummy_hashes(), typed)


def _typed(code: str) -> str:
    return "".join(code.split()).lower().replace("-", "")


def _take_totp(database: Database, account: Experimenter, typed: str, now: float) -> bool:
    totp = pyotp.TOTP(str(account.totp_secret))
    current = int(now // totp.interval)
    for step in range(current - DRIFT_STEPS, current + DRIFT_STEPS + 1):
        if secrets.compare_digest(totp.generate_otp(step), typed):
            with database.session_scope() as session:
                taken = session.execute(
                    update(Experimenter)
                    .where(
                        Experimenter.id == account.id,
                        Experimenter.totp_secret == account.totp_secret,
                        or_(
                            Experimenter.totp_last_step.is_(None),
                            Experimenter.totp_last_step < step,
                        ),
                    )
                    .values(totp_last_step=step)
                )
                # An UPDATE answers a CursorResult; Session.execute is typed as any Result.
                return int(taken.rowcount or 0) == 1  # type: ignore[attr-defined]
    return False


def _take_recovery(database: Database, account_id: int, typed: str) -> bool:
    """Remove the matching hash from the list it was found in, if that list is still stored.

    The list is compared as the text the database holds, so a code spent by
    another sign-in in between (this one or another) makes the UPDATE change
    nothing; a different code spent in between is looked for again.
    """
    as_text = cast(Experimenter.recovery_hashes, String)
    for _ in range(RECOVERY_CODES + 1):
        # Read, check, then take: the ten argon2 checks run with no transaction open (inside
        # one, a loaded machine idled it past PostgreSQL's limit and the sign-in answered 500).
        with database.session_scope() as session:
            stored = session.scalar(select(as_text).where(Experimenter.id == account_id))
        hashes = [str(h) for h in (json.loads(stored) if stored else None) or []]
        found = _matching(hashes, typed)
        if found is None:
            return False
        left = [h for h in hashes if h != found]
        with database.session_scope() as session:
            taken = session.execute(
                update(Experimenter)
                .where(Experimenter.id == account_id, as_text == stored)
                .values(recovery_hashes=left)
            )
            if int(taken.rowcount or 0) == 1:  # type: ignore[attr-defined]
                return True
    return False


def _matching(hashes: list[str], typed: str) -> str | None:
    """The hash `typed` matches, checking as many as a full list holds whatever the list."""
    found = None
    padded = hashes + _dummy_hashes()[len(hashes) :]
    for number, stored in enumerate(padded):
        if password_matches(stored, typed) and number < len(hashes) and found is None:
            found = stored
    return found


def _recovery_code() -> str:
    """Ten hex digits in two groups (40 bits), easy to read out and type."""
    raw = secrets.token_hex(5)
    return f"{raw[:5]}-{raw[5:]}"


_DUMMY_SECRET = pyotp.random_base32()


@functools.cache
def _dummy_hashes() -> list[str]:
    """The dummy factor's recovery hashes, made at the first code checked, not at import
    (every `hcss` command and server start paid for ten argon2 hashes)."""
    return [_recovery_hasher.hash(secrets.token_hex(5)) for _ in range(RECOVERY_CODES)]
