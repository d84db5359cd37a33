"""The console's live table: how long one poll of /console/progress.json takes.

300 participants on the demo study (an online study's size), each enrolled
and at the consent page with a heartbeat, on SQLite in a temporary folder.
Every open console polls every CONSOLE_POLL_S (2 s), so the time of one
poll is the share of a core one console costs.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from pathlib import Path

PARTICIPANTS = 300
POLLS = 5


def run() -> None:
    from hcss.platform.bots.participant import bot_app
    from hcss.platform.cli import upgrade_database
    from hcss.platform.console.participant_table import progress_json, progress_page
    from hcss.platform.models import Participant

    with tempfile.TemporaryDirectory() as folder:
        url = f"sqlite:///{Path(folder) / 'console-bench.sqlite3'}"
        upgrade_database(url)
        app = bot_app(url, "demo", SECRET_KEY="bench")
        database = app.extensions["hcss_db"]
        with database.session_scope() as session:
            participants = [Participant(study="demo") for _ in range(PARTICIPANTS)]
            session.add_all(participants)
            session.flush()
            tokens = [p.token for p in participants]
        client = app.test_client()
        for token in tokens:
            client.get(f"/p/{token}", follow_redirects=True)
            client.post(f"/p/{token}/heartbeat", json={"page": "study"})
        times = []
        with app.app_context(), database.session_scope() as session:
            for _ in range(POLLS):
                started = time.perf_counter()
                # what /console/progress.json does: the first page, read and serialised
                page = progress_page(session, app.extensions["hcss_runner"].clock())
                answer = progress_json(page)
                times.append(time.perf_counter() - started)
        database.engine.dispose()
    assert answer["total"] == PARTICIPANTS
    print(
        f"console table, {PARTICIPANTS} participants (SQLite): one poll "
        f"median {statistics.median(times) * 1000:.0f} ms, max {max(times) * 1000:.0f} ms "
        f"over {POLLS} polls (page 1 of {answer['pages']}, "
        f"{len(answer['participants'])} rows)"
    )
