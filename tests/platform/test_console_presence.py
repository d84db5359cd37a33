"""Heartbeats from the participant's page: connected, last seen, and what a hostile client sends."""

from __future__ import annotations

import pytest
from sqlalchemy import func, select

from hcss.platform.console.presence import CONNECTED_WITHIN_S
from hcss.platform.models import Participant, ParticipantPresence


def _new(console) -> tuple[str, str]:
    console.post("/console/participants", {"count": "1", "study": "demo"})
    (code,) = console.progress()
    with console.app.extensions["hcss_db"].session_scope() as session:
        token = session.scalars(select(Participant.token).where(Participant.code == code)).one()
    return code, token


def _token(app) -> str:
    """A participant made straight in the database (no console sign-in: argon2 is slow)."""
    with app.extensions["hcss_db"].session_scope() as session:
        participant = Participant(study="demo")
        session.add(participant)
        session.flush()
        return participant.token


def _presence_rows(app) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalar(select(func.count()).select_from(ParticipantPresence)) or 0


def test_the_participants_page_beats_and_the_console_shows_it(app, console) -> None:
    clock = app.extensions["hcss_runner"].clock
    clock.now = 1_000_000.0
    code, token = _new(console)
    row = console.progress()[code]
    assert (row["connected"], row["last_seen_s"]) == (False, None)

    participant = app.test_client()
    page = participant.get(f"/p/{token}", follow_redirects=True).get_data(as_text=True)
    assert "heartbeat.js" in page and f'data-heartbeat-url="/p/{token}/heartbeat"' in page
    assert "heartbeat.js" not in console.get("/console/").get_data(as_text=True)

    beat = participant.post(f"/p/{token}/heartbeat", json={"page": "study", "hidden": False})
    assert beat.status_code == 204 and beat.get_data() == b""
    clock.now += 4.0
    row = console.progress()[code]
    assert (row["connected"], row["last_seen_s"], row["page_hidden"]) == (True, 4.0, False)

    # A second beat overwrites the one row; a hidden tab is still connected.
    assert participant.post(f"/p/{token}/heartbeat", json={"hidden": True}).status_code == 204
    assert _presence_rows(app) == 1
    clock.now += CONNECTED_WITHIN_S
    row = console.progress()[code]
    assert (row["connected"], row["last_seen_s"], row["page_hidden"]) == (
        True,
        CONNECTED_WITHIN_S,
        True,
    )
    clock.now += 1.0  # three beats missed: the page is gone
    row = console.progress()[code]
    assert row["connected"] is False and row["last_seen_s"] == CONNECTED_WITHIN_S + 1.0

    # An empty body is a plain beat; withdrawal deletes the presence row with the rest.
    assert participant.post(f"/p/{token}/heartbeat").status_code == 204
    response = console.post(f"/console/participants/{code}/withdraw", {"confirm_code": code})
    assert response.status_code == 303
    assert _presence_rows(app) == 0


@pytest.mark.parametrize(
    ("path", "status"),
    [
        ("/p/{unknown}/heartbeat", 404),
        ("/p/a%00b/heartbeat", 404),
        ("/p/" + "A" * 5000 + "/heartbeat", 404),
        ("/p/%F0%9F%92%A9/heartbeat", 404),
        ("/p/{token}/heartbeat/", 404),
    ],
)
def test_a_heartbeat_for_no_participant_is_404(app, path, status) -> None:
    token = _token(app)
    url = path.format(token=token, unknown="x" * 32)
    assert app.test_client().post(url, json={}).status_code == status
    assert _presence_rows(app) == 0


@pytest.mark.parametrize(
    ("body", "content_type", "status"),
    [
        (b"not json", "application/json", 400),
        (b"[1, 2]", "application/json", 400),
        (b'"study"', "application/json", 400),
        (b'{"page": "console"}', "application/json", 400),
        (b'{"page": 7}', "application/json", 400),
        (b'{"hidden": "yes"}', "application/json", 400),
        (b'{"hidden": 1}', "application/json", 400),
        (b'{"page": "study", "extra": 1}', "application/json", 400),
        (b'{"page": "st\\u0000udy"}', "application/json", 400),
        (b"[" * 120 + b"]" * 120, "application/json", 400),
        (b"[" * 100_000, "application/json", 413),
        (b'{"page": "' + b"x" * 10_000 + b'"}', "text/plain", 413),
        (b"\xff\xfe\x00", "application/octet-stream", 400),
    ],
)
def test_a_malformed_heartbeat_is_refused_and_writes_nothing(
    app, body, content_type, status
) -> None:
    token = _token(app)
    response = app.test_client().post(
        f"/p/{token}/heartbeat", data=body, headers={"Content-Type": content_type}
    )
    assert response.status_code == status
    assert _presence_rows(app) == 0


def test_only_post_beats(app) -> None:
    token = _token(app)
    assert app.test_client().get(f"/p/{token}/heartbeat").status_code == 405
    assert _presence_rows(app) == 0


def test_the_trial_page_beats_too(app, make_trial) -> None:
    trial = make_trial()
    page = trial.client.get(f"/live/{trial.token}").get_data(as_text=True)
    assert f'data-heartbeat-url="/p/{trial.token}/heartbeat"' in page
    beat = trial.client.post(f"/p/{trial.token}/heartbeat", json={"page": "trial"})
    assert beat.status_code == 204
    with app.extensions["hcss_db"].session_scope() as session:
        (row,) = session.scalars(select(ParticipantPresence)).all()
        assert (row.page, row.hidden) == ("trial", False)


def test_a_busy_database_is_a_503_not_a_500(app, monkeypatch) -> None:
    from sqlalchemy.exc import OperationalError

    from hcss.platform.console import presence

    token = _token(app)

    def locked(*_args, **_kwargs):
        raise OperationalError("UPDATE participant_presence", {}, Exception("database is locked"))

    monkeypatch.setattr(presence, "record_heartbeat", locked)
    response = app.test_client().post(f"/p/{token}/heartbeat", json={"page": "study"})
    assert response.status_code == 503 and "Traceback" not in response.get_data(as_text=True)
    assert _presence_rows(app) == 0
