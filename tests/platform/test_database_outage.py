"""A database that drops out mid-trial loses nothing the participant saw.

Two real faults: a PostgreSQL server of the test's own stopped for 20 s,
and an SQLite database on a small file system of the test's own that is
filled for a window. In both the runner keeps
ticking as the server's thread does; afterwards every decision and every
event of an uninterrupted replay of the same trial is in the database, in
order, and the outage is an `interruption` row.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import pytest
from sqlalchemy import select

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.live.trials import latest_status, start_bot_trial
from hcss.platform.models import DecisionRow, Interruption, SimEvent, TrialStatusChange
from hcss.platform.models.vocabularies import TrialStatus
from hcss.simulation.messages import event_text
from tests.support.own_disk import own_disk
from tests.support.own_postgres import own_postgres
from tests.support.replays import replay_trial

TRIAL_S = 240.0
TICK_S = 0.5  # trial (= wall, acceleration 1) seconds per runner tick: two per sync, as in a server


def _app(database_url: str):
    app = create_app(
        {"DATABASE_URL": database_url, "SECRET_KEY": "s", "TESTING": True, "LIVE_RUNNER": False}
    )
    app.extensions["hcss_db"].create_all()
    app.extensions["hcss_runner"].clock = ManualClock(1_000_000.0)
    return app


def _run_through_outage(app, begin: Callable[[], None], end: Callable[[], None], outage_s: float):
    database, runner = app.extensions["hcss_db"], app.extensions["hcss_runner"]
    with database.session_scope() as session:
        _, trial = start_bot_trial(session, seed=7, duration_s=TRIAL_S)
        trial_id = trial.id
    clock: ManualClock = runner.clock

    def tick() -> None:
        """One turn of the runner thread's loop, which logs a failed tick and goes on."""
        clock.now += TICK_S
        try:
            runner.tick()
        except Exception:  # as Runner._run: a failed tick is logged and the next one runs
            logging.getLogger(__name__).exception("runner tick failed")

    for _ in range(int(TRIAL_S / 3 / TICK_S)):
        tick()
    live = runner.host(trial_id)
    assert live is not None and not live.ended
    shown_before = len(live.messages)
    begin()
    try:
        started = time.monotonic()
        while time.monotonic() - started < outage_s:
            tick()  # the runner thread carries on; its writes fail
            time.sleep(0.05)
        shown_during = len(live.messages)
    finally:
        end()
    for _ in range(int(3 * TRIAL_S / TICK_S)):
        tick()
        with database.session_scope() as session:
            if latest_status(session, trial_id) == TrialStatus.ENDED:
                break
    with database.session_scope() as session:
        assert latest_status(session, trial_id) == TrialStatus.ENDED
        ended = session.scalars(
            select(TrialStatusChange).where(TrialStatusChange.trial_id == trial_id)
        ).all()[-1]
        decisions = [
            (d.collective, d.decision_index, d.record["end_s"])
            for d in session.scalars(
                select(DecisionRow).where(DecisionRow.trial_id == trial_id).order_by(DecisionRow.id)
            )
        ]
        events = [
            (round(e.sim_time, 6), e.kind, e.text)
            for e in session.scalars(
                select(SimEvent).where(SimEvent.trial_id == trial_id).order_by(SimEvent.id)
            )
        ]
        interruptions = session.scalars(
            select(Interruption).where(Interruption.trial_id == trial_id)
        ).all()
        uninterrupted = replay_trial(session, trial_id, ended.step)
    replayed = [(int(d.collective), d.decision_index, d.end_s) for d in uninterrupted.decisions]
    replayed_events = [
        (round(float(e["time"]), 6), str(e["kind"]), event_text(e)[:300])
        for e in uninterrupted.drain_events()
    ]
    assert ended.reason == "time_limit"
    assert shown_during >= shown_before  # the page kept what it had shown
    assert len(replayed) > 0 and len(replayed_events) > 0
    assert decisions == replayed, (len(decisions), len(replayed))
    assert events == replayed_events, (len(events), len(replayed_events))
    assert len(interruptions) >= 1 and interruptions[0].outage_s > 0
    return interruptions


@pytest.mark.slow
def test_a_20_s_postgresql_outage_mid_trial_loses_no_decision_and_no_event() -> None:
    with own_postgres() as server:
        app = _app(server.url)
        try:
            (interruption, *_) = _run_through_outage(app, server.stop, server.start, 20.0)
            assert interruption.outage_s >= 20.0
        finally:
            app.extensions["hcss_db"].engine.dispose()


def test_an_sqlite_disk_full_window_mid_trial_loses_no_decision_and_no_event(tmp_path) -> None:
    with own_disk(tmp_path) as disk:
        app = _app(f"sqlite:///{disk.path / 'hcss.sqlite3'}")
        engine = app.extensions["hcss_db"].engine

        def fill() -> None:
            """The write-ahead log emptied and every byte taken: the next commit fails."""
            with engine.connect() as connection:
                connection.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")
            disk.fill()

        try:
            _run_through_outage(app, fill, disk.free, 3.0)
        finally:
            engine.dispose()
