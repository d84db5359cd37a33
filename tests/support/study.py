"""Fixtures and helpers for the study-flow tests (test_study_*.py).

The fixtures (`study_app`, `demo_app`, `demo_bot_app`) are registered for the whole suite by
tests/conftest.py (`pytest_plugins`): a test names them, never imports them.

They build on the live engineer's `database_url` fixture (tests/platform/
conftest.py), so every test runs on SQLite and, with HCSS_TEST_DATABASE_URL,
on PostgreSQL. The runner's clock is a `ManualClock` at the real time: stage
deadlines and trials share it, and a test moves it to jump ahead.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import pytest
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import select

from hcss.platform.bots.participant import (
    BotReport,
    ManualClock,
    PageParser,
    ParticipantBot,
    bot_app,
    parse_page,
)
from hcss.platform.models import Participant, StageEvent
from hcss.platform.study import assign_cell


def make_app(database_url: str, study: str = "original", now: float | None = None) -> Flask:
    app = bot_app(database_url, study, SECRET_KEY="test-secret", TESTING=True)
    app.extensions["hcss_db"].create_all()
    if now is not None:
        app.extensions["hcss_runner"].clock = ManualClock(now)
    return app


@pytest.fixture
def study_app(database_url: str) -> Iterator[Flask]:
    app = make_app(database_url)
    yield app
    app.extensions["hcss_db"].engine.dispose()


@pytest.fixture
def demo_app(database_url: str) -> Iterator[Flask]:
    app = make_app(database_url, "demo")
    yield app
    app.extensions["hcss_db"].engine.dispose()


def new_participant(app: Flask, *, cell: int | None = None, **flags: bool) -> str:
    """A participant enrolled in the app's study; returns the token."""
    with app.app_context():
        database = app.extensions["hcss_db"]
        with database.session_scope() as session:
            participant = Participant(**flags)
            session.add(participant)
            session.flush()
            assign_cell(session, participant, override=cell)
            return participant.token


@dataclass
class Visitor:
    """A participant's browser on the study pages."""

    app: Flask
    token: str
    client: FlaskClient

    @property
    def clock(self) -> ManualClock:
        return self.app.extensions["hcss_runner"].clock

    def page(self) -> PageParser:
        response = self.client.get(f"/p/{self.token}", follow_redirects=True)
        assert response.status_code == 200, response.status_code
        self.html = response.get_data(as_text=True)
        return parse_page(self.html)

    def submit(self, fields: dict[str, Any], page: PageParser | None = None) -> Any:
        """POST the current page's form with these answers (and its hidden fields)."""
        page = page or self.page()
        response = self.client.post(page.action, data=dict(page.hidden) | fields)
        self.html = response.get_data(as_text=True)
        return response

    def advance(self, wall_s: float) -> None:
        self.clock.now += wall_s
        self.app.extensions["hcss_runner"].tick()


def visitor(app: Flask, token: str) -> Visitor:
    return Visitor(app, token, app.test_client())


def events(app: Flask, token: str) -> list[StageEvent]:
    with app.app_context():
        database = app.extensions["hcss_db"]
        with database.session_scope() as session:
            participant = session.scalars(
                select(Participant).where(Participant.token == token)
            ).one()
            return list(
                session.scalars(
                    select(StageEvent)
                    .where(StageEvent.participant_id == participant.id)
                    .order_by(StageEvent.id)
                )
            )


def errors_in(html: str) -> list[str]:
    return re.findall(r'<p class="error"[^>]*role="alert"[^>]*>([^<]+)</p>', html)


@pytest.fixture
def demo_bot_app(database_url: str):
    """The demo study on a clock the bot moves (bot_app), with its schema."""
    app = bot_app(database_url, "demo")
    app.extensions["hcss_db"].create_all()
    yield app
    app.extensions["hcss_db"].engine.dispose()


def walk_to(v: Visitor, stage: str, step: str) -> PageParser:
    """Drive a participant with the bot's answers until the page is `stage`/`step`."""
    bot = ParticipantBot(v.app, v.token, seed=5)
    bot.client = v.client
    report = BotReport(code="")
    while True:
        page = v.page()
        if (page.stage, page.step) == (stage, step):
            return page
        if page.interface:
            bot.supervise(page, page.interface and trial_kind(v), report)
        else:
            bot.act(page, report)


def trial_kind(v: Visitor) -> str:
    return "training" if "<strong>Training</strong>" in v.html else "trial"
