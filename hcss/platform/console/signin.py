"""The console's sign-in: the throttle, the password, the second factor, in that order.

Every attempt is counted as a failure before its password is checked (the
throttle, hcss.platform.console.lockout), so a burst of guesses checks few.
One (account, client)'s attempts are checked in turn in a process, each after
the last one's outcome: ten right passwords sent at once all sign in, where
counting all ten before any was checked locked the fifth out.
An account with a second factor needs a valid code as well
(hcss.platform.console.second_factor). While the (account, client) pair is
locked, the password alone is not checked; the password with a valid code
opens the lockout, and only a few codes per account may be tried that way.

Wrong six-digit codes are capped per account (second_factor.CODE_FAILURES). While the cap
is in force a six-digit code answers 429 saying so, whatever the password (the answer is
no password oracle; it tells a stranger only that the account is under attack). The lab
is never locked out from everywhere: a recovery code is checked whatever the cap, and the
lab's network (CONSOLE_ALLOW) is not capped.
"""

from __future__ import annotations

from contextlib import nullcontext
from math import ceil

from flask import current_app, flash, redirect, render_template, request
from flask import session as cookie_session
from flask.typing import ResponseReturnValue
from flask_login import login_user

from hcss.platform.console import forms
from hcss.platform.console.accounts import authenticate
from hcss.platform.console.lockout import (
    Attempt,
    LoginThrottle,
    account_key,
    allowed,
    audit_lockout,
)
from hcss.platform.console.second_factor import (
    CODE_FAILURES,
    CODE_WINDOW_S,
    CODES_PER_LOCKOUT,
    FAILURE_SCOPE,
    LOCKOUT_SCOPE,
    check_nothing,
    has_second_factor,
    is_totp_shaped,
)
from hcss.platform.console.second_factor import verify as verify_second_factor
from hcss.platform.db import database, get_session, hand_back_connection
from hcss.platform.guards.clients import request_client


def answer_sign_in(form: forms.LoginForm, next_url: str) -> ResponseReturnValue:
    """Sign the experimenter in and go to `next_url`, or the page that says why not."""
    throttle = _throttle()
    hand_back_connection()  # no transaction open while this sign-in waits for its turn
    # One (account, client)'s sign-ins in turn, each seeing the last one's outcome.
    client = request_client()
    turn = throttle.in_turn(form.username.data, client) if throttle else nullcontext()
    with turn:
        return _sign_in(throttle, form, next_url, client)


def _sign_in(
    throttle: LoginThrottle | None, form: forms.LoginForm, next_url: str, client: str
) -> ResponseReturnValue:
    attempt = throttle.begin(form.username.data, client) if throttle else None
    locked = attempt is not None and attempt.wait_s > 0
    code = (form.code.data or "").strip()
    paused_s = _codes_paused_s(form.username.data) if code and is_totp_shaped(code) else 0.0
    if paused_s > 0:
        return _codes_paused(form, paused_s)
    # Through a lockout only a second factor opens the door, and only a few codes a while.
    if locked and not (code and _code_tries(LOCKOUT_SCOPE, form.username.data)):
        return _locked_out(form, attempt)
    account = authenticate(get_session(), form.username.data, form.password.data)
    if account is not None and has_second_factor(account):
        account = account if code and _code_is_right(account, code) else None
    else:
        if code:
            check_nothing(code)  # as long as checking it would take: time tells nothing
        if locked:
            account = None
    if account is not None:
        if throttle and attempt:
            throttle.succeeded(attempt)
        cookie_session.clear()  # no session fixation across the sign-in
        login_user(account)
        return redirect(next_url)
    if locked:
        return _locked_out(form, attempt)
    if attempt is not None:
        audit_lockout(database(), attempt, form.username.data)
    flash("Wrong username or password (or one-time code).")
    return render_template("console/login.html", form=form), 401


def _code_is_right(account, code: str) -> bool:  # type: ignore[no-untyped-def]
    """Check a code of an account whose password was right, within the account's allowance
    of wrong codes (from every address, on every process); past it no code is checked,
    and the answer is the one a wrong code gets."""
    if is_totp_shaped(code) and not _code_tries(FAILURE_SCOPE, account.username):
        check_nothing(code)
        return False
    if not verify_second_factor(database(), account, code):
        return False
    _throttle_of_app().forget(FAILURE_SCOPE, account_key(account.username))
    return True


def _throttle() -> LoginThrottle | None:
    """The app's sign-in throttle; None when LOGIN_RATE_LIMIT is off (the fuzz test) or
    for an address in CONSOLE_ALLOW (the lab's own network: a way in during a lockout)."""
    if not current_app.config.get("LOGIN_RATE_LIMIT", True):
        return None
    if allowed(request.remote_addr, current_app.config.get("CONSOLE_ALLOW") or ()):
        return None
    return _throttle_of_app()


def _throttle_of_app() -> LoginThrottle:
    return current_app.extensions.setdefault("hcss_login_throttle", LoginThrottle(database()))


def _code_tries(scope: str, username: str) -> bool:
    """Count a one-time code tried for the account; False past its allowance.

    LOCKOUT_SCOPE: every code tried through a lockout; FAILURE_SCOPE: the wrong
    ones (a right code clears them). Kept in the database, so the allowance is
    the account's on every server process.
    """
    if not current_app.config.get("LOGIN_RATE_LIMIT", True) or _labs_network():
        return True
    count = CODES_PER_LOCKOUT if scope == LOCKOUT_SCOPE else CODE_FAILURES
    return _throttle_of_app().take(scope, account_key(username), count, CODE_WINDOW_S)


def _labs_network() -> bool:
    return allowed(request.remote_addr, current_app.config.get("CONSOLE_ALLOW") or ())


def _codes_paused_s(username: str) -> float:
    """Seconds the account's six-digit codes stay refused (its wrong ones are at the cap);
    0 from the lab's network or with the limits off."""
    if not current_app.config.get("LOGIN_RATE_LIMIT", True) or _labs_network():
        return 0.0
    key = account_key(username)
    return _throttle_of_app().wait_s(FAILURE_SCOPE, key, CODE_FAILURES, CODE_WINDOW_S)


def _codes_paused(form: forms.LoginForm, wait_s: float) -> ResponseReturnValue:
    """The cap's answer, the same whatever the password (no oracle): what is paused, the
    ways in, and what the wrong codes mean."""
    flash(
        f"One-time codes for this account are paused for {ceil(wait_s / 60)} minute(s): too "
        "many wrong ones were sent with its password. Sign in with a recovery code, from the "
        "lab's network, or ask an administrator to run `hcss admin unlock`. If those codes "
        "were not yours, someone knows the password: change it."
    )
    page = render_template("console/login.html", form=form)
    return page, 429, {"Retry-After": str(ceil(wait_s))}


def _locked_out(form: forms.LoginForm, attempt: Attempt | None) -> ResponseReturnValue:
    wait_s = attempt.wait_s if attempt is not None else 60.0
    flash(f"Too many failed sign-ins; try again in {ceil(wait_s / 60)} minute(s).")
    page = render_template("console/login.html", form=form)
    return page, 429, {"Retry-After": str(ceil(wait_s))}
