"""Issue 13 §3: a live request never waits on a trial lock while holding a database connection.

At 200 concurrent trials the live benchmark's streams timed out. Every
stream held its request's pooled connection (from the token check) while it
waited for the runner to load its trial; the thread loading a trial, holding
the runner's lock, waited for a connection; the pool (60) was all held by
the waiters, so nothing moved until the pool timed out after 30 s. The token
check now hands its connection back before any wait.
"""

from __future__ import annotations

import threading
import time

import hcss.platform.live.takeover as takeover


def _wait_until(predicate, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_a_command_waiting_for_its_trial_holds_no_connection(app, make_trial) -> None:
    trial = make_trial()
    live = trial.live()
    pool = app.extensions["hcss_db"].engine.pool
    answers: list[int] = []

    def command() -> None:
        answers.append(
            trial.client.post(
                f"{trial.api}/requests",
                json={"kind": "decide", "collective": 0, "target": 1},
                headers={"X-CSRFToken": trial.csrf, "Idempotency-Key": "k-waiting-1"},
            ).status_code
        )

    with live.lock:  # a runner step under way
        waiter = threading.Thread(target=command)
        waiter.start()
        _wait_until(lambda: pool.checkedin() > 0 or pool.checkedout() > 0)
        time.sleep(0.3)  # the request has passed the token check and waits for the lock
        held = pool.checkedout()
    waiter.join(timeout=10)

    assert held == 0
    assert answers == [200]


def test_streams_waiting_for_a_trial_to_load_hold_no_connection(
    app, make_trial, monkeypatch
) -> None:
    """Two pages of one trial open its stream while the trial is being loaded: the second
    waits for the first's load (each trial has its loader; other trials load meanwhile)."""
    trial = make_trial()
    runner = trial.runner
    runner.forget(trial.trial_id)
    loading, finish = threading.Event(), threading.Event()
    real_load = takeover.load_trial
    loads: list[int] = []

    def slow_load(*args, **kwargs):
        loads.append(1)
        loading.set()
        assert finish.wait(timeout=10)
        return real_load(*args, **kwargs)

    monkeypatch.setattr(takeover, "load_trial", slow_load)
    pool = app.extensions["hcss_db"].engine.pool
    statuses: list[int] = []

    def open_stream() -> None:
        response = app.test_client().get(f"{trial.api}/stream", buffered=False)
        statuses.append(response.status_code)
        response.close()

    loader = threading.Thread(target=open_stream)
    loader.start()
    assert loading.wait(timeout=10)  # the first stream loads the trial
    waiter = threading.Thread(target=open_stream)
    waiter.start()
    time.sleep(0.3)  # the second waits for that load
    held = pool.checkedout()
    finish.set()
    loader.join(timeout=10)
    waiter.join(timeout=10)

    assert held == 1  # the loader's own unit of work, nothing else
    assert statuses == [200, 200]
    assert loads == [1]  # loaded once, for both


def test_the_stream_keeps_its_rate_when_each_frame_takes_time_to_send(app, make_trial) -> None:
    """Frames are due every interval from the last one, not an interval after each send.

    Under load a send (and the thread's wake-up) takes tens of milliseconds;
    waiting a full interval after it made 200 streams run at 1.7-1.8 Hz
    against a 2 Hz target. Here that wait would send 0.77 frames an interval
    (0.2 / 0.26). The test asks 0.9 over 20 intervals: a frame whose wake-up
    comes more than an interval late is skipped, not sent in a burst, and on
    a loaded machine (a suite's workers beside other work) one or two are.
    """
    from hcss.platform.live.frames import event_stream

    trial = make_trial()
    interval_s, send_s, span_s = 0.2, 0.06, 4.0
    frames = event_stream(
        trial.live(), after_seq=0, interval_s=interval_s, max_s=span_s, clock=lambda: 0.0
    )
    started = time.monotonic()
    sent = 0
    for text in frames:
        sent += text.startswith("id:")
        time.sleep(send_s)  # the server writing the frame, under load
    elapsed = time.monotonic() - started

    assert sent >= 0.9 * elapsed / interval_s, (sent, elapsed)


def test_a_command_holds_one_connection_while_it_holds_its_trials_lock(make_trial) -> None:
    """A command's record is written on one connection; the request's own is handed back first.

    A request with selections read them on the request's session, kept that
    connection, then took the trial's lock and a second connection for its
    unit of work. With the PostgreSQL pool bounded (20 + 40), 60 commands on
    60 trials at once each held one connection and waited for a second, so
    none moved until the pool timed out (30 s).
    """
    from sqlalchemy import event

    trial = make_trial()
    trial.run_to(60)
    database = trial.app.extensions["hcss_db"]
    target = next(t for t in trial.state()["view"]["targets"] if 0 in t["in_range_of"])["id"]
    clicks = [
        trial.post("/observations", {"kind": "collective", "collective": 0, "button": "left"}),
        trial.post("/observations", {"kind": "target", "target": target, "button": "left"}),
    ]
    selections = [click.get_json()["observation_id"] for click in clicks]
    pool = database.engine.pool
    held: list[int] = []

    def note_connections(*_args) -> None:
        held.append(pool.checkedout())  # this checkout included

    event.listen(pool, "checkout", note_connections)
    sent = [
        (selections, {"Idempotency-Key": "k-one-connection-0"}, 200),
        (selections, {"Idempotency-Key": "k-one-connection-1"}, 200),
        # a refusal after the selections were read: its key is stored on its own
        (selections + [10**6], {"Idempotency-Key": "k-one-connection-2"}, 400),
    ]
    try:
        for chosen, key, status in sent:
            answer = trial.client.post(
                f"{trial.api}/requests",
                json={
                    "kind": "investigate",
                    "collective": 0,
                    "target": target,
                    "selections": chosen,
                },
                headers={"X-CSRFToken": trial.csrf, **key},
            )
            assert answer.status_code == status, answer.get_json()
    finally:
        event.remove(pool, "checkout", note_connections)

    assert held and max(held) == 1, held
