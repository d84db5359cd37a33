"""Issue 13 §2: the inputs that gave 500s answer 4xx, on SQLite and PostgreSQL.

Huge ids (OverflowError on SQLite, "integer out of range" on PostgreSQL),
NUL bytes (PostgreSQL refuses them in text), malformed stream positions,
JSON nested past the recursion limit, and bodies of any size.
"""

from __future__ import annotations

import uuid

import pytest

from tests.support.trials import csrf_token_of

HUGE_IDS = [2**31, 2**31 + 7, 2**63, 2**64 + 1, 10**40]


@pytest.mark.parametrize("huge", HUGE_IDS)
def test_huge_ids_in_urls_are_not_found(make_trial, huge: int) -> None:
    trial = make_trial()
    base = f"/api/live/{trial.token}/trials"
    assert trial.client.get(f"{base}/{huge}/state").status_code == 404
    assert trial.client.get(f"{base}/{huge}/stream").status_code == 404
    for route in ("ready", "answer"):
        response = trial.post(f"/probes/{huge}/{route}", {"answer": "x"})
        assert response.status_code == 404, route
    stage = trial.client.post(f"/p/{trial.token}/stage/{huge}/form", data={})
    assert stage.status_code == 404


@pytest.mark.parametrize("huge", HUGE_IDS)
def test_huge_ids_in_json_are_refused(make_trial, huge: int) -> None:
    trial = make_trial()
    for body in (
        {"kind": "investigate", "collective": huge, "target": 1},
        {"kind": "investigate", "collective": 0, "target": huge},
        {"kind": "cancel", "request_id": huge},
        {"kind": "investigate", "collective": 0, "target": 1, "selections": [huge]},
    ):
        assert trial.post("/requests", body).status_code == 400, body
    assert (
        trial.post(
            "/observations", {"kind": "target", "target": huge, "button": "left"}
        ).status_code
        == 400
    )


def test_nul_bytes_in_tokens_codes_and_logins_are_refused(make_trial, console) -> None:
    trial = make_trial()
    client = trial.client
    assert client.get("/p/a%00b").status_code == 404
    assert client.get("/p/a%00b/stage").status_code == 404
    assert client.get("/live/a%00b").status_code == 404
    assert (
        client.get(f"/api/live/{trial.token}%00/trials/{trial.trial_id}/state").status_code == 404
    )
    assert console.get("/console/participants/a%00b").status_code == 404
    login = client.get("/console/login")
    assert login.status_code == 200
    answer = client.post(
        "/console/login",
        data={
            "csrf_token": csrf_token_of(login.get_data(as_text=True)),
            "username": "ali\x00ce",
            "password": "correct horse battery",
        },
    )
    assert answer.status_code == 400
    assert client.get("/console/login?next=%00").status_code == 400


@pytest.mark.parametrize(
    ("after", "last_event_id"),
    [("%C2%B2", None), ("9" * 5000, None), ("0", "\xb2"), ("1", "9" * 5000), ("-3", "+5")],
)
def test_malformed_stream_positions_start_from_the_beginning(
    app, make_trial, after: str, last_event_id: str | None
) -> None:
    app.config["STREAM_MAX_S"] = 0.0  # one frame, then the stream closes
    trial = make_trial()
    headers = {} if last_event_id is None else {"Last-Event-ID": last_event_id}
    response = trial.client.get(f"{trial.api}/stream?after={after}", headers=headers)
    assert response.status_code == 200
    assert "data: {" in response.get_data(as_text=True)


@pytest.mark.parametrize("depth", [1000, 100_000])
def test_json_nested_past_the_recursion_limit_is_bad_json(make_trial, depth: int) -> None:
    trial = make_trial()
    body = "[" * depth + "]" * depth
    for path in ("/requests", "/observations", "/probes/1/answer"):
        response = trial.client.post(
            trial.api + path,
            data=body,
            content_type="application/json",
            headers={"X-CSRFToken": trial.csrf, "Idempotency-Key": uuid.uuid4().hex},
        )
        assert response.status_code == 400, path
        assert "JSON" in response.get_json()["message"]


def test_request_bodies_are_limited(make_trial) -> None:
    trial = make_trial()
    big = b"x" * (trial.app.config["MAX_CONTENT_LENGTH"] + 1)
    assert (
        trial.client.post("/console/login", data=big, content_type="text/plain").status_code == 413
    )
    assert (
        trial.client.post(
            "/console/login", data={"username": "x" * len(big), "password": "y"}
        ).status_code
        == 413
    )
    response = trial.client.post(
        trial.api + "/requests",
        data=big,
        content_type="application/json",
        headers={"X-CSRFToken": trial.csrf, "Idempotency-Key": uuid.uuid4().hex},
    )
    assert response.status_code == 413 and response.get_json()["error"]


def test_a_json_body_to_a_page_is_refused(make_trial) -> None:
    trial = make_trial()
    response = trial.client.post("/console/login", json=False)
    assert response.status_code == 415
