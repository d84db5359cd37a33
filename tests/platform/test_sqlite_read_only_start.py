"""Issue 30 §3: SQLite read-only across a start recovers once the disk is writable again.

A server that started on a read-only disk, with a live trial in it, answered
503 to the trial's state, commands and heartbeats for good: SQLite shares a
read-only -shm mapping among the process's connections to the file while any
of them stays open, so replacing one connection at a time never let a
writable one in; and a connection dropped after a read-only error stayed open
behind its failed cursor. Walked as a participant's page does: the state, a command,
the runner's tick, over the app's routes.
"""

from __future__ import annotations

import subprocess
import sys
import time
import uuid

import pytest

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.cli import upgrade_database
from tests.support.own_disk import own_disk

_CRASHING_WRITER = """
import os, sys
from hcss.platform.db import Database
from hcss.platform.live.trials import start_trial
from hcss.platform.models import Participant
database = Database(sys.argv[1])
with database.session_scope() as session:
    participant = Participant(is_demo=True, study="demo")
    session.add(participant)
    session.flush()
    trial = start_trial(session, participant, kind="trial", duration_s=600.0)
    print(participant.token, trial.id, flush=True)
connection = database.engine.raw_connection()  # held open, then the process dies
os._exit(0)
"""


@pytest.mark.slow
def test_a_live_trial_read_only_across_a_start_runs_again_once_the_disk_is_writable(
    tmp_path,
) -> None:
    with own_disk(tmp_path) as disk:
        url = f"sqlite:///{disk.path / 'hcss.sqlite3'}"
        upgrade_database(url)
        # The trial is written by a process that then dies without closing the database
        # (kill -9, a power cut): its -wal and -shm files stay beside it.
        written = subprocess.run(
            [sys.executable, "-c", _CRASHING_WRITER, url], capture_output=True, text=True
        )
        assert written.returncode == 0, written.stderr
        token, trial_id = written.stdout.split()
        assert (disk.path / "hcss.sqlite3-shm").exists()

        disk.read_only()
        app = create_app({"DATABASE_URL": url, "SECRET_KEY": "s", "LIVE_RUNNER": False})
        runner = app.extensions["hcss_runner"]
        runner.clock = ManualClock(time.time())
        client = app.test_client()
        api = f"/api/live/{token}/trials/{trial_id}"
        try:
            # Several requests at once while read-only: the pool holds several connections.
            engine = app.extensions["hcss_db"].engine
            held = [engine.connect() for _ in range(5)]
            for connection in held:
                connection.exec_driver_sql("SELECT count(*) FROM participant").scalar()
            for connection in held:
                connection.close()
            page = client.get(f"/live/{token}")
            csrf = _csrf(page.get_data(as_text=True)) if page.status_code == 200 else ""
            refused = [_decide(client, api, csrf).status_code for _ in range(2)]
            with app.app_context():
                runner.tick()

            disk.writable()
            statuses = []
            for _ in range(20):
                with app.app_context():
                    runner.tick()
                page = client.get(f"/live/{token}")
                if page.status_code == 200:
                    csrf = _csrf(page.get_data(as_text=True))
                statuses.append((page.status_code, _decide(client, api, csrf).status_code))
                if statuses[-1] == (200, 200):
                    break
                time.sleep(0.25)
            print(f"after the disk is writable again: {statuses}")
            assert set(refused) == {503}
            assert statuses[-1] == (200, 200), statuses
            assert len(statuses) <= 4, statuses  # within a second of the disk's return
        finally:
            disk.writable()
            runner.stop()
            app.extensions["hcss_db"].engine.dispose()


def _decide(client, api: str, csrf: str):
    return client.post(
        f"{api}/requests",
        json={"kind": "decide", "collective": 0, "target": 1},
        headers={"X-CSRFToken": csrf, "Idempotency-Key": uuid.uuid4().hex},
    )


def _csrf(html: str) -> str:
    import re

    found = re.search(r'name="csrf-token" content="([^"]+)"', html)
    assert found is not None
    return found.group(1)
