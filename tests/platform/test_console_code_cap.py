"""Issue 44 §5: the account's cap on wrong one-time codes, and who it can lock out.

The design (hcss.platform.console.signin): the cap bounds guesses at the six digits of a
TOTP code (`CODE_FAILURES` wrong ones per account in `CODE_WINDOW_S`, from every address).
Someone who has the password could spend it from anywhere, so:
- while it is in force, a sign-in that sends a six-digit code answers 429 with Retry-After
  and says codes are paused, what to do, and that the password is known to whoever spent
  them; it says so whether the password was right or not (no password oracle), so it tells
  a stranger only that the account is under attack;
- a recovery code (40 bits: unguessable in any number of tries) is checked whatever the
  cap: the lab signs in from anywhere with one;
- from the lab's own network (CONSOLE_ALLOW) the cap does not apply, as the per-client
  lockout does not; `hcss admin unlock` clears it.
"""

from __future__ import annotations

import pytest

from hcss.platform.console import second_factor
from hcss.platform.console.second_factor import CODE_FAILURES
from tests.support.console import PASSWORD
from tests.support.second_factor import enrol as _enrol
from tests.support.second_factor import next_step_code as _next_step_code
from tests.support.second_factor import sign_in as _sign_in

pytestmark = pytest.mark.slow  # a dozen argon2-checked sign-ins


def _spend_the_cap(app, totp) -> None:
    wrong = "000000" if totp.now() != "000000" else "111111"
    for number in range(CODE_FAILURES):
        answer = _sign_in(app, PASSWORD, wrong, address=f"10.0.9.{number}")
        assert answer.status_code == 401


def test_the_labs_valid_code_during_the_cap_is_told_why_and_a_recovery_code_signs_in(
    app, experimenter, monkeypatch
) -> None:
    totp, codes = _enrol(app, monkeypatch)
    _spend_the_cap(app, totp)
    refused = _sign_in(app, PASSWORD, _next_step_code(totp), address="10.0.10.1")
    assert refused.status_code == 429
    assert int(refused.headers["Retry-After"]) > 0
    page = refused.get_data(as_text=True)
    assert "codes for this account are paused" in page and "recovery code" in page
    assert _sign_in(app, PASSWORD, codes[0], address="10.0.10.2").status_code == 302


def test_the_cap_says_the_same_to_a_wrong_password(app, experimenter, monkeypatch) -> None:
    """No oracle: the cap's answer does not depend on the password."""
    totp, _ = _enrol(app, monkeypatch)
    _spend_the_cap(app, totp)
    right = _sign_in(app, PASSWORD, "123456", address="10.0.11.1")
    wrong = _sign_in(app, "not the password", "123456", address="10.0.11.2")
    assert right.status_code == wrong.status_code == 429

    def message(answer) -> str:
        text = answer.get_data(as_text=True)
        return text[text.index("paused") - 40 : text.index("paused") + 200]

    assert message(right) == message(wrong)


def test_the_labs_network_is_not_capped(app, experimenter, monkeypatch) -> None:
    app.config["CONSOLE_ALLOW"] = ["192.168.7.0/24"]
    totp, _ = _enrol(app, monkeypatch)
    _spend_the_cap(app, totp)
    assert _sign_in(app, PASSWORD, _next_step_code(totp), address="192.168.7.20").status_code == 302


def test_a_wrong_recovery_code_is_not_refused_unchecked_during_the_cap(
    app, experimenter, monkeypatch
) -> None:
    """Recovery codes are checked (ten argon2 checks) during the cap, and spend nothing."""
    totp, codes = _enrol(app, monkeypatch)
    _spend_the_cap(app, totp)
    checked: list[str] = []
    matches = second_factor.password_matches
    monkeypatch.setattr(
        second_factor, "password_matches", lambda s, t: checked.append(t) or matches(s, t)
    )
    assert _sign_in(app, PASSWORD, "abcde-12345", address="10.0.12.1").status_code == 401
    assert len(checked) == second_factor.RECOVERY_CODES
    assert _sign_in(app, PASSWORD, codes[1], address="10.0.12.2").status_code == 302
