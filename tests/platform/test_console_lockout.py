"""The sign-in lockout stops guessers without locking the experimenters out.

Walked as an attacker does: real HTTP to a running server for the burst,
CSRF tokens taken from the login form, any username typed.
"""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor

from click.testing import CliRunner

from hcss.platform.bots.http_load import HttpClient, LoadFigures
from hcss.platform.console.lockout import CLIENT_FAILURES, LoginThrottle
from tests.support.console import PASSWORD, USERNAME, sign_in
from tests.support.inprocess import serving
from tests.support.trials import csrf_token_of


def _attempt(app, username: str, password: str, address: str = "10.0.0.1", **headers: str):
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = address
    for name, value in headers.items():
        client.environ_base[f"HTTP_{name.upper()}"] = value
    return sign_in(client, username, password)


def test_the_console_still_works_after_five_failed_sign_ins_for_any_username(app, console) -> None:
    """A lockout's audit row used to hold text the index summed: /console/ answered 500."""
    for address in ("10.0.0.1", "10.0.0.2"):
        for _ in range(CLIENT_FAILURES):
            _attempt(app, "x", "y", address=address)
        assert _attempt(app, "x", "y", address=address).status_code == 429
    page = console.get("/console/")
    assert page.status_code == 200, page.get_data(as_text=True)[:300]
    assert "login_lockout" in page.get_data(as_text=True)
    assert console.get("/console/progress.json").status_code == 200


def test_a_burst_of_100_simultaneous_guesses_checks_at_most_the_allowed_passwords(
    app, experimenter
) -> None:
    """The failure is counted before the password is checked, so guesses sent at once
    cannot all slip in before the first is counted. The right one among them is refused
    once the lockout holds; before it, it signs in and takes back only its own count."""
    figures = LoadFigures(bots=100, concurrency=100)
    with serving(app) as base_url:
        clients, tokens = [], []
        for _ in range(100):
            client = HttpClient(base_url, figures)
            tokens.append(csrf_token_of(client.get("/console/login").get_data(as_text=True)))
            clients.append(client)
        start = threading.Barrier(100)

        def guess(number: int) -> int:
            password = PASSWORD if number == 60 else f"guess-{number}"
            start.wait()
            fields = {"csrf_token": tokens[number], "username": USERNAME, "password": password}
            return clients[number].post("/console/login", data=fields).status_code

        with ThreadPoolExecutor(100) as pool:
            statuses = list(pool.map(guess, range(100)))
    # At most the allowed wrong passwords are checked. The right one, in turn with the
    # guesses, signs in when its turn comes before the lockout, and is then no failure.
    assert statuses.count(401) <= CLIENT_FAILURES, sorted(statuses)
    assert set(statuses) <= {200, 401, 429} and statuses.count(200) <= 1, sorted(statuses)
    assert statuses[60] in (200, 429)
    assert statuses.count(429) >= 100 - CLIENT_FAILURES - statuses.count(200)


def test_the_right_password_from_another_client_works_while_one_client_is_locked_out(
    app, experimenter
) -> None:
    for _ in range(CLIENT_FAILURES):
        assert _attempt(app, USERNAME, "wrong", address="10.6.6.6").status_code == 401
    assert _attempt(app, USERNAME, PASSWORD, address="10.6.6.6").status_code == 429
    assert _attempt(app, USERNAME, PASSWORD, address="10.7.7.7").status_code == 302


def test_guessing_many_usernames_from_one_address_does_not_lock_the_real_account_there(
    app, experimenter
) -> None:
    for number in range(21):  # the old per-address limit was 20
        assert _attempt(app, f"user{number}", "wrong", address="10.6.6.6").status_code == 401
    assert _attempt(app, USERNAME, PASSWORD, address="10.6.6.6").status_code == 302


def test_forwarded_for_is_ignored_unless_a_proxy_is_configured(app, experimenter) -> None:
    """Behind no configured proxy a forged X-Forwarded-For cannot make a guesser a new client."""
    for number in range(CLIENT_FAILURES):
        forged = {"X_FORWARDED_FOR": f"192.0.2.{number}"}
        assert _attempt(app, USERNAME, "wrong", **forged).status_code == 401
    forged = {"X_FORWARDED_FOR": "192.0.2.99"}
    assert _attempt(app, USERNAME, PASSWORD, **forged).status_code == 429


