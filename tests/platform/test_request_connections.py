"""Issue 20: a request holds one database connection at a time, so a bounded pool cannot deadlock.

The console's requests read the signed-in experimenter (and the participant)
on the request's session, kept that connection, then opened a unit of work
(a pause, a skip, a withdrawal, the export) on a second one. With the pool
bounded, enough such requests at once each held one connection and waited
for a second until the pool timed out, so the SQLite pool had no ceiling.
The study flow ended an overdue trial from inside its own unit of work,
committing the request's session mid-way so the runner's unit of work did
not wait for its SQLite write lock. Now a unit of work opened in a request
first hands the request session's connection back (it may not have written),
the live service ends an overdue trial before the flow begins, and the pool
is bounded on SQLite as on PostgreSQL.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from flask import Flask
from flask.testing import FlaskClient
from sqlalchemy import event, select

import hcss.platform.db as db_module
from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.live.trials import latest_status
from hcss.platform.models import Participant
from hcss.platform.models.vocabularies import TrialStatus
from hcss.platform.study.enrolment import current_enrolment
from hcss.platform.study.flow import Flow
from tests.support.console import code_of
from tests.support.study import events, new_participant, visitor, walk_to

#: A pool far smaller than the requests sent at once, failing in seconds, not 30.
SMALL_POOL = {"pool_size": 4, "max_overflow": 4, "pool_timeout": 15}


@pytest.fixture
def app(database_url: str, monkeypatch: pytest.MonkeyPatch) -> Iterator[Flask]:
    """The conftest's app on a small bounded pool (`db.POOL` is read when the engine is made)."""
    monkeypatch.setattr(db_module, "POOL", SMALL_POOL)
    app = create_app(
        {
            "DATABASE_URL": database_url,
            "SECRET_KEY": "test-secret",
            "TESTING": True,
            "LIVE_RUNNER": False,
            "SNAPSHOT_INTERVAL_S": 5.0,
        }
    )
    app.extensions["hcss_db"].create_all()
    app.extensions["hcss_runner"].clock = ManualClock(0.0)
    yield app
    app.extensions["hcss_runner"].stop()
    app.extensions["hcss_db"].engine.dispose()


class MostHeld:
    """The most connections the pool had out at once, counted at each checkout."""

    def __init__(self, app: Flask) -> None:
        self.pool = app.extensions["hcss_db"].engine.pool
        self.counts: list[int] = []

    def _note(self, *_args: Any) -> None:
        self.counts.append(self.pool.checkedout())  # this checkout included

    def __enter__(self) -> MostHeld:
        event.listen(self.pool, "checkout", self._note)
        return self

    def __exit__(self, *_exc: Any) -> None:
        event.remove(self.pool, "checkout", self._note)

    @property
    def most(self) -> int:
        return max(self.counts)


def test_settling_the_flow_leaves_an_overdue_trial_to_the_live_service(demo_app) -> None:
    token = new_participant(demo_app, is_bot=True)
    v = visitor(demo_app, token)
    walk_to(v, "training", "ready")
    assert v.submit({}).status_code == 302
    (run,) = [e for e in events(demo_app, token) if e.step == "run" and e.kind == "entered"]
    trial_id = run.detail["trial_id"]
    v.clock.now = run.deadline.timestamp() + 3600  # the browser closed; nobody stepped it

    database = demo_app.extensions["hcss_db"]
    commits: list[object] = []
    with demo_app.app_context(), database.session_scope() as session:
        event.listen(session, "after_commit", commits.append)
        participant = session.scalars(select(Participant).where(Participant.token == token)).one()
        enrolment = current_enrolment(session, participant.id)
        assert enrolment is not None
        position = Flow(session, participant, enrolment, database.now()).settle()
        # The flow only reads the trial: it neither commits its caller's session
        # nor has the runner write the trial's end.
        assert commits == []
        assert (position.slot and position.slot.name, position.step) == ("training", "run")
        assert latest_status(session, trial_id) == TrialStatus.RUNNING
        session.rollback()

    # The participant's page: the live service ends the trial first, then the flow moves on,
    # one connection at a time.
    with MostHeld(demo_app) as held:
        page = v.page()
    assert (page.stage, page.step) == ("trial", "ready")
    (done,) = [e for e in events(demo_app, token) if e.step == "run" and e.kind == "submitted"]
    assert done.at == run.deadline
    assert held.most == 1, held.counts


def test_no_console_request_holds_two_connections(app, make_trial, console) -> None:
    running, overdue = make_trial(duration_s=600.0), make_trial(seed=3, duration_s=30.0)
    running_code, overdue_code = code_of(app, running.token), code_of(app, overdue.token)
    app.extensions["hcss_runner"].clock.now += 60.0  # `overdue` is past its time; none stepped

    with MostHeld(app) as held:
        assert console.act(running_code, "pause").status_code == 303
        assert console.act(running_code, "resume").status_code == 303
        assert console.act(running_code, "mark_pilot").status_code == 303
        assert console.act(running_code, "skip_stage").status_code == 303  # refused: running
        assert console.act(overdue_code, "skip_stage").status_code == 303  # ends it first
        assert console.get("/console/progress.json").status_code == 200
        assert console.get("/console/export.zip").status_code == 200
        assert console.act(running_code, "abort").status_code == 303
        assert (
            console.post(
                f"/console/participants/{overdue_code}/withdraw", {"confirm_code": overdue_code}
            ).status_code
            == 303
        )
        assert running.client.get(f"/p/{running.token}").status_code == 302
    assert held.most == 1, held.counts
    with app.extensions["hcss_db"].session_scope() as session:
        assert latest_status(session, running.trial_id) == TrialStatus.ENDED
        assert session.scalar(select(Participant).where(Participant.code == overdue_code)) is None


