"""A study server in the test's own process, on a clock the test moves.

The participant browser tests drive Chromium against waitress serving an app
whose live runner has a `ManualClock` and no thread of its own: time stands
still while the browser clicks, and `advance()` moves it and lets the runner
step. A two-minute trial takes as long as its simulation steps, not two
minutes, and nothing in a test depends on how fast the machine is.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flask import Flask
from waitress.server import create_server

from hcss.platform.bots.participant import ManualClock, bot_app
from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.live.runner import Runner
from hcss.platform.models import Participant
from hcss.platform.serving.connections import close_server
from hcss.platform.study import assign_cell


@dataclass
class StudyServer:
    url: str
    app: Flask
    database: Database
    #: The waitress server itself (its trigger, its task threads), for the harness's own tests.
    waitress: Any = None

    @property
    def runner(self) -> Runner:
        return self.app.extensions["hcss_runner"]

    @property
    def clock(self) -> ManualClock:
        return self.runner.clock

    def advance(self, wall_s: float) -> None:
        """Move the clock and let the runner step every live trial up to it."""
        self.clock.now += wall_s
        with self.app.app_context():
            self.runner.tick()

    def participant(self, **flags: bool) -> str:
        """A new participant enrolled in the server's study; returns the token."""
        with self.app.app_context(), self.database.session_scope() as session:
            participant = Participant(**flags)
            session.add(participant)
            session.flush()
            assign_cell(session, participant, override=1)
            return participant.token


@contextmanager
def study_server(tmp_path: Path, study: str = "demo", **config: Any) -> Iterator[StudyServer]:
    """The named study on a loopback port, its database built by the migrations."""
    url = f"sqlite:///{tmp_path / 'participant-browser.sqlite3'}"
    upgrade_database(url)
    app = bot_app(
        url,
        study,
        SECRET_KEY="test-secret",
        TIME_ACCELERATION=1.0,  # the manual clock is the acceleration
        STREAM_INTERVAL_S=0.1,
        **config,
    )
    server = create_server(app, host="127.0.0.1", port=0, threads=16)
    thread = threading.Thread(target=server.run, name="waitress-test", daemon=True)
    thread.start()
    try:
        yield StudyServer(
            f"http://127.0.0.1:{server.effective_port}", app, app.extensions["hcss_db"], server
        )
    finally:
        close_server(
            server, thread
        )  # tasks first, then the trigger pipe: hcss.platform.serving.connections
        app.extensions["hcss_db"].engine.dispose()
