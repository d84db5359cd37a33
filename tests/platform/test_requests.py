"""Requests through the HTTP API: accepted, refused for each reason, or rejected as bad input."""

from __future__ import annotations

import uuid

from sqlalchemy import select

from hcss.platform.models import Command, CommandOutcome, RequestStatusChange
from tests.support.counting import count_rows


def _rows(app, model):
    with app.extensions["hcss_db"].session_scope() as session:
        return list(session.scalars(select(model).order_by(model.id)))


def _in_range_target(view, collective: int):
    return next(t for t in view["targets"] if collective in t["in_range_of"])


def test_accepted_investigate_is_logged_applied_and_listed(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    view = trial.state()["view"]
    target = _in_range_target(view, 0)
    step = trial.state()["trial"]["step"]

    response = trial.post(
        "/requests", {"kind": "investigate", "collective": 0, "target": target["id"]}
    )

    assert response.status_code == 200
    outcome = response.get_json()
    assert outcome["accepted"] is True and outcome["reason"] == ""
    assert outcome["step"] == step
    listed = trial.state()["view"]["requests"]
    assert [(r["id"], r["kind"], r["collective"], r["target"]) for r in listed] == [
        (outcome["request_id"], "investigate", 0, target["id"])
    ]
    (command,) = _rows(trial.app, Command)
    assert (command.kind, command.collective, command.target, command.step_applied) == (
        "investigate",
        0,
        target["id"],
        step,
    )
    assert command.support == target["support"][0]
    assert command.decision_index == 1
    (logged,) = _rows(trial.app, CommandOutcome)
    assert logged.accepted and logged.request_id == outcome["request_id"]
    (status,) = _rows(trial.app, RequestStatusChange)
    assert (status.request_id, status.status) == (outcome["request_id"], "in_progress")


def test_investigate_completes_once_ten_agents_acknowledge(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    target = _in_range_target(trial.state()["view"], 0)
    request_id = trial.post(
        "/requests", {"kind": "investigate", "collective": 0, "target": target["id"]}
    ).get_json()["request_id"]
    for second in range(61, 120):
        trial.run_to(second)
        statuses = [
            c.status for c in _rows(trial.app, RequestStatusChange) if c.request_id == request_id
        ]
        if "completed" in statuses:
            break
    assert statuses[:2] == ["in_progress", "completed"]


def _refuse(trial, body, expected_reason: str) -> None:
    before = trial.state()
    response = trial.post("/requests", body)
    assert response.status_code == 200
    outcome = response.get_json()
    assert outcome["accepted"] is False
    assert expected_reason in outcome["reason"]
    after = trial.state()
    assert after["view"]["requests"] == before["view"]["requests"]  # nothing changed
    shown = [m["text"] for m in after["messages"] if m["kind"] == "refusal"]
    assert any(expected_reason in text for text in shown), shown
    command = _rows(trial.app, Command)[-1]
    logged = _rows(trial.app, CommandOutcome)[-1]
    assert logged.command_id == command.id
    assert logged.accepted is False and expected_reason in logged.reason


def test_each_refusal_reason_is_logged_and_shown(make_trial) -> None:
    trial = make_trial(seed=2)
    # Out of the trial's range (target 99, collective 7 of four) is a 400 before anything is
    # stored (tests/platform/test_command_hardening.py); in range but impossible now is a refusal.
    _refuse(trial, {"kind": "investigate", "collective": 0, "target": 1}, "not been discovered")

    trial.run_to(60)
    view = trial.state()["view"]
    far = next(t for t in view["targets"] if 0 not in t["in_range_of"])
    _refuse(trial, {"kind": "investigate", "collective": 0, "target": far["id"]}, "out of range")
    weak = next(t for t in view["targets"] if 0 in t["in_range_of"] and t["support"][0] < 0.01)
    _refuse(
        trial,
        {"kind": "abandon", "collective": 0, "target": weak["id"]},
        "abandon needs at least 2",
    )
    _refuse(
        trial,
        {"kind": "decide", "collective": 0, "target": weak["id"]},
        "decide needs at least 30%",
    )

    # Seed 2: collective II starts moving to target 8, which is also in range of IV.
    second = 60
    while not any(c["executing"] for c in trial.state()["view"]["collectives"]):
        second += 5
        assert second < 600, "no collective began a move in 10 minutes"
        trial.run_to(second)
    view = trial.state()["view"]
    mover = next(c for c in view["collectives"] if c["executing"])
    goal = mover["move"]["target"]
    _refuse(
        trial,
        {"kind": "investigate", "collective": mover["index"], "target": goal},
        "is executing a move",
    )
    rival = next(
        (c["index"] for c in view["collectives"] if c["index"] != mover["index"]),
    )
    _refuse(
        trial,
        {"kind": "investigate", "collective": rival, "target": goal},
        "is taken by collective",
    )


def test_abandon_then_cancel_assignment(make_trial) -> None:
    trial = make_trial()
    # At 90 s collective I was already moving (compiled engine, calibrated defaults).
    trial.run_to(60)
    view = trial.state()["view"]
    favoured = max(
        (t for t in view["targets"] if 0 in t["in_range_of"]), key=lambda t: t["support"][0]
    )
    assert favoured["support"][0] * 200 >= 2
    abandon = trial.post(
        "/requests", {"kind": "abandon", "collective": 0, "target": favoured["id"]}
    ).get_json()
    assert abandon["accepted"], abandon
    listed = trial.state()["view"]["requests"]
    assert [(r["kind"], r["status"]) for r in listed] == [("abandon", "in_progress")]
    cancel = trial.post(
        "/requests", {"kind": "cancel", "request_id": abandon["request_id"]}
    ).get_json()
    assert cancel["accepted"], cancel
    assert trial.state()["view"]["requests"] == []
    commands = _rows(trial.app, Command)
    assert [(c.kind, c.collective, c.target) for c in commands] == [
        ("abandon", 0, favoured["id"]),
        ("cancel", 0, favoured["id"]),
    ]
    trial.run_to(61)
    statuses = [(c.request_id, c.status) for c in _rows(trial.app, RequestStatusChange)]
    assert statuses == [(abandon["request_id"], "in_progress"), (abandon["request_id"], "removed")]
    again = abandon["request_id"]
    _refuse(trial, {"kind": "cancel", "request_id": again}, f"no active abandon assignment {again}")


def test_bad_input_gets_a_json_error_and_changes_nothing(make_trial) -> None:
    trial = make_trial()
    trial.run_to(30)
    bad_bodies = [
        {"kind": "explode", "collective": 0, "target": 1},
        {"kind": "investigate", "collective": "zero", "target": 1},
        {"kind": "investigate", "collective": 0},
        {"kind": "investigate", "collective": True, "target": 1},
        {"kind": "investigate", "collective": -1, "target": 1},
        {"kind": "cancel"},
        {"kind": "investigate", "collective": 0, "target": 1, "selections": "x"},
        {"kind": "investigate", "collective": 0, "target": 1, "selections": [999]},
        ["not", "an", "object"],
    ]
    for body in bad_bodies:
        response = trial.post("/requests", body)
        assert response.status_code == 400, body
        error = response.get_json()
        assert error["message"], body
    not_json = trial.client.post(
        trial.api + "/requests",
        data="kind=decide",
        headers={"X-CSRFToken": trial.csrf, "Idempotency-Key": uuid.uuid4().hex},
    )
    assert not_json.status_code == 400 and "JSON" in not_json.get_json()["message"]
    assert count_rows(trial.app, Command) == 0
    assert count_rows(trial.app, CommandOutcome) == 0


def test_accepted_requests_are_logged_in_system_messages_and_survive_a_rebuild(
    make_trial,
) -> None:
    trial = make_trial()
    trial.run_to(60)
    target = _in_range_target(trial.state()["view"], 0)
    outcome = trial.post(
        "/requests", {"kind": "investigate", "collective": 0, "target": target["id"]}
    ).get_json()
    expected = f"Request {outcome['request_id']} accepted (investigate by collective I on target {target['id']})"
    shown = [m for m in trial.state()["messages"] if m["kind"] == "accepted"]
    assert [m["text"] for m in shown] == [expected]
    trial.runner.forget(trial.trial_id)  # forget it: the next look rebuilds from the log
    rebuilt = [m["text"] for m in trial.live().messages if m["kind"] == "accepted"]
    assert rebuilt == [expected]
