"""Fixtures and helpers for the console and export tests.

The fixtures (`experimenter`, `console`, `console_app`) are registered for the whole suite
by tests/conftest.py (`pytest_plugins`): a test names them, never imports them.
"""

from __future__ import annotations

import functools
import re
import sqlite3
import threading
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import pytest
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import Table, event, select
from waitress.server import create_server

from hcss.platform.bots.participant import bot_app
from hcss.platform.cli import upgrade_database
from hcss.platform.console.accounts import hash_password
from hcss.platform.models import Base, Experimenter, Participant
from hcss.platform.serving.connections import close_server
from tests.support.trials import csrf_token_of

USERNAME = "alice"
PASSWORD = "correct horse battery"


@functools.cache
def _password_hash() -> str:
    """The account's argon2 hash, with the server's own parameters, made once per test
    process: each hash costs 0.15 s of both cores (more on a loaded machine), and 212
    tests make this same account. Signing in still verifies it as for any account."""
    return hash_password(PASSWORD)


def add_account(app: Flask) -> tuple[str, str]:
    """The console account tests sign in with, stored as `create_experimenter` stores one
    (a username and the password's hash); its username and password."""
    with app.extensions["hcss_db"].session_scope() as session:
        session.add(Experimenter(username=USERNAME, password_hash=_password_hash()))
    return USERNAME, PASSWORD


@pytest.fixture
def experimenter(app: Flask) -> tuple[str, str]:
    return add_account(app)


@dataclass
class Console:
    """A signed-in experimenter's browser: it keeps the CSRF token pages carry."""

    app: Flask
    client: FlaskClient
    csrf: str = ""

    def get(self, path: str, **options: Any):
        response = self.client.get(path, **options)
        text = response.get_data(as_text=True) if response.mimetype == "text/html" else ""
        if 'name="csrf-token"' in text:
            self.csrf = csrf_token_of(text)
        return response

    def post(self, path: str, fields: dict[str, Any] | None = None):
        return self.client.post(path, data={"csrf_token": self.csrf, **(fields or {})})

    def act(self, code: str, action: str):
        return self.post(f"/console/participants/{code}/{action}")

    def progress(self) -> dict[str, dict[str, Any]]:
        response = self.client.get("/console/progress.json")
        assert response.status_code == 200
        return {row["code"]: row for row in response.get_json()["participants"]}


def sign_in(client: FlaskClient, username: str, password: str):
    page = client.get("/console/login")
    return client.post(
        "/console/login",
        data={
            "csrf_token": csrf_token_of(page.get_data(as_text=True)),
            "username": username,
            "password": password,
        },
    )


@pytest.fixture
def console(app: Flask, experimenter: tuple[str, str]) -> Iterator[Console]:
    client = app.test_client()
    response = sign_in(client, *experimenter)
    assert response.status_code == 302, response.get_data(as_text=True)
    signed_in = Console(app=app, client=client)
    signed_in.get("/console/")
    yield signed_in


def code_of(app: Flask, token: str) -> str:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalars(select(Participant.code).where(Participant.token == token)).one()


def rows_referencing(session, participant_id: int) -> dict[str, int]:
    """Rows of each table reached from the participant through foreign keys.

    Written independently of the withdrawal module: it loads every table and
    follows each foreign key in Python, parents before children.
    """
    owned: dict[str, set[Any]] = {}
    counts: dict[str, int] = {}
    for table in Base.metadata.sorted_tables:
        rows = session.execute(select(table)).mappings().all()
        if table.name == "participant":
            mine = [r for r in rows if r["id"] == participant_id]
        else:
            mine = [r for r in rows if _reaches(table, r, owned)]
        if table.name == "participant" or mine or _has_path(table, owned):
            counts[table.name] = len(mine)
            owned[table.name] = {r["id"] for r in mine}
    return counts


def _has_path(table: Table, owned: dict[str, set[Any]]) -> bool:
    return any(fk.column.table.name in owned for fk in table.foreign_keys)


def _reaches(table: Table, row: Any, owned: dict[str, set[Any]]) -> bool:
    return any(
        fk.column.table.name in owned and row[fk.parent.name] in owned[fk.column.table.name]
        for fk in table.foreign_keys
    )


def cells_containing(session, needle: str, skip: tuple[str, ...] = ()) -> list[str]:
    """`table.column` of every cell whose text contains `needle` (JSON included)."""
    found = []
    for table in Base.metadata.sorted_tables:
        if table.name in skip:
            continue
        for row in session.execute(select(table)).mappings():
            for column, value in row.items():
                if value is not None and needle in str(value):
                    found.append(f"{table.name}.{column}")
    return found


CODE_PATTERN = re.compile(r"P[0-9A-F]{12}")


