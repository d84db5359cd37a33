"""A second factor for console sign-in: TOTP codes (RFC 6238, via pyotp) and recovery codes.

An account with a second factor signs in with its password and a code: the
six digits an authenticator app shows, or one of ten recovery codes printed
once at enrolment (each works once; only argon2 hashes are kept). A TOTP code is taken once: the step it belongs to is stored, and
a code of that step or an earlier one is refused, so a code seen over a
shoulder or in a log cannot be replayed.

The second factor is also the lab's way in while a guesser has locked the
experimenter's address out: the right password with a valid code signs in
through a lockout (hcss.platform.console.views.login). Codes tried through a
lockout are limited per account (`CODES_PER_LOCKOUT` in `CODE_WINDOW_S`), so
the six digits cannot be guessed there.
"""

from __future__ import annotations

import secrets
import time
from dataclasses import dataclass

import pyotp
from argon2 import PasswordHasher

from hcss.platform.console.accounts import password_matches
from hcss.platform.models import Experimenter

ISSUER = "hcss console"
RECOVERY_CODES = 10
#: Steps either side of now a TOTP code may belong to (clock drift of the phone).
DRIFT_STEPS = 1
#: Codes one account may try through a lockout in any `CODE_WINDOW_S`.
CODES_PER_LOCKOUT = 5
CODE_WINDOW_S = 900.0
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
    """Give the account a new second factor (replacing any earlier one); show it once."""
    secret = pyotp.random_base32()
    codes = tuple(_recovery_code() for _ in range(RECOVERY_CODES))
    account.totp_secret = secret
    account.totp_last_step = None
    account.recovery_hashes = [_recovery_hasher.hash(code.replace("-", "")) for code in codes]
    uri = pyotp.TOTP(secret).provisioning_uri(name=account.username, issuer_name=ISSUER)
    return Enrolment(secret, uri, codes)


def remove(account: Experimenter) -> None:
    account.totp_secret = None
    account.totp_last_step = None
    account.recovery_hashes = None


def has_second_factor(account: Experimenter) -> bool:
    return bool(account.totp_secret)


def verify(account: Experimenter, code: str, now: float | None = None) -> bool:
    """Whether `code` is a TOTP code not used before or an unused recovery code; a
    match is spent (the caller commits the account)."""
    if not account.totp_secret:
        return False
    typed = "".join(code.split()).lower().replace("-", "")
    if typed.isascii() and typed.isdigit() and len(typed) == 6:
        return _take_totp(account, typed, time.time() if now is None else now)
    return _take_recovery(account, typed)


def _take_totp(account: Experimenter, typed: str, now: float) -> bool:
    totp = pyotp.TOTP(str(account.totp_secret))
    current = int(now // totp.interval)
    for step in range(current - DRIFT_STEPS, current + DRIFT_STEPS + 1):
        if secrets.compare_digest(totp.generate_otp(step), typed):
            if account.totp_last_step is not None and step <= account.totp_last_step:
                return False  # used already (or an older one): no replay
            account.totp_last_step = step
            return True
    return False


def _take_recovery(account: Experimenter, typed: str) -> bool:
    hashes = list(account.recovery_hashes or [])
    for stored in hashes:
        if password_matches(str(stored), typed):
            hashes.remove(stored)
            account.recovery_hashes = hashes  # a new list: the JSON column sees the change
            return True
    return False


def _recovery_code() -> str:
    """Ten hex digits in two groups (40 bits), easy to read out and type."""
    raw = secrets.token_hex(5)
    return f"{raw[:5]}-{raw[5:]}"
