"""CSRF on every POST, and a participant's token opens only that participant's trial."""

from __future__ import annotations

from hcss.platform.models import Command, Observation
from tests.support.counting import count_rows


def test_post_without_csrf_token_is_refused(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    target = trial.state()["view"]["targets"][0]
    body = {"kind": "investigate", "collective": 0, "target": target["id"]}

    missing = trial.client.post(trial.api + "/requests", json=body)
    forged = trial.client.post(
        trial.api + "/requests", json=body, headers={"X-CSRFToken": "forged"}
    )
    observation = trial.client.post(
        trial.api + "/observations", json={"kind": "collective", "collective": 0, "button": "left"}
    )

    for response in (missing, forged, observation):
        assert response.status_code == 400
        assert response.get_json()["error"] == "csrf"
    assert count_rows(trial.app, Command) == 0
    assert count_rows(trial.app, Observation) == 0
    assert trial.post("/requests", body).status_code == 200  # the page's token works


def test_csrf_token_of_another_browser_session_is_refused(make_trial) -> None:
    trial = make_trial()
    other = trial.app.test_client()  # no session cookie: the token is not bound to it
    response = other.post(
        trial.api + "/observations",
        json={"kind": "collective", "collective": 0, "button": "left"},
        headers={"X-CSRFToken": trial.csrf},
    )
    assert response.status_code == 400 and response.get_json()["error"] == "csrf"


def test_a_participant_cannot_read_or_command_another_trial(make_trial) -> None:
    alice, bob = make_trial(seed=2), make_trial(seed=3)
    alice.run_to(60)
    foreign = f"/api/live/{alice.token}/trials/{bob.trial_id}"
    assert alice.client.get(foreign + "/state").status_code == 404
    assert alice.client.get(foreign + "/stream").status_code == 404
    body = {"kind": "investigate", "collective": 0, "target": 1}
    response = alice.client.post(
        foreign + "/requests", json=body, headers={"X-CSRFToken": alice.csrf}
    )
    assert response.status_code == 404 and response.is_json
    probe = alice.client.post(foreign + "/probes/1/ready", headers={"X-CSRFToken": alice.csrf})
    assert probe.status_code == 404
    assert count_rows(alice.app, Command) == 0
    # Bob's own token still works, and an unknown token opens nothing.
    assert bob.client.get(bob.api + "/state").status_code == 200
    assert (
        alice.client.get(f"/api/live/not-a-token/trials/{alice.trial_id}/state").status_code == 404
    )
    assert alice.client.get("/live/not-a-token").status_code == 404
