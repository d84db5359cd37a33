"""Idempotent commands: a repeated or racing POST with the same key is carried out once.

The double-clicked Commit of issue 8 recorded two investigate requests 14 ms
apart; with a key per command the second POST gets the first answer and
writes nothing.
"""

from __future__ import annotations

import threading
import uuid

from sqlalchemy import select

from hcss.platform.models import Command, CommandKey, CommandOutcome, Observation, ProbeEvent
from tests.support.console import SECOND_FACTOR_COLUMNS, UNIQUE_TRIAL_KEYS
from tests.support.counting import count_rows
from tests.support.trials import csrf_token_of, investigate_request, until_probe


def _keyed(trial, path: str, body, key: str):
    return trial.client.post(
        trial.api + path,
        json=body,
        headers={"X-CSRFToken": trial.csrf, "Idempotency-Key": key},
    )


def test_the_same_key_twice_gives_one_request_and_the_same_answer(make_trial) -> None:
    trial = make_trial()
    body, key = investigate_request(trial), str(uuid.uuid4())

    first = _keyed(trial, "/requests", body, key)
    trial.run_to(61)  # the repeat comes later, after the simulation moved on
    second = _keyed(trial, "/requests", body, key)

    assert first.status_code == second.status_code == 200
    assert first.get_json()["accepted"] is True
    assert second.get_json() == first.get_json()
    assert second.headers["Idempotent-Replayed"] == "true"
    assert (count_rows(trial.app, Command), count_rows(trial.app, CommandOutcome)) == (1, 1)
    assert count_rows(trial.app, CommandKey) == 1
    assert len(trial.state()["view"]["requests"]) == 1
    # A fresh key is a new command: refused now (the collective is already investigating).
    third = _keyed(trial, "/requests", body, str(uuid.uuid4()))
    assert third.status_code == 200 and count_rows(trial.app, Command) == 2


