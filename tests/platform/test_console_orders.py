"""A console action issued in one process reaches the trial's host in another, within 2 s.

Two apps on one database stand for two processes; the host's runner ticks in
its own thread, as `hcss serve` runs it. The same through nginx and real
processes is in test_failover.py.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator

import pytest
from flask import Flask
from sqlalchemy import select

from hcss.platform.bots.participant import ManualClock
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.models import ConsoleAction, Participant, TrialLease, TrialOrder
from tests.support.console import sign_in
from tests.support.leases import leased_process, start_trial_on

ORDER_LIMIT_S = 2.0


@pytest.fixture
def host_and_console(database_url: str) -> Iterator[tuple[Flask, Flask]]:
    clock = ManualClock(1_000_000.0)
    host = leased_process(database_url, "127.0.0.1:5001", clock)
    host.extensions["hcss_db"].create_all()
    console = leased_process(database_url, "127.0.0.1:5002", clock)
    stop = threading.Event()

    def run_host() -> None:  # the host's runner thread, on the (still) fake clock
        while not stop.is_set():
            host.extensions["hcss_runner"].tick()
            stop.wait(0.05)

    ticking = threading.Thread(target=run_host, daemon=True)
    ticking.start()
    yield host, console
    stop.set()
    ticking.join(timeout=10)
    for app in (host, console):
        app.extensions["hcss_db"].engine.dispose()


def _hosted_trial_and_console(host: Flask, console: Flask):
    """A trial the host holds, its participant's code, and an experimenter signed in on the other."""
    runner = host.extensions["hcss_runner"]
    live = runner.host(start_trial_on(runner))
    assert live is not None
    with host.extensions["hcss_db"].session_scope() as session:
        create_experimenter(session, "alice", "correct horse battery")
        code = session.scalars(select(Participant.code)).one()
    client = console.test_client()
    assert sign_in(client, "alice", "correct horse battery").status_code == 302
    return live, code, client


def _csrf(client, code: str) -> str:
    page = client.get(f"/console/participants/{code}")
    return page.get_data(as_text=True).split('name="csrf-token" content="')[1].split('"')[0]


def test_a_pause_and_resume_on_one_process_reach_the_host_of_the_trial(host_and_console) -> None:
    host, console = host_and_console
    live, code, client = _hosted_trial_and_console(host, console)
    trial_id = live.trial_id

    for action, paused in (("pause", True), ("resume", False)):
        csrf = _csrf(client, code)
        started = time.monotonic()
        answer = client.post(
            f"/console/participants/{code}/{action}",
            data={"csrf_token": csrf},
            follow_redirects=True,
        )
        took_s = time.monotonic() - started
        assert f"{code}: {action} done" in answer.get_data(as_text=True)
        assert took_s < ORDER_LIMIT_S, took_s
        assert (
            live.trial_clock.paused_since is not None
        ) is paused  # carried out in the host's memory
        assert trial_id not in console.extensions["hcss_runner"].loaded_ids()

    with host.extensions["hcss_db"].session_scope() as session:
        actions = session.scalars(select(ConsoleAction).order_by(ConsoleAction.id)).all()
        orders = session.scalars(select(TrialOrder).order_by(TrialOrder.id)).all()
    assert [(a.action, a.trial_id) for a in actions] == [("pause", trial_id), ("resume", trial_id)]
    assert [(o.action, o.outcome, o.issued_by) for o in orders] == [
        ("pause", "done", "127.0.0.1:5002"),
        ("resume", "done", "127.0.0.1:5002"),
    ]


def test_a_withdrawal_on_one_process_takes_the_trial_from_its_host_first(
    host_and_console,
) -> None:
    host, console = host_and_console
    runner = host.extensions["hcss_runner"]
    live, code, client = _hosted_trial_and_console(host, console)
    trial_id = live.trial_id
    csrf = _csrf(client, code)
    answer = client.post(
        f"/console/participants/{code}/withdraw",
        data={"csrf_token": csrf, "confirm_code": code},
        follow_redirects=True,
    )
    assert answer.status_code == 200
    assert live.moved and trial_id not in runner.loaded_ids()  # the host stopped first
    with host.extensions["hcss_db"].session_scope() as session:
        assert session.scalars(select(Participant)).all() == []
        assert session.scalars(select(TrialLease)).all() == []
    for _ in range(5):  # and writes nothing for it afterwards
        runner.clock.now += 1.0
        runner.tick()
    assert trial_id not in runner.loaded_ids()
