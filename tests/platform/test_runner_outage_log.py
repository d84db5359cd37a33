"""Issue 44: while the database takes no writes, the live runner logs one line, not tracebacks.

The request path already logs an outage as one WARNING line ("database away ..."); the
runner did not. In the chaos soak's read-only windows each process's runner logged a full
traceback for every trial it tried to take up, every second ("could not load live trial
N", 64 and 65 in two minutes), and one more for each trial whose clock stopped. Here a
process of a group (leases on) meets a database that refuses writes for real: SQLite's
disk remounted read-only, PostgreSQL's sessions read-only by default.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from flask import Flask
from sqlalchemy import event

from hcss.platform.bots.participant import ManualClock
from hcss.platform.live.placement import address_of
from tests.support.leases import leased_process, start_trial_on
from tests.support.own_disk import OwnDisk, own_disk


@contextmanager
def _process(database_url: str, tmp_path) -> Iterator[tuple[Flask, OwnDisk | None]]:
    """A group's process on the database; SQLite's file on a disk the test can make read-only."""
    clock = ManualClock(1_000_000.0)
    name = "127.0.0.1:5001/a"
    group = (address_of(name),)  # a group of one: its home for every trial
    if not database_url.startswith("sqlite"):
        app = leased_process(database_url, name, clock, group)
        yield app, None
        app.extensions["hcss_db"].engine.dispose()
        return
    with own_disk(tmp_path) as disk:
        app = leased_process(f"sqlite:///{disk.path / 'hcss.sqlite3'}", name, clock, group)
        yield app, disk
        app.extensions["hcss_db"].engine.dispose()


@contextmanager
def _read_only(app: Flask, disk: OwnDisk | None) -> Iterator[None]:
    engine = app.extensions["hcss_db"].engine
    engine.dispose()
    if disk is not None:
        disk.read_only()
        try:
            yield
        finally:
            disk.writable()
            engine.dispose()
        return

    def read_only(dbapi_connection, _record) -> None:
        with dbapi_connection.cursor() as cursor:
            cursor.execute("SET default_transaction_read_only = on")
        dbapi_connection.commit()

    event.listen(engine, "connect", read_only)
    try:
        yield
    finally:
        event.remove(engine, "connect", read_only)
        engine.dispose()


def _said(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    return [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_trials_not_taken_up_while_the_database_is_read_only_are_one_warning_per_sync(
    database_url, tmp_path, caplog
) -> None:
    with _process(database_url, tmp_path) as (app, disk):
        app.extensions["hcss_db"].create_all()
        runner = app.extensions["hcss_runner"]
        trials = [start_trial_on(runner) for _ in range(4)]
        caplog.clear()
        with caplog.at_level(logging.INFO), _read_only(app, disk):
            for _ in range(3):  # three syncs, each finding four trials nobody hosts
                runner.clock.now += 1.5
                runner.tick()
            assert runner.loaded_ids() == set()
        said = _said(caplog)
        assert not [r for r in said if r.exc_info], [r.getMessage()[:160] for r in said]
        assert len(said) == 1, [r.getMessage()[:160] for r in said]  # one outage, one line
        assert all("database" in r.getMessage() and "\n" not in r.getMessage() for r in said)
        for _ in range(len(trials)):  # writable again: every trial is taken up (in batches)
            runner.clock.now += 1.5
            runner.tick()
        assert runner.loaded_ids() == set(trials)


def test_a_trial_whose_clock_stops_for_a_read_only_database_says_so_in_one_line(
    database_url, tmp_path, caplog
) -> None:
    with _process(database_url, tmp_path) as (app, disk):
        app.extensions["hcss_db"].create_all()
        runner = app.extensions["hcss_runner"]
        trial_id = start_trial_on(runner)
        runner.clock.now += 1.5
        runner.tick()
        assert runner.loaded_ids() == {trial_id}
        caplog.clear()
        with caplog.at_level(logging.INFO), _read_only(app, disk):
            for _ in range(3):  # a snapshot is due every second: the runner writes
                runner.clock.now += 1.1
                runner.tick()
            live = runner.loaded(trial_id)
            assert live is not None and live.trial_clock.database_away_since is not None
        said = _said(caplog)
        assert not [r for r in said if r.exc_info], [r.getMessage()[:160] for r in said]
        assert any(f"live trial {trial_id}" in r.getMessage() for r in said)
