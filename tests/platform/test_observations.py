"""Clicks on hubs and targets are logged as observation actions."""

from __future__ import annotations

from sqlalchemy import select

from hcss.platform.live.trial_log import observation_actions
from hcss.platform.models import Command, Observation


def _observations(app):
    with app.extensions["hcss_db"].session_scope() as session:
        return list(session.scalars(select(Observation).order_by(Observation.id)))


def test_clicks_are_logged_with_kind_button_and_time(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    state = trial.state()
    target = state["view"]["targets"][0]["id"]
    clicks = [
        {"kind": "collective", "collective": 1, "button": "right"},
        {"kind": "target", "target": target, "button": "right"},
        {"kind": "collective", "collective": 0, "button": "left"},
    ]
    for click in clicks:
        response = trial.post("/observations", click)
        assert response.status_code == 201, response.get_json()
    rows = _observations(trial.app)
    assert [(r.kind, r.collective, r.target, r.button) for r in rows] == [
        ("collective", 1, None, "right"),
        ("target", None, target, "right"),
        ("collective", 0, None, "left"),
    ]
    assert {r.step for r in rows} == {state["trial"]["step"]}
    assert {r.sim_time for r in rows} == {state["view"]["time"]}


def test_clicks_that_filled_a_committed_request_are_not_observation_actions(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    target = next(t for t in trial.state()["view"]["targets"] if 0 in t["in_range_of"])["id"]
    inspect = trial.post("/observations", {"kind": "target", "target": target, "button": "right"})
    hub = trial.post("/observations", {"kind": "collective", "collective": 0, "button": "left"})
    pick = trial.post("/observations", {"kind": "target", "target": target, "button": "left"})
    selections = [hub.get_json()["observation_id"], pick.get_json()["observation_id"]]
    outcome = trial.post(
        "/requests",
        {"kind": "investigate", "collective": 0, "target": target, "selections": selections},
    ).get_json()
    assert outcome["accepted"]
    with trial.app.extensions["hcss_db"].session_scope() as session:
        (command,) = session.scalars(select(Command))
        assert command.selections == selections
        actions = observation_actions(session, trial.trial_id)
    assert [a.id for a in actions] == [inspect.get_json()["observation_id"]]


def test_invalid_clicks_are_rejected_and_not_logged(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    for body in [
        {"kind": "hub", "collective": 0, "button": "left"},
        {"kind": "collective", "collective": 0, "button": "middle"},
        {"kind": "collective", "button": "left"},
        {"kind": "collective", "collective": 9, "button": "left"},
        {"kind": "target", "target": 999, "button": "left"},
        {"kind": "target", "button": "right"},
    ]:
        response = trial.post("/observations", body)
        assert response.status_code == 400, body
        assert response.get_json()["message"]
    assert _observations(trial.app) == []