def test_a_refusal_is_recorded_once_and_replayed(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    target = min(trial.state()["view"]["targets"], key=lambda t: t["support"][0])
    body, key = {"kind": "decide", "collective": 0, "target": target["id"]}, "k-" + "7" * 30
    first, second = (_keyed(trial, "/requests", body, key) for _ in range(2))
    assert first.get_json()["accepted"] is False
    assert (second.status_code, second.get_json()) == (first.status_code, first.get_json())
    assert count_rows(trial.app, Command) == 1
    refusals = [m for m in trial.live().messages if m["kind"] == "refusal"]
    assert len(refusals) == 1  # System Messages say it once


def test_two_racing_posts_with_one_key_give_one_row(make_trial) -> None:
    trial = make_trial()
    body, key = investigate_request(trial), str(uuid.uuid4())
    barrier, answers = threading.Barrier(2), []

    def post() -> None:
        client = trial.app.test_client()
        page = client.get(f"/live/{trial.token}")  # each racer its own browser session
        csrf = csrf_token_of(page.get_data(as_text=True))
        barrier.wait()
        response = client.post(
            trial.api + "/requests",
            json=body,
            headers={"X-CSRFToken": csrf, "Idempotency-Key": key},
        )
        answers.append((response.status_code, response.get_json()))

    racers = [threading.Thread(target=post) for _ in range(2)]
    for racer in racers:
        racer.start()
    for racer in racers:
        racer.join(timeout=30)
    assert len(answers) == 2 and answers[0] == answers[1]
    assert answers[0][0] == 200
    assert (count_rows(trial.app, Command), count_rows(trial.app, CommandKey)) == (1, 1)


def test_clicks_and_probe_answers_are_idempotent_too(make_trial) -> None:
    trial = make_trial(seed=4)
    click = {"kind": "collective", "collective": 1, "button": "right"}
    first, second = (_keyed(trial, "/observations", click, "click-key-1") for _ in range(2))
    assert first.status_code == second.status_code == 201
    assert first.get_json() == second.get_json()
    assert count_rows(trial.app, Observation) == 1

    probe, _, _ = until_probe(trial, 0)
    ready = [_keyed(trial, f"/probes/{probe['id']}/ready", {}, "ready-key-1") for _ in range(2)]
    assert [r.status_code for r in ready] == [200, 200]  # not a 409 "already ready"
    choice = trial.state()["probe"]["choices"][0]
    answers = [
        _keyed(trial, f"/probes/{probe['id']}/answer", {"answer": choice}, "answer-key-1")
        for _ in range(2)
    ]
    assert [r.status_code for r in answers] == [200, 200]
    with trial.app.extensions["hcss_db"].session_scope() as session:
        kinds = list(
            session.scalars(select(ProbeEvent.kind).where(ProbeEvent.probe_id == probe["id"]))
        )
    assert kinds.count("ready") == 1 and kinds.count("answer") == 1


def test_an_error_is_the_first_outcome_too(make_trial) -> None:
    trial = make_trial()
    trial.run_to(10)
    bad = {"kind": "investigate", "collective": "I", "target": 1}
    first, second = (_keyed(trial, "/requests", bad, "err-key-01") for _ in range(2))
    assert first.status_code == second.status_code == 400
    assert first.get_json() == second.get_json()
    assert (count_rows(trial.app, Command), count_rows(trial.app, CommandKey)) == (0, 1)


def test_bad_keys_get_a_clear_400_and_change_nothing(make_trial) -> None:
    trial = make_trial()
    body = investigate_request(trial)
    for key in (
        "short",
        "x" * 65,
        "a" * 100_000,
        "has space in it",
        "nul\x00byte-key",
        "ünïcode-key",
    ):
        try:
            response = _keyed(trial, "/requests", body, key)
        except ValueError:  # the test client refuses to send some headers at all
            continue
        assert response.status_code == 400, key
        assert response.get_json()["error"] == "bad_idempotency_key"
    assert (count_rows(trial.app, Command), count_rows(trial.app, CommandKey)) == (0, 0)


def test_a_key_reused_for_another_command_is_refused(make_trial) -> None:
    trial = make_trial()
    body = investigate_request(trial)
    assert _keyed(trial, "/requests", body, "reused-key").status_code == 200
    other = {**body, "collective": 1}
    response = _keyed(trial, "/requests", other, "reused-key")
    assert response.status_code == 422
    assert response.get_json()["error"] == "idempotency_key_reused"
    assert count_rows(trial.app, Command) == 1


def test_a_command_without_a_key_is_refused_and_changes_nothing(make_trial) -> None:
    """Every page and bot sends a key; a command without one gets a 400 that says to send
    one, and nothing is written (before issue 41 it was carried out unprotected)."""
    trial = make_trial()
    body = investigate_request(trial)
    probe, _state, _second = until_probe(trial, 60)
    for path, sent in (
        ("/requests", body),
        ("/observations", {"kind": "collective", "collective": 0, "button": "left"}),
        (f"/probes/{probe['id']}/ready", {}),
        (f"/probes/{probe['id']}/answer", {"answer": "x"}),
    ):
        response = trial.client.post(
            trial.api + path, json=sent, headers={"X-CSRFToken": trial.csrf}
        )
        assert response.status_code == 400, (path, response.get_data(as_text=True))
        assert response.get_json()["error"] == "idempotency_key_required"
        assert "Idempotency-Key" in response.get_json()["message"]
    assert count_rows(trial.app, Command) == 0
    assert count_rows(trial.app, Observation) == 0
    assert count_rows(trial.app, CommandKey) == 0
    assert count_rows(trial.app, ProbeEvent) == 0


def test_the_same_key_in_another_participants_trial_is_another_command(make_trial) -> None:
    first, second = make_trial(), make_trial()
    for trial in (first, second):
        assert (
            _keyed(trial, "/requests", investigate_request(trial), "shared-key").status_code == 200
        )
    assert (count_rows(first.app, Command), count_rows(first.app, CommandKey)) == (2, 2)


def test_the_migration_creates_the_key_table_as_modelled_and_removes_it(database_url) -> None:
    """0004_p8_idempotency against the model, on SQLite and PostgreSQL; then downgraded."""
    from alembic import command
    from alembic.autogenerate import compare_metadata
    from alembic.migration import MigrationContext
    from sqlalchemy import MetaData, create_engine, inspect

    from hcss.platform.cli import alembic_config
    from hcss.platform.models import Base

    config = alembic_config(database_url)
    command.upgrade(config, "0004_p8_idempotency")
    engine = create_engine(database_url)
    try:
        expected = MetaData(naming_convention=Base.metadata.naming_convention)
        for table in Base.metadata.sorted_tables:
            if table.name in set(inspect(engine).get_table_names()):
                table.to_metadata(expected)
        assert "command_key" in expected.tables
        later = SECOND_FACTOR_COLUMNS | {  # columns revisions after 0004_p8_idempotency add
            ("interruption", "outage_s"),  # 0004_h13_hardening
            ("experimenter", "login_generation"),  # 0004_h13_hardening
            ("trial", "probe_counts"),  # 0005_a10_vocabularies
            ("recruitment", "submit_to"),  # i31a_mturk_submit_to
        }

        def not_later(obj, name, type_, reflected, compare_to) -> bool:
            if type_ == "index":
                return name not in UNIQUE_TRIAL_KEYS
            return not (type_ == "column" and (obj.table.name, name) in later)

        with engine.connect() as connection:
            context = MigrationContext.configure(connection, opts={"include_object": not_later})
            assert compare_metadata(context, expected) == []
        command.downgrade(config, "0003_study")
        assert "command_key" not in inspect(create_engine(database_url)).get_table_names()
    finally:
        engine.dispose()


class _LostKey(Exception):
    """The write of a key failed (or the server died) after the command was carried out."""


def _lose_the_next_key(app):
    """Make the next transaction that holds a `CommandKey` fail, as a kill -9 would."""
    from sqlalchemy import event

    sessions = app.extensions["hcss_db"].sessions
    lost = []

    def fail(session, _flush_context, _instances) -> None:
        if not lost and any(isinstance(row, CommandKey) for row in session.new):
            lost.append(True)
            raise _LostKey("the key's write failed")

    event.listen(sessions, "before_flush", fail)
    return lambda: event.remove(sessions, "before_flush", fail)


def _post_losing_the_key(trial, path: str, body, key: str) -> None:
    restore = _lose_the_next_key(trial.app)
    try:
        response = _keyed(trial, path, body, key)
        assert response.status_code >= 500  # a client retries this with the same key
    except _LostKey:  # the test app propagates the server's exception
        pass
    finally:
        restore()


def test_a_command_whose_key_was_lost_is_not_carried_out_again(make_trial) -> None:
    """Command and key are committed together: a retry after a failed write gives one request."""
    trial = make_trial()
    body, key = investigate_request(trial), str(uuid.uuid4())

    _post_losing_the_key(trial, "/requests", body, key)
    assert count_rows(trial.app, Command) == count_rows(trial.app, CommandKey)  # both or neither
    retry = _keyed(trial, "/requests", body, key)
    again = _keyed(trial, "/requests", body, key)

    assert retry.status_code == again.status_code == 200
    assert retry.get_json()["accepted"] is True and again.get_json() == retry.get_json()
    assert (count_rows(trial.app, Command), count_rows(trial.app, CommandOutcome)) == (1, 1)
    assert count_rows(trial.app, CommandKey) == 1
    assert len(trial.state()["view"]["requests"]) == 1
    accepted = [m for m in trial.live().messages if m["kind"] == "accepted"]
    assert len(accepted) == 1  # System Messages say it once


def test_clicks_and_probe_answers_whose_key_was_lost_are_recorded_once(make_trial) -> None:
    trial = make_trial(seed=4)
    click = {"kind": "collective", "collective": 1, "button": "right"}
    _post_losing_the_key(trial, "/observations", click, "click-key-lost")
    assert count_rows(trial.app, Observation) == count_rows(trial.app, CommandKey)
    retry = _keyed(trial, "/observations", click, "click-key-lost")
    assert retry.status_code == 201 and count_rows(trial.app, Observation) == 1

    probe, _, _ = until_probe(trial, 0)
    ready, answer = f"/probes/{probe['id']}/ready", f"/probes/{probe['id']}/answer"
    _post_losing_the_key(trial, ready, {}, "ready-key-lost")
    assert _keyed(trial, ready, {}, "ready-key-lost").status_code == 200  # not 409
    choice = trial.state()["probe"]["choices"][0]
    _post_losing_the_key(trial, answer, {"answer": choice}, "answer-key-lost")
    retried = _keyed(trial, answer, {"answer": choice}, "answer-key-lost")
    assert retried.status_code == 200  # not 409 "closed"
    with trial.app.extensions["hcss_db"].session_scope() as session:
        kinds = list(
            session.scalars(select(ProbeEvent.kind).where(ProbeEvent.probe_id == probe["id"]))
        )
    assert kinds.count("ready") == 1 and kinds.count("answer") == 1
    assert count_rows(trial.app, CommandKey) == 3


def test_no_view_runs_under_the_trials_lock(make_trial, monkeypatch) -> None:
    """A keyed command's Flask view reads the request and answers outside the trial's lock:
    only the live service takes it (issue 29: the view ran inside it, so a slow read of the
    body held up the runner's steps and the trial's streams)."""
    from hcss.platform.live import api

    trial = make_trial()
    body = investigate_request(trial)
    lock = trial.live().lock
    held_while_reading: list[bool] = []
    read = api._json

    def spy():
        held_while_reading.append(lock._is_owned())
        return read()

    monkeypatch.setattr(api, "_json", spy)
    answer = _keyed(trial, "/requests", body, str(uuid.uuid4()))
    assert answer.status_code == 200 and answer.get_json()["accepted"] is True
    assert held_while_reading == [False]
