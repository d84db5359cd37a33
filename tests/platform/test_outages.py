"""Issue 13 §6: the trial does not run on while the server is down, and the data say so.

A training trial used to advance 38 steps during an 8.8 s outage, and the
interruption's `last_seen_at` was often the restart time (it was read after
the rebuild had written new rows). Now the outage stops the trial clock like
a pause: the trial resumes at the step the server reached, its end moves by
the outage, and the export's `interruptions` table shows the outage.
"""

from __future__ import annotations

import csv

import pytest
from click.testing import CliRunner
from sqlalchemy import select

from hcss.cli import main
from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.models import Interruption

ACCELERATION = 4.0  # trial seconds per wall second


def _restart(database_url: str, now: float):
    app = create_app(
        {"DATABASE_URL": database_url, "SECRET_KEY": "test-secret", "LIVE_RUNNER": False}
    )
    app.extensions["hcss_runner"].clock = ManualClock(now)
    return app


def test_an_outage_stops_the_trial_clock_and_moves_its_end(
    app, make_trial, database_url, tmp_path
) -> None:
    trial = make_trial(kind="training", duration_s=120.0, time_acceleration=ACCELERATION)
    trial.run_to(40.0)
    reached = trial.live().sim.step_count
    assert reached == 40
    crash_wall = trial.started_epoch + 40.0 / ACCELERATION

    restarted = _restart(database_url, crash_wall + 8.8)  # 8.8 s later, 35 trial s at 4x
    try:
        runner = restarted.extensions["hcss_runner"]
        live = runner.host(trial.trial_id)
        assert live.sim.step_count == reached  # not 40 + 35
        with restarted.extensions["hcss_db"].session_scope() as session:
            (interruption,) = session.scalars(select(Interruption)).all()
            assert interruption.outage_s == pytest.approx(8.8)
            assert interruption.resumed_step == reached
            assert interruption.last_seen_at < interruption.created_at  # read before the rebuild

        end_wall = trial.started_epoch + 120.0 / ACCELERATION
        runner.clock.now = end_wall  # the original end: 8.8 s of it were the outage
        runner.tick()
        assert not live.ended and live.sim.step_count == pytest.approx(120 - 35, abs=1)
        runner.clock.now = end_wall + 8.8 + 0.01
        runner.tick()
        assert live.ended and live.sim.step_count == 120

        # Another restart later: the earlier outage still counts, the new one adds to it.
        restarted_again = _restart(database_url, end_wall + 20)
        assert restarted_again.extensions["hcss_runner"].host(trial.trial_id) is None  # ended
        restarted_again.extensions["hcss_db"].engine.dispose()
    finally:
        restarted.extensions["hcss_db"].engine.dispose()

    outdir = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    assert result.exit_code == 0, result.output
    with (outdir / "interruptions.csv").open(encoding="utf-8") as handle:
        (row,) = list(csv.DictReader(handle))
    assert (row["trial_id"], row["trial_kind"], row["resumed_step"]) == (
        str(trial.trial_id),
        "training",
        "40",
    )
    assert float(row["outage_s"]) == pytest.approx(8.8)
    assert row["last_seen_at"] < row["resumed_at"]


def test_two_outages_both_stop_the_clock(app, make_trial, database_url) -> None:
    trial = make_trial(duration_s=600.0, time_acceleration=1.0)
    trial.run_to(30.0)
    first = _restart(database_url, trial.started_epoch + 30.0 + 5.0)
    try:
        runner = first.extensions["hcss_runner"]
        assert runner.host(trial.trial_id).sim.step_count == 30
        runner.clock.now = trial.started_epoch + 30.0 + 5.0 + 20.0  # 20 s of running
        runner.tick()
        assert runner.host(trial.trial_id).sim.step_count == 50
    finally:
        first.extensions["hcss_db"].engine.dispose()
    second = _restart(database_url, trial.started_epoch + 55.0 + 7.0)  # down another 7 s
    try:
        live = second.extensions["hcss_runner"].host(trial.trial_id)
        assert live.sim.step_count == 50
        with second.extensions["hcss_db"].session_scope() as session:
            outages = [
                i.outage_s for i in session.scalars(select(Interruption).order_by(Interruption.id))
            ]
        assert outages == [pytest.approx(5.0), pytest.approx(7.0)]
    finally:
        second.extensions["hcss_db"].engine.dispose()


def test_a_trial_whose_simulation_finished_early_loses_only_the_outage(
    app, make_trial, database_url
) -> None:
    """The server is last seen alive by its newest row's time, not by its newest step.

    A simulation whose decisions are all made stops stepping while the trial
    runs on to its deadline; its rows keep the finishing step. Taking that step
    as the last moment seen counted all the time since the finish as outage:
    the clock went back hundreds of seconds and the trial ran past its end.
    """
    trial = make_trial(seed=2, duration_s=3000.0)
    seconds = 0.0
    while not trial.live().sim.finished and seconds < 3000.0:
        seconds += 20.0
        trial.run_to(seconds)
    assert trial.live().sim.finished, "the simulation never finished"
    seconds += 300.0  # running on, finished, for 300 s
    for _ in range(60):
        seconds += 5.0
        trial.run_to(seconds)
    clock_at_crash = trial.live().trial_time(trial.runner.clock.now)
    crash_wall = trial.runner.clock.now

    restarted = _restart(database_url, crash_wall + 6.0)
    try:
        live = restarted.extensions["hcss_runner"].host(trial.trial_id)
        assert live is not None
        assert live.trial_time(crash_wall + 6.0) == pytest.approx(clock_at_crash, abs=0.5)
        with restarted.extensions["hcss_db"].session_scope() as session:
            (interruption,) = session.scalars(select(Interruption)).all()
        assert interruption.outage_s == pytest.approx(6.0, abs=0.5)
    finally:
        restarted.extensions["hcss_db"].engine.dispose()