def play_trial(trial: Any, until_s: float) -> None:  # TrialHandle
    """A scripted operator: requests (accepted and refused), clicks and probe answers.

    Runs the trial second by second so probes appear, get answered or time
    out, and collectives complete decisions, as in a real session.
    """
    trial.run_to(20.0)
    view = trial.state()["view"]
    in_range = [t["id"] for t in view["targets"] if 0 in t["in_range_of"]]
    if in_range:
        trial.post("/requests", {"kind": "investigate", "collective": 0, "target": in_range[0]})
    # Refused: a target too few of collective II favour (or, with none visible, undiscovered).
    weak = next((t["id"] for t in view["targets"] if t["support"][1] < 0.3), None)
    shown = {t["id"] for t in view["targets"]}
    weak = weak if weak is not None else min(set(range(1, len(shown) + 2)) - shown)
    assert (
        trial.post("/requests", {"kind": "decide", "collective": 1, "target": weak}).status_code
        == 200
    )
    trial.post("/observations", {"kind": "collective", "collective": 2, "button": "right"})
    if view["targets"]:
        trial.post(
            "/observations",
            {"kind": "target", "target": view["targets"][0]["id"], "button": "left"},
        )
    answered = 0
    second = 20.0
    while second + 2.0 < until_s:
        second += 2.0
        trial.run_to(second)
        probe = trial.state()["probe"]
        if probe and answered < 3:  # answer a few, leave the rest to time out
            trial.post(f"/probes/{probe['id']}/ready", {})
            choices = trial.state()["probe"]["choices"]
            trial.post(f"/probes/{probe['id']}/answer", {"answer": choices[0]})
            answered += 1
    trial.run_to(until_s)  # the time limit ends the trial


def open_replay(browser, url: str, code: str, trial_id: int, viewport: dict[str, int]):
    """Sign in to the console as the test experimenter and open one trial's replay: the page."""
    page = browser.new_page(viewport=viewport)
    page.goto(f"{url}/console/login")
    page.get_by_label("Username").fill(USERNAME)
    page.get_by_label("Password").fill(PASSWORD)
    page.get_by_role("button", name="Sign in").click()
    page.goto(f"{url}/console/participants/{code}")
    page.locator(f'tr[data-trial="{trial_id}"] a.replay-link').click()
    return page


@contextmanager
def statements(app) -> Iterator[Counter[str]]:
    """SQL statements sent while the block runs, counted under "all"."""
    counts: Counter[str] = Counter()

    def count(*_args) -> None:
        counts["all"] += 1

    engine = app.extensions["hcss_db"].engine
    event.listen(engine, "before_cursor_execute", count)
    try:
        yield counts
    finally:
        event.remove(engine, "before_cursor_execute", count)


#: Columns 0011_second_factor adds, later than every revision these tests stop at.
SECOND_FACTOR_COLUMNS = {
    ("experimenter", "totp_secret"),
    ("experimenter", "totp_last_step"),
    ("experimenter", "recovery_hashes"),
}
#: The unique keys of a trial's rows, added by i29_unique_trial_rows (later than these tests).
UNIQUE_TRIAL_KEYS = {
    "uq_decision_trial",
    "uq_sim_event_trial",
    "uq_probe_trial",
    "uq_probe_event_probe",
    "uq_request_status_change_trial",
    "uq_interruption_trial",
}


@pytest.fixture
def console_app(tmp_path):
    """The app (bots' clock, no runner thread) served by waitress in this process."""
    url = f"sqlite:///{tmp_path / 'console-browser.sqlite3'}"
    upgrade_database(url)
    # The table polls every 0.3 s here (2 s by default), so a fast bot's stages all show.
    app = bot_app(url, "original", SECRET_KEY="console-browser-secret", CONSOLE_POLL_S=0.3)
    add_account(app)
    server = create_server(app, host="127.0.0.1", port=0, threads=8)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    yield app, f"http://127.0.0.1:{server.effective_port}"
    close_server(server, thread)
    app.extensions["hcss_db"].engine.dispose()


def sign_in_page(page, base: str) -> None:
    """The experimenter signs in and lands on the live table."""
    from playwright.sync_api import expect

    page.goto(f"{base}/console/")
    page.fill("#username", USERNAME)
    page.fill("#password", PASSWORD)
    page.click("button[type=submit]")
    expect(page.locator("h1")).to_have_text("Participants")


@contextmanager
def writers_held(database: Any) -> Iterator[None]:
    """Another writer holding the database for a moment, as on a loaded lab server: SQLite's
    write lock, or on PostgreSQL a lock on `console_form` that lets reads through and makes
    its inserts wait."""
    engine = database.engine
    if engine.dialect.name == "sqlite":
        holder = sqlite3.connect(engine.url.database, isolation_level=None)
        holder.execute("BEGIN IMMEDIATE")
        try:
            yield
        finally:
            holder.execute("ROLLBACK")
            holder.close()
        return
    with engine.connect() as holder:
        holder.exec_driver_sql("LOCK TABLE console_form IN EXCLUSIVE MODE")
        try:
            yield
        finally:
            holder.rollback()