def test_behind_a_configured_proxy_each_visitor_is_their_own_client(database_url) -> None:
    """Behind the proxy every visitor has the proxy's address; one guesser must not lock all."""
    from hcss.platform.app import create_app
    from hcss.platform.console.accounts import create_experimenter

    app = create_app(
        {
            "DATABASE_URL": database_url,
            "SECRET_KEY": "test-secret",
            "TESTING": True,
            "PROXY_HOPS": 1,
        }
    )
    app.extensions["hcss_db"].create_all()
    with app.extensions["hcss_db"].session_scope() as session:
        create_experimenter(session, USERNAME, PASSWORD)
    try:
        proxy = "127.0.0.1"
        for _ in range(CLIENT_FAILURES):
            guess = _attempt(app, USERNAME, "x", address=proxy, X_FORWARDED_FOR="203.0.113.9")
            assert guess.status_code == 401
        locked = _attempt(app, USERNAME, PASSWORD, address=proxy, X_FORWARDED_FOR="203.0.113.9")
        assert locked.status_code == 429
        lab = _attempt(app, USERNAME, PASSWORD, address=proxy, X_FORWARDED_FOR="198.51.100.4")
        assert lab.status_code == 302
    finally:
        app.extensions["hcss_runner"].stop()
        app.extensions["hcss_db"].engine.dispose()


def test_hcss_admin_unlock_lets_a_locked_out_experimenter_sign_in(
    app, experimenter, monkeypatch
) -> None:
    from hcss.cli import main as cli

    for _ in range(CLIENT_FAILURES):
        _attempt(app, USERNAME, "wrong")
    assert _attempt(app, USERNAME, PASSWORD).status_code == 429
    monkeypatch.setenv("DATABASE_URL", app.config["DATABASE_URL"])
    result = CliRunner().invoke(cli, ["admin", "unlock", USERNAME])
    assert result.exit_code == 0, result.output
    assert "unlocked" in result.output
    assert _attempt(app, USERNAME, PASSWORD).status_code == 302


def test_an_allow_listed_address_signs_in_during_a_lockout_of_that_address(
    app, experimenter
) -> None:
    app.config["CONSOLE_ALLOW"] = ["10.1.0.0/16"]
    for _ in range(CLIENT_FAILURES):
        _attempt(app, USERNAME, "wrong", address="10.1.2.3")
    assert _attempt(app, USERNAME, PASSWORD, address="10.1.2.3").status_code == 302


def test_a_right_password_in_a_burst_does_not_reset_the_count_of_the_guesses_behind_it(
    app,
) -> None:
    """Sign-ins of one (account, client) take turns, so a right password among a burst of
    guesses used to clear the count before the guesses behind it were counted: a burst with
    the right password early in it had 9 passwords checked, not at most 5. A person signs in
    once at a time; a success resets the count only when no other sign-in waits its turn."""
    throttle = LoginThrottle(app.extensions["hcss_db"])
    for _ in range(2):
        throttle.begin(USERNAME, "10.0.0.9")
    waiting, inside = threading.Event(), threading.Event()

    def behind() -> None:
        inside.wait()
        waiting.set()
        with throttle.in_turn(USERNAME, "10.0.0.9"):
            pass

    other = threading.Thread(target=behind)
    other.start()
    with throttle.in_turn(USERNAME, "10.0.0.9"):
        right = throttle.begin(USERNAME, "10.0.0.9")
        inside.set()
        waiting.wait()
        time.sleep(0.2)  # the other sign-in is now waiting for this turn
        throttle.succeeded(right)
    other.join()
    counted = [throttle.begin(USERNAME, "10.0.0.9") for _ in range(4)]
    assert [a.failures for a in counted] == [3, 4, 5, 0] and counted[-1].wait_s > 0
    # Alone, the right password still means this client never failed.
    throttle.unlock(USERNAME)
    for _ in range(2):
        throttle.begin(USERNAME, "10.0.0.9")
    with throttle.in_turn(USERNAME, "10.0.0.9"):
        throttle.succeeded(throttle.begin(USERNAME, "10.0.0.9"))
    assert throttle.begin(USERNAME, "10.0.0.9").failures == 1
