"""Processes of one group on one database, for lease tests: apps whose runners share a clock.

Each app stands for one `hcss serve --cluster` process (its `PROCESS_NAME`), with
no runner thread: a test ticks the runners on the shared `ManualClock`, so a
lease runs out when the test moves the clock past it.
"""

from __future__ import annotations

import pytest
from flask import Flask
from sqlalchemy import select

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.db import Database
from hcss.platform.live.runner import Runner
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.models import TrialLease
from hcss.platform.serving.localserver import LocalNginx, LocalServer, as_group

LEASE_S = 6.0


def leased_process(
    database_url: str, name: str | None, clock: ManualClock, group: tuple[str, ...] = ()
) -> Flask:
    """One process of the group, named `name`, its runner on `clock`; `group`: the members'
    addresses as nginx lists them (HCSS_GROUP), for placement (none: no placement)."""
    app = create_app(
        {
            "DATABASE_URL": database_url,
            "SECRET_KEY": "test-secret",
            "TESTING": True,
            "LIVE_RUNNER": False,
            "SNAPSHOT_INTERVAL_S": 1.0,
            "PROCESS_NAME": name,
            "LEASE_S": LEASE_S,
            "GROUP_MEMBERS": list(group),
        }
    )
    app.extensions["hcss_runner"].clock = clock
    return app


def start_trial_on(runner: Runner, duration_s: float = 600.0) -> int:
    """A bot participant's trial, started in the group's database; its id."""
    with runner.database.session_scope() as session:
        _, trial = start_bot_trial(session, seed=2, duration_s=duration_s)
        return trial.id


def skip_unless_group(database_url: str) -> str:
    """PostgreSQL for a group of processes behind nginx; a clear skip otherwise."""
    if not database_url.startswith("postgresql"):
        pytest.skip("several server processes share PostgreSQL; SQLite serves one process")
    if not LocalNginx.available():
        pytest.skip(f"needs nginx at {LocalNginx.BINARY} (scripts/ensure-nginx installs it)")
    return database_url


def lease_owner(database: Database, trial_id: int) -> str | None:
    with database.session_scope() as session:
        return session.scalar(select(TrialLease.owner).where(TrialLease.trial_id == trial_id))


def two_cluster_processes(
    database_url: str, tmp_path, extra_env: dict[str, str] | None = None
) -> list[LocalServer]:
    """Two `hcss serve --cluster` processes of one group (not started), on two loopback
    addresses, snapshotting every second, each told the group (HCSS_GROUP) in the order
    `LocalNginx` lists them."""
    servers = [
        LocalServer(
            database_url,
            tmp_path / name,
            snapshot_interval_s=1.0,
            serve_args=["--cluster"],
            host=address,
            extra_env=dict(extra_env or {}),
        )
        for name, address in (("a", "127.0.0.2"), ("b", "127.0.0.3"))
    ]
    return as_group(servers)
