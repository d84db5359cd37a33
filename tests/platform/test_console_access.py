"""Only a signed-in experimenter reaches the console; a participant's token opens nothing."""

from __future__ import annotations

import pytest
from sqlalchemy import func, select

from hcss.platform.models import ConsoleAction, Participant
from tests.support.console import PASSWORD, USERNAME, code_of, sign_in
from tests.support.trials import csrf_token_of

# Fixtures of this part's own module (conftest.py belongs to the live trial tests).


def _console_urls(app, code: str, trial_id: int = 1) -> list[tuple[str, str]]:
    """Every console route (but sign-in and static files), filled with a real participant."""
    urls = []
    for rule in app.url_map.iter_rules():
        if not rule.rule.startswith("/console") or rule.endpoint in (
            "console.login",
            "console.static",
        ):
            continue
        path = rule.rule.replace("<code>", code).replace("<action>", "pause")
        path = path.replace("<int:trial_id>", str(trial_id))
        for method in sorted(rule.methods - {"HEAD", "OPTIONS"}):
            urls.append((method, path))
    return urls


def _action_count(app) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalar(select(func.count()).select_from(ConsoleAction))


def test_no_console_page_or_download_without_signing_in(app, make_trial, experimenter) -> None:
    trial = make_trial(duration_s=120.0)
    code = code_of(app, trial.token)
    urls = _console_urls(app, code, trial.trial_id)
    assert ("GET", "/console/export.zip") in urls and (
        "POST",
        f"/console/participants/{code}/withdraw",
    ) in urls
    assert len(urls) >= 8
    # The participant's own browser, holding a valid CSRF token from their trial page.
    participant_browser = trial.client
    for method, path in urls:
        response = participant_browser.open(path, method=method, data={"csrf_token": trial.csrf})
        assert response.status_code == 302, (method, path, response.status_code)
        assert response.headers["Location"].startswith("/console/login"), (method, path)
        assert response.data.startswith(b"<!doctype html>") and b"Redirecting" in response.data
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 1
    assert _action_count(app) == 0


def test_a_participant_token_is_no_login_and_no_console_address(
    app,
    make_trial,
    console,
) -> None:
    trial = make_trial(duration_s=120.0)
    # Token as username or password: refused like any wrong login.
    stranger = app.test_client()
    assert sign_in(stranger, trial.token, trial.token).status_code == 401
    assert sign_in(stranger, USERNAME, trial.token).status_code == 401
    assert stranger.get("/console/").status_code == 302
    # Console URLs name participants by code; a token names nobody there, even signed in.
    assert console.get(f"/console/participants/{trial.token}").status_code == 404
    assert console.act(trial.token, "pause").status_code == 404
    assert _action_count(app) == 0
    # And the console never shows a token except on the participant's own page (the link).
    index = console.get("/console/").get_data(as_text=True)
    assert trial.token not in index
    assert trial.token not in console.client.get("/console/progress.json").get_data(as_text=True)


def test_wrong_password_is_refused_and_the_right_one_lets_in(app, experimenter) -> None:
    client = app.test_client()
    refused = sign_in(client, USERNAME, PASSWORD + "x")
    assert refused.status_code == 401 and b"Wrong username or password" in refused.data
    assert client.get("/console/").status_code == 302
    assert sign_in(client, "nobody", PASSWORD).status_code == 401
    assert client.get("/console/progress.json").status_code == 302
    accepted = sign_in(client, USERNAME, PASSWORD)
    assert accepted.status_code == 302 and accepted.headers["Location"] == "/console/"
    assert client.get("/console/").status_code == 200


def test_sign_in_redirects_only_inside_the_console(app, experimenter) -> None:
    client = app.test_client()
    page = client.get("/console/login?next=https://evil.example/")
    response = client.post(
        "/console/login?next=https://evil.example/",
        data={
            "csrf_token": csrf_token_of(page.get_data(as_text=True)),
            "username": USERNAME,
            "password": PASSWORD,
        },
    )
    assert response.headers["Location"] == "/console/"


def test_sign_out_closes_the_console(console) -> None:
    assert console.post("/console/logout").status_code == 302
    assert console.client.get("/console/").status_code == 302


def test_posts_without_csrf_change_nothing(app, make_trial, console) -> None:
    trial = make_trial(duration_s=120.0)
    code = code_of(app, trial.token)
    for path, fields in [
        (f"/console/participants/{code}/pause", {}),
        (f"/console/participants/{code}/withdraw", {"confirm_code": code}),
        ("/console/participants", {"count": "1"}),
    ]:
        response = console.client.post(path, data=fields)
        assert response.status_code == 400, path
    assert _action_count(app) == 0
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 1


@pytest.mark.parametrize("count", ["0", "51", "many"])
def test_bad_participant_counts_create_nobody(app, console, count: str) -> None:
    response = console.post("/console/participants", {"count": count})
    assert response.status_code == 303
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 0