def test_many_requests_at_once_on_a_small_pool_all_answer(app, make_trial, console) -> None:
    """64 requests of the kinds that held two connections, on a pool of 8: none times out."""
    running = [make_trial(seed=seed, duration_s=600.0) for seed in range(8)]
    overdue = [make_trial(seed=10 + seed, duration_s=30.0) for seed in range(8)]
    app.extensions["hcss_runner"].clock.now += 60.0  # the short trials are past their time

    def like(browser: FlaskClient) -> FlaskClient:
        """A client of its own (one per thread) signed in as `browser` is."""
        cookie = browser.get_cookie("session")
        assert cookie is not None
        client = app.test_client()
        client.set_cookie("session", cookie.value)
        return client

    def console_client() -> FlaskClient:
        return like(console.client)

    def pause(trial) -> int:
        code = code_of(app, trial.token)
        fields = {"csrf_token": console.csrf}
        return console_client().post(f"/console/participants/{code}/pause", data=fields).status_code

    def skip(trial) -> int:
        code = code_of(app, trial.token)
        fields = {"csrf_token": console.csrf}
        return (
            console_client()
            .post(f"/console/participants/{code}/skip_stage", data=fields)
            .status_code
        )

    def command(trial) -> int:
        key = f"k-burst-{trial.trial_id}-{threading.get_ident()}"
        return (
            like(trial.client)
            .post(
                f"{trial.api}/observations",
                json={"kind": "collective", "collective": 0, "button": "left"},
                headers={"X-CSRFToken": trial.csrf, "Idempotency-Key": key},
            )
            .status_code
        )

    def study_page(trial) -> int:
        return app.test_client().get(f"/p/{trial.token}/stage").status_code

    def table(_trial) -> int:
        return console_client().get("/console/progress.json").status_code

    def export(_trial) -> int:
        return console_client().get("/console/export.zip").status_code

    jobs = (
        [(pause, t) for t in running]
        + [(command, t) for t in running]
        + [(command, t) for t in running]
        + [(skip, t) for t in overdue]
        + [(study_page, t) for t in overdue]
        + [(study_page, t) for t in running]
        + [(table, None)] * 12
        + [(export, None)] * 4
    )
    assert len(jobs) == 64
    answers: dict[int, tuple[str, int | str, float]] = {}
    start = threading.Barrier(len(jobs))

    def run(index: int, job, trial) -> None:
        start.wait()
        began = time.monotonic()
        try:
            status: int | str = job(trial)
        except Exception as error:  # noqa: BLE001 - reported by the assertion below
            status = repr(error)
        answers[index] = (job.__name__, status, time.monotonic() - began)

    threads = [
        threading.Thread(target=run, args=(i, job, trial), daemon=True)
        for i, (job, trial) in enumerate(jobs)
    ]
    began = time.monotonic()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    elapsed = time.monotonic() - began

    assert len(answers) == len(jobs), f"{len(jobs) - len(answers)} requests never answered"
    failed = [a for a in answers.values() if not isinstance(a[1], int) or a[1] >= 500]
    assert failed == [], failed
    slowest = max(seconds for _, _, seconds in answers.values())
    # Under the pool's timeout: no request waited for a connection that never came.
    assert slowest < SMALL_POOL["pool_timeout"], (slowest, elapsed)
    with app.extensions["hcss_db"].session_scope() as session:
        for trial in overdue:  # ended by the live service before the page or the skip
            assert latest_status(session, trial.trial_id) == TrialStatus.ENDED


def test_the_sqlite_pool_is_bounded(tmp_path) -> None:
    """A thread that cannot get a connection fails after the pool's timeout; it never opens more."""
    from sqlalchemy.exc import TimeoutError as PoolTimeout

    engine = db_module.make_engine(f"sqlite:///{tmp_path / 'pool.sqlite3'}")
    engine.pool._timeout = 0.5  # fail in half a second rather than the 30 s a server waits
    bound = db_module.POOL["pool_size"] + db_module.POOL["max_overflow"]
    connections = [engine.connect() for _ in range(bound)]
    with pytest.raises(PoolTimeout):
        engine.connect()
    for connection in connections:
        connection.close()
    engine.dispose()


def test_a_unit_of_work_after_the_request_wrote_is_refused_and_keeps_nothing(app) -> None:
    """Ending the request's transaction there would commit half a request: refused instead."""
    database = app.extensions["hcss_db"]
    with app.test_request_context("/"):
        db_module.get_session().add(Participant(is_bot=True))
        with pytest.raises(db_module.RequestHoldsWrites), database.session_scope():
            pass
        db_module.get_session().rollback()
    with database.session_scope() as session:
        assert session.scalars(select(Participant)).all() == []


def test_a_statement_that_writes_counts_as_a_write_too(app) -> None:
    """The heartbeat's upsert (`session.execute`) writes without a flush; it is refused the same."""
    from hcss.platform.console.presence import record_heartbeat
    from hcss.platform.models import ParticipantPresence

    database = app.extensions["hcss_db"]
    with database.session_scope() as session:
        participant = Participant(is_bot=True)
        session.add(participant)
    with app.test_request_context("/"):
        record_heartbeat(db_module.get_session(), participant.id, 1.0, "stage", False)
        with pytest.raises(db_module.RequestHoldsWrites), database.session_scope():
            pass
        db_module.get_session().rollback()
    with database.session_scope() as session:
        assert session.scalars(select(ParticipantPresence)).all() == []
