"""Issue 44 §2: a form field sent as a multipart file part answers 400, on every form.

No page of the platform takes a file. Flask-WTF reads ``request.files`` together with the
form, and WTForms' ``Length`` called ``len()`` on the FileStorage: the public sign-in
page's username, password and code and the withdraw form's confirm code answered 500.
"""

from __future__ import annotations

import io

import pytest
from sqlalchemy import func, select

from hcss.platform.models import AuditRecord, LoginFailure, Participant, StageEvent
from tests.support.console import PASSWORD, USERNAME
from tests.support.study import new_participant, visitor


def _as_file(fields: dict[str, str], name: str) -> dict[str, object]:
    """The form with `name` sent as a file part (a file's name and bytes), the rest as text."""
    sent: dict[str, object] = dict(fields)
    sent[name] = (io.BytesIO(fields[name].encode()), "field.txt")
    return sent


def _rows(app, model) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return int(session.scalar(select(func.count()).select_from(model)) or 0)


@pytest.mark.parametrize("name", ["username", "password", "code", "csrf_token"])
def test_a_sign_in_field_sent_as_a_file_answers_400(app, experimenter, name) -> None:
    from tests.support.trials import csrf_token_of

    client = app.test_client()
    token = csrf_token_of(client.get("/console/login").get_data(as_text=True))
    fields = {"csrf_token": token, "username": USERNAME, "password": PASSWORD, "code": "123456"}
    answer = client.post("/console/login", data=_as_file(fields, name))
    assert answer.status_code == 400, answer.status_code
    assert b"Traceback" not in answer.get_data()
    assert _rows(app, LoginFailure) == 0  # refused before the throttle counted it


@pytest.mark.parametrize(
    ("action", "fields"),
    [
        ("withdraw", {"confirm_code": "CODE"}),
        ("create", {"count": "2", "study": "original"}),
        ("pause", {"csrf_token": ""}),
    ],
)
def test_a_console_form_field_sent_as_a_file_answers_400(app, console, action, fields) -> None:
    token = new_participant(app)
    with app.extensions["hcss_db"].session_scope() as session:
        code = session.scalar(select(Participant.code).where(Participant.token == token))
    fields = {name: (code if value == "CODE" else value) for name, value in fields.items()}
    fields["csrf_token"] = console.csrf
    name = next(iter(fields))
    path = (
        "/console/participants" if action == "create" else f"/console/participants/{code}/{action}"
    )
    participants, audits = _rows(app, Participant), _rows(app, AuditRecord)
    answer = console.client.post(path, data=_as_file(fields, name))
    assert answer.status_code == 400, answer.status_code
    assert (_rows(app, Participant), _rows(app, AuditRecord)) == (participants, audits)


def test_a_participants_answer_sent_as_a_file_answers_400(app) -> None:
    v = visitor(app, new_participant(app))
    page = v.page()
    fields = dict(page.hidden) | {"answer": "yes"}
    events = _rows(app, StageEvent)
    answer = v.client.post(page.action, data=_as_file(fields, "answer"))
    assert answer.status_code == 400, answer.status_code
    assert _rows(app, StageEvent) == events
