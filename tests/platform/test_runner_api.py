"""The runner's thread runs only where trials are served; an unmigrated database is one message."""

from __future__ import annotations

import logging
import time

from hcss.platform.app import create_app


def test_an_app_built_for_a_script_has_no_runner_thread(tmp_path) -> None:
    app = create_app({"DATABASE_URL": f"sqlite:///{tmp_path / 'x.db'}", "SECRET_KEY": "s"})
    runner = app.extensions["hcss_runner"]
    try:
        assert runner._thread is None  # the point of the test
    finally:
        runner.stop()
        app.extensions["hcss_db"].engine.dispose()


def test_an_unmigrated_database_gives_one_clear_message_not_a_traceback_per_tick(
    tmp_path, caplog
) -> None:
    app = create_app(
        {
            "DATABASE_URL": f"sqlite:///{tmp_path / 'empty.db'}",
            "SECRET_KEY": "s",
            "LIVE_RUNNER": True,
        }
    )
    runner = app.extensions["hcss_runner"]
    runner._last_sync = -float("inf")
    with caplog.at_level(logging.INFO, logger="hcss.platform.live.runner"):
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and not caplog.records:
            time.sleep(0.05)
        time.sleep(1.5)  # more than one sync interval: a second failing tick must stay quiet
        runner.stop()
    app.extensions["hcss_db"].engine.dispose()
    records = [r for r in caplog.records if r.name == "hcss.platform.live.runner"]
    assert len(records) == 1, [r.getMessage() for r in records]
    assert "hcss db upgrade" in records[0].getMessage()
    assert records[0].exc_info is None
