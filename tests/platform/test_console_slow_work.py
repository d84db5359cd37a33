"""Issue 44 §1: no request holds a transaction open across slow work, and a connection the
database server ended is "database away" (503 with Retry-After), never a 500.

PostgreSQL ends a transaction left idle longer than `db.IDLE_IN_TRANSACTION_MS` (5 s) and
closes its connection (SQLSTATE 25P03). A loaded machine stretched an argon2 check, ten
recovery-code checks or a wait on the sign-in throttle past that inside a request's read:
40 wrong-password sign-ins at once gave 5 × 500. Here the limit is lowered to a fraction of
an argon2 check, so the same slow work overruns it on any machine; on SQLite (no such limit)
the same sign-ins run as a control.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator

import pytest
from flask import Flask
from sqlalchemy import select

from hcss.platform import db
from hcss.platform.console import accounts, second_factor
from hcss.platform.models import Experimenter
from tests.support.console import PASSWORD, USERNAME
from tests.support.inprocess import serving
from tests.support.second_factor import enrol as _enrol
from tests.support.second_factor import sign_ins_at_once
from tests.support.trials import csrf_token_of

#: Milliseconds: below an argon2 check among 40 at once on 2 cores (seconds), far above
#: the gap between two statements of a unit of work.
SHORT_IDLE_MS = 2500


@pytest.fixture
def short_idle(app: Flask, monkeypatch) -> Iterator[Flask]:
    """The app with PostgreSQL's idle-in-transaction limit lowered (new connections)."""
    monkeypatch.setattr(db, "IDLE_IN_TRANSACTION_MS", SHORT_IDLE_MS)
    app.extensions["hcss_db"].engine.dispose()
    yield app


def test_no_connection_is_held_while_a_password_or_a_code_is_checked(
    app, experimenter, monkeypatch
) -> None:
    """Every argon2 check of a sign-in (the password, the dummy hash, ten recovery codes)
    runs with none of the pool's connections checked out, on both databases."""
    _, codes = _enrol(app, monkeypatch)
    pool = app.extensions["hcss_db"].engine.pool
    held: list[int] = []

    def counting(check: Callable[[str, str], bool]) -> Callable[[str, str], bool]:
        def checked(stored: str, typed: str) -> bool:
            held.append(pool.checkedout())
            return check(stored, typed)

        return checked

    monkeypatch.setattr(accounts, "password_matches", counting(accounts.password_matches))
    monkeypatch.setattr(second_factor, "password_matches", counting(second_factor.password_matches))
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = "10.0.44.1"
    attempts = [
        ("nobody", "some password", ""),
        (USERNAME, "wrong password", ""),
        (USERNAME, PASSWORD, "00000-00000"),
        (USERNAME, PASSWORD, codes[3]),
    ]
    statuses = []
    for username, password, code in attempts:
        token = csrf_token_of(client.get("/console/login").get_data(as_text=True))
        fields = {"csrf_token": token, "username": username, "password": password, "code": code}
        statuses.append(client.post("/console/login", data=fields).status_code)
    assert statuses == [401, 401, 401, 302]
    assert len(held) >= 4 + 2 * second_factor.RECOVERY_CODES
    assert set(held) == {0}, held


@pytest.mark.slow
def test_forty_wrong_password_sign_ins_at_once_answer_no_500(short_idle, experimenter) -> None:
    """The issue's acceptance: 40 wrong passwords from 40 addresses at once, no 500 (39 of
    40 before the fix). At a load of 30 on 2 cores (other test sessions) a thread once waited
    longer than the lowered limit between two statements of the throttle's count: that
    answers 503 with Retry-After, the database being away for it, and is allowed rarely."""
    with serving(short_idle) as base_url:
        statuses = sign_ins_at_once(
            base_url, 40, lambda _: {"password": "wrong password"}, subnet="127.0.6", timeout=120.0
        )
    assert statuses.count(500) == 0, statuses
    assert set(statuses) <= {401, 503}, statuses
    assert statuses.count(401) >= 36, statuses


