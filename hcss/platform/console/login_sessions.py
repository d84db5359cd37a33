"""Console sign-ins that a sign-out really ends, server-side.

Flask keeps the session in a signed cookie, so deleting it in the browser
alone would leave a copied cookie working. Each account has a
`login_generation`; the cookie names the account *and* the
generation it was issued in (``"<id>.<generation>"``), and signing out moves
the generation on, so every cookie issued before stops working (on every
device of that account: signing out signs out everywhere).
"""

from __future__ import annotations

from sqlalchemy import update
from sqlalchemy.orm import Session

from hcss.platform.models import Experimenter


def experimenter_for_cookie(session: Session, user_id: str) -> Experimenter | None:
    """The account a session cookie names, if the cookie is of its current generation."""
    account_id, _, generation = user_id.partition(".")
    if not (account_id.isascii() and account_id.isdigit() and generation.isascii()):
        return None
    if not generation.isdigit() or len(account_id) > 10 or len(generation) > 10:
        return None
    account = session.get(Experimenter, int(account_id))
    if account is None or account.login_generation != int(generation):
        return None
    return account


def end_sessions(session: Session, account_id: int) -> None:
    """Invalidate every cookie of the account (committed with the sign-out request)."""
    session.execute(
        update(Experimenter)
        .where(Experimenter.id == account_id)
        .values(login_generation=Experimenter.login_generation + 1)
    )
