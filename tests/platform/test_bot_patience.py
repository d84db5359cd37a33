"""Issue 44: an HTTP bot waits out a trial held at its time limit, as the page does.

A trial whose end cannot be written (the database away, read-only, or its link stalled)
stands at its time limit, running, until the end is written: the page waits, and the
participant's study goes on once it is. The HTTP bot gave up after 50 looks past the
limit (10 s): in the 3-minute chaos soak (seed 44) a 10.5-s partition of the host's
database link stopped one bot ("trial 50 is still running after its time limit"). Over
HTTP it now waits as long as it waits for a server that is away (RECONNECT_FOR_S); a trial
that never ends is still a finding after that.

Here the app is served over HTTP, its runner on the test's clock: the clock passes the
trial's limit and the runner is not let step for 15 s (the end not written), then it is.
"""

from __future__ import annotations

import json
import re
import threading
import time

from hcss.platform.bots.http_load import HttpClient, LoadFigures
from hcss.platform.bots.participant import BotReport, ParticipantBot, parse_page
from tests.support.inprocess import serving
from tests.support.study import make_app, new_participant, visitor, walk_to

HELD_S = 15.0


def test_an_http_bot_waits_for_a_trial_held_at_its_time_limit(database_url) -> None:
    app = make_app(database_url, "demo")
    runner = app.extensions["hcss_runner"]
    try:
        participant = visitor(app, new_participant(app))
        ready = walk_to(participant, "training", "ready")
        assert participant.submit({}, ready).status_code == 302
        live_page = participant.client.get(f"/p/{participant.token}", follow_redirects=True)
        page = parse_page(live_page.get_data(as_text=True))
        assert page.interface, "the Start leads to the live interface"
        runner.clock.now += 0.5
        runner.tick()  # the runner hosts the trial
        frame = _state(participant)["trial"]
        wall_left_s = (frame["duration_s"] - frame["clock_s"]) / _acceleration(app)
        cookie = participant.client.get_cookie("session")
        assert cookie is not None
        outcome: dict[str, object] = {}
        with serving(app) as base_url:
            client = HttpClient(base_url, LoadFigures(bots=1, concurrency=1))
            client.http.cookies.set("session", cookie.value)
            bot = ParticipantBot(None, participant.token, client=client, code="patient")

            def supervise() -> None:
                try:
                    outcome["html"] = bot.supervise(page, "training", BotReport(code="patient"))
                except Exception as error:  # noqa: BLE001 - the test reports it
                    outcome["error"] = error

            watcher = threading.Thread(target=supervise)
            watcher.start()
            # Past the limit, and the end not written for HELD_S (the runner cannot step).
            runner.clock.now += wall_left_s + 1.0
            watcher.join(timeout=HELD_S)
            assert watcher.is_alive(), f"the bot stopped while the trial was held: {outcome}"
            for _ in range(20):  # the end is written: the trial ends, the bot walks on
                runner.clock.now += 0.5
                runner.tick()
                time.sleep(0.1)
            watcher.join(timeout=30)
            client.close()
        assert "error" not in outcome, outcome.get("error")
        after = parse_page(str(outcome["html"]))
        assert (after.stage, after.step) == ("trial", "ready")
    finally:
        app.extensions["hcss_db"].engine.dispose()


def _state(participant) -> dict:
    page = participant.client.get(f"/p/{participant.token}", follow_redirects=True)
    trial = re.search(r"/trials/(\d+)/", page.get_data(as_text=True))
    assert trial is not None
    api = f"/api/live/{participant.token}/trials/{trial.group(1)}/state"
    return json.loads(participant.client.get(api).get_data(as_text=True))


def _acceleration(app) -> float:
    from sqlalchemy import select

    from hcss.platform.models import Trial

    with app.extensions["hcss_db"].session_scope() as session:
        return float(session.scalar(select(Trial.time_acceleration).limit(1)) or 1.0)