@pytest.mark.slow
def test_one_recovery_code_in_twenty_sign_ins_at_once_answers_no_500(
    short_idle, experimenter, monkeypatch
) -> None:
    """Ten argon2 checks per sign-in were made inside the unit of work that took the code."""
    _, codes = _enrol(short_idle, monkeypatch)
    short_idle.extensions["hcss_db"].engine.dispose()
    with serving(short_idle) as base_url:
        statuses = sign_ins_at_once(
            base_url,
            20,
            lambda _: {"password": PASSWORD, "code": codes[0]},
            subnet="127.0.6",
            timeout=120.0,
        )
    assert statuses.count(500) == 0, statuses
    assert statuses.count(302) == 1, statuses
    with short_idle.extensions["hcss_db"].session_scope() as session:
        left = session.scalar(select(Experimenter.recovery_hashes))
    assert len(left or []) == second_factor.RECOVERY_CODES - 1


def test_a_transaction_the_server_ended_answers_503_with_retry_after(short_idle) -> None:
    """Slow work inside a request's read (here a sleep past the limit, as a loaded machine
    gives) meets a connection PostgreSQL closed (25P03): the database is away, not a bug."""
    if not short_idle.config["DATABASE_URL"].startswith("postgresql"):
        pytest.skip("SQLite ends no idle transaction")

    @short_idle.get("/slow-read")
    def slow_read() -> str:
        session = db.get_session()
        session.scalar(select(Experimenter.id))
        time.sleep(3 * SHORT_IDLE_MS / 1000)
        session.scalar(select(Experimenter.id))
        return "read"

    answer = short_idle.test_client().get("/slow-read")
    assert answer.status_code == 503
    assert answer.headers["Retry-After"] == "5"


def test_a_page_after_a_swallowed_lost_connection_still_renders(app) -> None:
    """Found by the chaos soak (seed 44, 30 min): an error page looked the participant up,
    the connection had been ended by the server (57P01, the run's sessions ended), the
    lookup's error was swallowed, and ending the request's read before the page raised
    PendingRollbackError: a 500 instead of the please-wait page."""
    if not app.config["DATABASE_URL"].startswith("postgresql"):
        pytest.skip("the server ends the connection: PostgreSQL's pg_terminate_backend")
    from flask import render_template
    from sqlalchemy import text
    from sqlalchemy.exc import OperationalError

    @app.get("/lost-then-page")
    def lost_then_page() -> str:
        session = db.get_session()
        session.scalar(select(Experimenter.id))
        # Swallowed, as errors.participant_token does: the database may be what failed.
        with contextlib.suppress(OperationalError):
            session.execute(text("SELECT pg_terminate_backend(pg_backend_pid())"))
        return render_template("error.html", code=503, heading="h", detail=None, advice="a")

    answer = app.test_client().get("/lost-then-page")
    assert answer.status_code == 200, answer.status_code


def test_no_connection_is_held_while_a_new_account_s_password_is_hashed(app, monkeypatch) -> None:
    """A new account's argon2 hash (the first start's console login, `hcss admin create`)
    runs before its unit of work takes a connection: it was made after the "is the name
    taken" read, inside its transaction (and the first login's inside the "no account yet"
    count), so a loaded machine could let PostgreSQL end that transaction (25P03)."""
    database = app.extensions["hcss_db"]
    pool = database.engine.pool
    held: list[int] = []
    hash_password = accounts.hash_password

    def counting(password: str) -> str:
        held.append(pool.checkedout())
        return hash_password(password)

    monkeypatch.setattr(accounts, "hash_password", counting)
    first = accounts.ensure_first_login(app)  # the first start on an empty database
    assert first is not None
    with database.command_scope() as session:  # as `hcss admin create` does
        accounts.create_experimenter(session, "second", "another long password")
    assert len(held) == 2 and set(held) == {0}, held
    with database.session_scope() as session:
        names = set(session.scalars(select(Experimenter.username)))
    assert names == {first[0], "second"}
    with database.session_scope() as session, pytest.raises(accounts.AccountError):
        accounts.create_experimenter(session, "second", "yet another password")  # taken
