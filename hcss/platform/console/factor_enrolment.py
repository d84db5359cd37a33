"""Enrolling a second factor from the console: a QR code to scan, a code to confirm, the
recovery codes once.

The secret offered is stored nowhere until the experimenter has typed a code of it: it
travels in the enrolment page, signed with the app's secret key for this account and
for `OFFER_MAX_AGE_S`. An enrolment left half done leaves the account as it was, and a
mistyped code shows the same QR code again.

Confirming is `second_factor.enrol` (new recovery codes, every other session of the
account ended, its code history cleared) with the scanned secret put in place of the one
it draws, in one unit of work; the typed code is then spent through
`second_factor.verify`, so the code that confirmed cannot sign in as well.
"""

from __future__ import annotations

from dataclasses import dataclass

import pyotp
import segno
from itsdangerous import BadSignature, URLSafeTimedSerializer
from markupsafe import Markup

from hcss.platform.console.second_factor import DRIFT_STEPS, ISSUER, Enrolment, enrol, verify
from hcss.platform.db import Database
from hcss.platform.models import Experimenter

#: How long an offered secret may be confirmed (seconds): time to find the phone and scan.
OFFER_MAX_AGE_S = 900
_SALT = "hcss-console-second-factor-offer"


@dataclass(frozen=True)
class Offer:
    """A secret offered to one account: for the app (QR code, or typed), and signed for the form."""

    secret: str
    uri: str
    signed: str

    def qr_code(self) -> Markup:
        """The otpauth:// link as an inline SVG QR code (segno), labelled for screen readers."""
        svg = segno.make(self.uri, error="m").svg_inline(
            scale=5, title="QR code of the second factor for an authenticator app"
        )
        return Markup(
            svg.replace("<svg ", '<svg role="img" aria-labelledby="qr-title" ', 1).replace(
                "<title>", '<title id="qr-title">', 1
            )
        )


def _serializer(secret_key: str) -> URLSafeTimedSerializer:
    return URLSafeTimedSerializer(secret_key, salt=_SALT)


def offer(account: Experimenter, secret_key: str, secret: str | None = None) -> Offer:
    """A new secret for `account` (or `secret` again, after a mistyped code)."""
    secret = secret or pyotp.random_base32()
    uri = pyotp.TOTP(secret).provisioning_uri(name=account.username, issuer_name=ISSUER)
    signed = _serializer(secret_key).dumps({"account": account.id, "secret": secret})
    return Offer(secret, uri, signed)


def offered_secret(account: Experimenter, signed: str, secret_key: str) -> str | None:
    """The secret a form carries back, if it was offered to this account and is not too old."""
    try:
        carried = _serializer(secret_key).loads(signed, max_age=OFFER_MAX_AGE_S)
    except BadSignature:  # SignatureExpired is one
        return None
    if not isinstance(carried, dict) or carried.get("account") != account.id:
        return None
    secret = carried.get("secret")
    return secret if isinstance(secret, str) else None


@dataclass(frozen=True)
class Confirmed:
    """An enrolment done: what to show once, and the account as now stored (its sign-in
    generation moved on), to sign this browser in again."""

    enrolment: Enrolment
    account: Experimenter


def confirm(database: Database, account_id: int, secret: str, code: str) -> Confirmed | None:
    """Make `secret` the account's second factor if `code` is one of its codes now; None
    (nothing written) for a wrong code."""
    typed = "".join(code.split())
    if not (typed.isascii() and typed.isdigit() and len(typed) == 6):
        return None
    if not pyotp.TOTP(secret).verify(typed, valid_window=DRIFT_STEPS):
        return None
    with database.session_scope() as session:
        account = session.get(Experimenter, account_id)
        if account is None:
            return None
        drawn = enrol(account)
        account.totp_secret = secret  # the one scanned, not the one enrol drew
    verify(database, account, typed)  # spent: the confirming code signs nobody in
    uri = pyotp.TOTP(secret).provisioning_uri(name=account.username, issuer_name=ISSUER)
    return Confirmed(Enrolment(secret, uri, drawn.recovery_codes), account)
