"""Issue 30 §5: a study page whose database stops mid-request answers 503, never 500.

The view had read its participant; the failure's rollback expired it, and the
please-wait page's context processor (`_participant_code`) read its token
again, from the stopped database, inside the 503 handler: 3 of 12 bots met a
500 in the issue's outage. Here every statement fails from the moment the
participant is read, as a database that stops there fails them.
"""

from __future__ import annotations

from sqlalchemy import event
from sqlalchemy.exc import OperationalError

from hcss.platform.models import Participant
from tests.support.recruitment import join


class _Stopped(Exception):
    pass


def test_a_study_page_whose_database_stops_after_reading_the_participant_answers_503(
    app,
) -> None:
    client = app.test_client()
    started = join(client)
    assert started.status_code == 302
    page = started.headers["Location"]
    first = client.get(page, follow_redirects=True)
    assert first.status_code == 200
    page = first.request.path

    database = app.extensions["hcss_db"]
    stopped = {"now": False}

    def stop_after_participant(_session, instance) -> None:
        if isinstance(instance, Participant):
            stopped["now"] = True

    def refuse(*_args) -> None:
        if stopped["now"]:
            raise OperationalError("SELECT", {}, _Stopped("server closed the connection"))

    event.listen(database.sessions, "loaded_as_persistent", stop_after_participant)
    event.listen(database.engine, "before_cursor_execute", refuse)
    try:
        answers = [client.get(page), client.get(page)]
    finally:
        event.remove(database.engine, "before_cursor_execute", refuse)
        event.remove(database.sessions, "loaded_as_persistent", stop_after_participant)
    assert [answer.status_code for answer in answers] == [503, 503]
    assert "Traceback" not in answers[0].get_data(as_text=True)
    assert all(answer.headers.get("Retry-After") for answer in answers)
