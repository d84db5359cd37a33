"""Fixtures for the platform tests: a database per test, on SQLite and PostgreSQL.

Every test that takes `database_url` (directly or through `app`) runs on a
fresh SQLite file, and again on PostgreSQL when HCSS_TEST_DATABASE_URL is set
(e.g. postgresql+psycopg://postgres@127.0.0.1:5432/test). On PostgreSQL each
test gets its own schema, dropped afterwards, so parallel test sessions and
other engineers' databases never collide.

Live trials run on a fake clock: `TrialHandle.run_to(seconds)` moves the
wall clock and lets the runner step, so a 20-minute trial takes a second.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

import pytest
from flask import Flask

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.serving.localserver import postgres_schema
from tests.support.databases import PG_ENV
from tests.support.trials import STUDY, TrialHandle


@pytest.fixture(params=["sqlite", "postgresql"])
def database_url(request: pytest.FixtureRequest, tmp_path) -> Iterator[str]:
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'hcss-test.sqlite3'}"
        return
    base = os.environ.get(PG_ENV)
    if not base:
        pytest.skip(f"PostgreSQL tests need {PG_ENV}")
    # Commits need not wait for the disk in a test database: about 4x faster on
    # PostgreSQL's write-heavy tests, with the same visibility and isolation.
    with postgres_schema(base, "hcss_test", options="-csynchronous_commit=off") as url:
        yield url


@pytest.fixture
def app(database_url: str) -> Iterator[Flask]:
    app = create_app(
        {
            "DATABASE_URL": database_url,
            "SECRET_KEY": "test-secret",
            "TESTING": True,
            "LIVE_RUNNER": False,  # tests drive runner.tick() on a fake clock
            "SNAPSHOT_INTERVAL_S": 5.0,  # seconds of the fake wall clock
        }
    )
    app.extensions["hcss_db"].create_all()
    app.extensions["hcss_runner"].clock = ManualClock(0.0)
    yield app
    app.extensions["hcss_runner"].stop()
    app.extensions["hcss_db"].engine.dispose()


@pytest.fixture
def make_trial(app: Flask):
    """Start a trial for a new participant: make_trial(seed=2, model="M1", kind="trial").

    Unless told otherwise it is the original study's trial: its length and its simulation
    preset (the study file names one, which need not be the simulation's default);
    `preset=None` starts it as start_trial does when no preset is named.
    """

    def make(**options: Any) -> TrialHandle:
        options.setdefault("seed", 2)
        if "preset" not in options:
            options["preset"] = STUDY.simulation.preset
        elif options["preset"] is None:
            del options["preset"]
        training = options.get("kind") == "training"
        options.setdefault(
            "duration_s", STUDY.timing.training_s if training else STUDY.timing.trial_s
        )
        database = app.extensions["hcss_db"]
        with database.session_scope() as session:
            participant, trial = start_bot_trial(session, **options)
            handle = TrialHandle(
                app=app,
                client=app.test_client(),
                token=participant.token,
                trial_id=trial.id,
                started_epoch=trial.started_at.timestamp(),
                acceleration=trial.time_acceleration,
            )
        handle.run_to(0.0)
        handle.open_page()
        return handle

    return make
