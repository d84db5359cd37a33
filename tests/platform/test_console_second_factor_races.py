"""Issue 30 §2: the second factor is taken once, tells nothing by its time, and is bounded
per account.

Sign-ins over real HTTP to a threaded server, each from its own loopback
address (127.0.5.x), so the per-client lockout and the one-at-a-time turn of a
client play no part: only the database decides which sign-in gets the code.
"""

from __future__ import annotations

import threading
from concurrent.futures import ThreadPoolExecutor

import httpx
import pytest

from hcss.platform.console import second_factor
from hcss.platform.console.second_factor import CODE_FAILURES
from tests.support.console import PASSWORD, USERNAME
from tests.support.inprocess import serving
from tests.support.second_factor import enrol as _enrol
from tests.support.second_factor import sign_ins_at_once
from tests.support.trials import csrf_token_of

pytestmark = pytest.mark.slow  # sign-ins at once: each checks an argon2 password


def _browser(base_url: str, address: str) -> httpx.Client:
    transport = httpx.HTTPTransport(local_address=address)
    return httpx.Client(base_url=base_url, transport=transport, timeout=60.0)


def test_one_totp_code_in_ten_simultaneous_sign_ins_gives_one_session(
    app, experimenter, monkeypatch
) -> None:
    totp, _ = _enrol(app, monkeypatch)
    with serving(app) as base_url:
        code = totp.now()
        statuses = sign_ins_at_once(base_url, 10, lambda _: {"password": PASSWORD, "code": code})
    assert statuses.count(302) == 1, statuses
    assert statuses.count(401) == 9


def test_one_recovery_code_in_ten_simultaneous_sign_ins_gives_one_session(
    app, experimenter, monkeypatch
) -> None:
    _, codes = _enrol(app, monkeypatch)
    with serving(app) as base_url:
        statuses = sign_ins_at_once(
            base_url, 10, lambda _: {"password": PASSWORD, "code": codes[0]}
        )
    assert statuses.count(302) == 1, statuses


def test_two_recovery_codes_spent_at_once_both_sign_in_and_neither_comes_back(
    app, experimenter, monkeypatch
) -> None:
    """Apart from the ten-at-once test: its nine refused repeats are wrong codes, and when
    the one that signed in was counted before them they stay on the account's tally, so
    with two codes more in flight the tenth code failure refuses one of these (seen once
    in CI as [401, 302]); that is the limit working, not the single use under test."""
    _, codes = _enrol(app, monkeypatch)
    with serving(app) as base_url:
        both = sign_ins_at_once(
            base_url, 2, lambda number: {"password": PASSWORD, "code": codes[number]}
        )
        again = sign_ins_at_once(
            base_url, 2, lambda number: {"password": PASSWORD, "code": codes[number]}
        )
    assert both == [302, 302]
    assert again == [401, 401]


def test_a_wrong_password_costs_the_code_checks_a_right_one_costs(
    app, experimenter, monkeypatch
) -> None:
    """The oracle was time: only a right password checked a recovery-shaped code (ten argon2
    checks); the checks are counted here, the same on both paths."""
    _, codes = _enrol(app, monkeypatch)
    checked: list[str] = []
    matches = second_factor.password_matches

    def counted(stored: str, typed: str) -> bool:
        checked.append(typed)
        return matches(stored, typed)

    monkeypatch.setattr(second_factor, "password_matches", counted)
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = "10.0.5.1"
    guess = "abcde-12345"
    costs = []
    for password in ("wrong password", PASSWORD, "another wrong one"):
        checked.clear()
        form = client.get("/console/login").get_data(as_text=True)
        fields = {"csrf_token": csrf_token_of(form), "username": USERNAME, "password": password}
        answer = client.post("/console/login", data={**fields, "code": guess})
        assert answer.status_code == 401
        costs.append(len(checked))
    assert costs == [10, 10, 10]
    assert len(codes) == 10


def test_wrong_codes_from_many_addresses_are_bounded_per_account(
    app, experimenter, monkeypatch
) -> None:
    """Someone with the password tries codes from 12 addresses, one each: the account's
    allowance of wrong codes holds for all of them together, a right code included."""
    totp, codes = _enrol(app, monkeypatch)
    tried: list[str] = []
    take = second_factor._take_totp

    def counted(database, account, typed, now):
        tried.append(typed)
        return take(database, account, typed, now)

    monkeypatch.setattr(second_factor, "_take_totp", counted)
    wrong = "000000" if totp.now() != "000000" else "111111"
    statuses = []
    for number in range(CODE_FAILURES + 2):
        client = app.test_client()
        client.environ_base["REMOTE_ADDR"] = f"10.0.6.{number}"
        for _ in range(1):
            form = client.get("/console/login").get_data(as_text=True)
            fields = {"csrf_token": csrf_token_of(form), "username": USERNAME}
            answer = client.post(
                "/console/login", data={**fields, "password": PASSWORD, "code": wrong}
            )
            statuses.append(answer.status_code)
    # Past the allowance six-digit codes are paused, and say so (test_console_code_cap).
    assert statuses == [401] * CODE_FAILURES + [429, 429]
    assert len(tried) <= CODE_FAILURES  # the rest were never checked
    # A recovery code, unguessable, is not capped: the lab is not locked out from anywhere.
    lab = app.test_client()
    lab.environ_base["REMOTE_ADDR"] = "10.0.7.1"
    form = lab.get("/console/login").get_data(as_text=True)
    fields = {"csrf_token": csrf_token_of(form), "username": USERNAME, "password": PASSWORD}
    assert lab.post("/console/login", data={**fields, "code": codes[0]}).status_code == 302


def test_enrolling_a_second_factor_ends_the_accounts_sessions(
    app, experimenter, console, monkeypatch
) -> None:
    assert console.get("/console/").status_code == 200
    _enrol(app, monkeypatch)
    assert console.get("/console/").status_code == 302  # signed out: sign in with the code


def test_ten_right_passwords_at_once_from_one_address_all_sign_in(app, experimenter) -> None:
    with serving(app) as base_url:
        browsers = [_browser(base_url, "127.0.5.200") for _ in range(10)]
        tokens = [csrf_token_of(b.get("/console/login").text) for b in browsers]
        start = threading.Barrier(10)

        def sign_in(number: int) -> int:
            form = {"csrf_token": tokens[number], "username": USERNAME, "password": PASSWORD}
            start.wait()
            return browsers[number].post("/console/login", data=form).status_code

        with ThreadPoolExecutor(10) as pool:
            statuses = list(pool.map(sign_in, range(10)))
        for browser in browsers:
            browser.close()
    assert statuses == [302] * 10
