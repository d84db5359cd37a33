"""Processes of one group on one database, for lease tests: apps whose runners share a clock.

Each app stands for one `hcss serve --cluster` process (its `PROCESS_NAME`), with
no runner thread: a test ticks the runners on the shared `ManualClock`, so a
lease runs out when the test moves the clock past it.
"""

from __future__ import annotations

from flask import Flask

from hcss.platform.app import create_app
from hcss.platform.bots import ManualClock
from hcss.platform.live.runner import Runner
from hcss.platform.live.trials import start_bot_trial

LEASE_S = 6.0


def leased_process(database_url: str, name: str | None, clock: ManualClock) -> Flask:
    """One process of the group, named `name`, its runner on `clock`."""
    app = create_app(
        {
            "DATABASE_URL": database_url,
            "SECRET_KEY": "test-secret",
            "TESTING": True,
            "LIVE_RUNNER": False,
            "SNAPSHOT_INTERVAL_S": 1.0,
            "PROCESS_NAME": name,
            "LEASE_S": LEASE_S,
        }
    )
    app.extensions["hcss_runner"].clock = clock
    return app


def start_trial_on(runner: Runner, duration_s: float = 600.0) -> int:
    """A bot participant's trial, started in the group's database; its id."""
    with runner.database.session_scope() as session:
        _, trial = start_bot_trial(session, seed=2, duration_s=duration_s)
        return trial.id
