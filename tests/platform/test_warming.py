"""Serving while the simulation warms up: pages answer, a trial's Start waits for it.

`hcss serve` compiles the simulation's kernels in a background thread
(hcss.platform.live.warmup.Warmup); a real compile on an empty cache is in
test_warm_start_browser. Here the warm-up is one the test holds, over HTTP:
the study link and consent answer meanwhile, the training's page says the
simulation is being prepared and reloads itself, a Start posted anyway starts
no trial, and once the warm-up is done the same page starts the training.
"""

from __future__ import annotations

import re
import threading
from urllib.parse import urlencode

from sqlalchemy import func, select

from hcss.platform.bots.participant import parse_page
from hcss.platform.live.warmup import Warmup
from hcss.platform.models import Trial
from tests.support.recruitment import demo_variant

LAPTOP = {"width": "1366", "height": "657", "mobile": "0", "missing": ""}
HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')


def _trials(app) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return int(session.scalar(select(func.count()).select_from(Trial)) or 0)


def test_pages_answer_during_the_warm_up_and_a_training_waits_for_it(
    app, tmp_path, monkeypatch
) -> None:
    name = demo_variant(tmp_path / "studies", monkeypatch, "warming", {})
    path = tmp_path / "studies" / "warming.toml"
    text = re.sub(r"before = \[[^\]]*\]", 'before = ["consent"]', path.read_text(), count=1)
    path.write_text(re.sub(r"per_model = \[[^\]]*\]", 'per_model = ["training"]', text, count=1))
    compiling = threading.Event()
    warmup = Warmup(compiling.wait)
    warmup.install(app)
    warmup.start()

    client = app.test_client()
    first = client.get(f"/join/{name}?{urlencode({'PROLIFIC_PID': 'w1'})}")
    assert first.status_code == 200
    joined = client.post(
        f"/join/{name}", data=dict(HIDDEN.findall(first.get_data(as_text=True))) | LAPTOP
    )
    consent = parse_page(client.get(joined.location, follow_redirects=True).get_data(as_text=True))
    assert consent.stage == "consent"
    client.post(consent.action, data=consent.hidden | {"decision": "agree"})
    waiting = client.get(joined.location, follow_redirects=True).get_data(as_text=True)
    assert 'id="simulation-warming"' in waiting and 'http-equiv="refresh"' in waiting
    assert 'id="stage-form"' not in waiting
    training = parse_page(waiting)
    assert training.stage == "training"
    # A Start posted anyway (a page opened in another tab, a script) starts nothing.
    token = joined.location.rsplit("/", 1)[-1]
    csrf = re.search(r'name="csrf-token" content="([^"]+)"', waiting).group(1)
    refused = client.post(f"/p/{token}/stage/1/ready", data={"csrf_token": csrf})
    # "Not now", not "no": a 503 that says when to send it again (a 409 stopped the bot).
    assert refused.status_code == 503, refused.status_code
    assert float(refused.headers["Retry-After"]) > 0
    assert "still being prepared" in refused.get_data(as_text=True)
    assert 'http-equiv="refresh"' in refused.get_data(as_text=True)  # back to the page by itself
    assert _trials(app) == 0

    compiling.set()  # the warm-up ends: the same page starts the training
    for _ in range(200):
        if warmup.ready:
            break
        threading.Event().wait(0.01)
    ready = parse_page(client.get(joined.location, follow_redirects=True).get_data(as_text=True))
    assert ready.stage == "training" and "simulation-warming" not in client.get(
        joined.location, follow_redirects=True
    ).get_data(as_text=True)
    started = client.post(ready.action, data=ready.hidden)
    assert started.status_code == 302 and _trials(app) == 1
    assert "/live/" in client.get(started.location).location  # on to the live interface


class _HeldWarmup(Warmup):
    """A warm-up that ends once a page has asked whether it is ready twice.

    The first look renders the training's waiting page; a second look is the
    page asked for again, as the participant's browser does every 5 s. A bot
    that posted the waiting page's missing form instead never looks again.
    """

    def __init__(self) -> None:
        self.released = threading.Event()
        super().__init__(lambda: self.released.wait(120))
        self.looks = 0

    @property
    def ready(self) -> bool:
        done = super().ready
        if not done:
            self.looks += 1
            if self.looks >= 2:
                self.released.set()
        return done


def test_a_bot_that_meets_the_waiting_page_waits_and_walks_on(database_url) -> None:
    """`hcss bots` against a server still compiling: every bot failed 'POST  answered 405'
    on the training's waiting page, which has no form (seen on a fresh install and under load)."""
    from hcss.platform.bots.participant import bot_app, run_bots

    app = bot_app(database_url, "demo")
    app.extensions["hcss_db"].create_all()
    warmup = _HeldWarmup()
    warmup.install(app)
    warmup.start()
    [report] = run_bots(app, 1)
    assert warmup.looks >= 2 and warmup.ready
    assert len(report.trials) == 6  # then every training and trial ran (3 models)
    app.extensions["hcss_runner"].stop()
    app.extensions["hcss_db"].engine.dispose()


def test_a_start_shown_by_a_warm_member_and_sent_to_a_warming_one_is_not_now(
    database_url,
) -> None:
    """Issue 44: two processes of a group on one database. After a kill -9 the survivor
    shows a participant hashed to the killed process their training's Start (it is warm);
    the killed process, back on its address, gets the Start while it still warms up (3 s
    after a restart, far more under load) and refused it with 409: the chaos soak's bots
    stopped there (3 of 110 in 30 minutes). It is "not now": 503 with Retry-After, the
    same form sent again once warm starts the training."""
    from tests.support.study import make_app, visitor, walk_to

    survivor, restarted = make_app(database_url, "demo"), make_app(database_url, "demo")
    compiling = threading.Event()
    warmup = Warmup(compiling.wait)
    warmup.install(restarted)
    warmup.start()
    try:
        participant = visitor(survivor, _new_demo_participant(survivor))
        page = walk_to(participant, "training", "ready")
        cookie = participant.client.get_cookie("session")
        assert cookie is not None
        other = restarted.test_client()
        other.set_cookie("session", cookie.value)  # the same browser, sent to the other member
        refused = other.post(page.action, data=page.hidden)
        assert refused.status_code == 503, refused.status_code
        assert float(refused.headers["Retry-After"]) > 0
        assert _trials(restarted) == 0
        compiling.set()
        for _ in range(200):
            if warmup.ready:
                break
            threading.Event().wait(0.01)
        started = other.post(page.action, data=page.hidden)
        assert started.status_code == 302 and _trials(restarted) == 1
    finally:
        compiling.set()
        for app in (survivor, restarted):
            app.extensions["hcss_db"].engine.dispose()


def _new_demo_participant(app) -> str:
    from tests.support.study import new_participant

    return new_participant(app)
