"""A second factor for console sign-in: enrolment, TOTP codes, recovery codes, lockouts.

Enrolled through `hcss admin second-factor`, as an administrator does; codes
made with pyotp from the printed secret, as an authenticator app makes them.
"""

from __future__ import annotations

from click.testing import CliRunner
from sqlalchemy import select

from hcss.platform.console.lockout import CLIENT_FAILURES
from hcss.platform.console.second_factor import CODES_PER_LOCKOUT
from hcss.platform.models import Experimenter
from tests.support.console import PASSWORD, USERNAME
from tests.support.second_factor import enrol as _enrol
from tests.support.second_factor import next_step_code as _next_step_code
from tests.support.second_factor import sign_in as _sign_in


def test_an_enrolled_account_needs_its_code_once_and_a_code_is_not_taken_twice(
    app, experimenter, monkeypatch
) -> None:
    assert _sign_in(app, PASSWORD).status_code == 302  # not enrolled: the password alone
    totp, _ = _enrol(app, monkeypatch)
    assert _sign_in(app, PASSWORD).status_code == 401  # no code
    assert (
        _sign_in(app, PASSWORD, "000000" if totp.now() != "000000" else "111111").status_code == 401
    )
    assert _sign_in(app, "wrong password", totp.now()).status_code == 401
    code = totp.now()
    assert _sign_in(app, PASSWORD, code).status_code == 302
    assert _sign_in(app, PASSWORD, code).status_code == 401  # replayed: refused
    assert _sign_in(app, PASSWORD, _next_step_code(totp)).status_code == 302


def test_a_recovery_code_signs_in_once_and_removal_restores_the_password_alone(
    app, experimenter, monkeypatch
) -> None:
    from hcss.cli import main as cli

    _, codes = _enrol(app, monkeypatch)
    assert _sign_in(app, PASSWORD, codes[3].upper()).status_code == 302
    assert _sign_in(app, PASSWORD, codes[3]).status_code == 401  # spent
    assert _sign_in(app, PASSWORD, codes[4].replace("-", "")).status_code == 302
    with app.extensions["hcss_db"].session_scope() as session:
        account = session.scalars(select(Experimenter)).one()
        assert len(account.recovery_hashes or []) == 8
        assert all(code not in str(account.recovery_hashes) for code in codes)  # hashes only
    result = CliRunner().invoke(cli, ["admin", "second-factor", USERNAME, "--remove"])
    assert result.exit_code == 0, result.output
    assert _sign_in(app, PASSWORD).status_code == 302
    unknown = CliRunner().invoke(cli, ["admin", "second-factor", "nobody"])
    assert unknown.exit_code != 0 and "no experimenter named 'nobody'" in unknown.output


def test_a_valid_code_signs_in_through_a_lockout_and_guessed_codes_are_bounded(
    app, experimenter, monkeypatch
) -> None:
    totp, codes = _enrol(app, monkeypatch)
    for _ in range(CLIENT_FAILURES):
        assert _sign_in(app, "wrong").status_code == 401
    assert _sign_in(app, PASSWORD).status_code == 429  # locked out, the password alone
    assert _sign_in(app, PASSWORD, totp.now()).status_code == 302  # the second factor opens it
    assert _sign_in(app, PASSWORD, _next_step_code(totp)).status_code == 302  # lifted

    for _ in range(CLIENT_FAILURES):
        _sign_in(app, "wrong", address="10.0.0.9")
    for _ in range(CODES_PER_LOCKOUT - 1):  # someone with the password guesses codes
        guessed = _sign_in(app, PASSWORD, "123456", address="10.0.0.9")
        assert guessed.status_code == 429
    # The account's codes through a lockout (one used above, four guessed) are spent:
    # even a right code waits now.
    assert _sign_in(app, PASSWORD, codes[0], address="10.0.0.9").status_code == 429
    assert _sign_in(app, PASSWORD, codes[1], address="10.0.0.9").status_code == 429
    # Elsewhere the account signs in as usual (the lockout is of one address).
    assert _sign_in(app, PASSWORD, codes[2], address="10.0.0.7").status_code == 302
