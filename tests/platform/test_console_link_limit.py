"""Participant links one experimenter account may create are rate limited.

An experimenter account, or a session stolen from one, must not make
participants without bound (each is a link, a row in every export and a row
of the live table). Past `LINKS_PER_EXPERIMENTER` in the window the console
answers 429 with a message, creates nothing, and says so in the audit log.
"""

from __future__ import annotations

import threading

from sqlalchemy import func, select

from hcss.platform.console.accounts import create_experimenter
from hcss.platform.models import AuditRecord, Participant
from tests.support.console import Console, sign_in


def _participants(app) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return int(session.scalar(select(func.count()).select_from(Participant)) or 0)


def test_links_past_the_limit_answer_429_create_nothing_and_are_audited(app, console) -> None:
    app.config["LINKS_PER_EXPERIMENTER"] = (60, 3600.0)
    assert console.post("/console/participants", {"count": "50"}).status_code == 303
    refused = console.post("/console/participants", {"count": "11"})
    assert refused.status_code == 429
    text = refused.get_data(as_text=True)
    assert "60 participant links per hour" in text and "10 more" in text
    assert int(refused.headers["Retry-After"]) > 0
    assert _participants(app) == 50  # nothing of the refused batch
    assert console.post("/console/participants", {"count": "10"}).status_code == 303
    assert console.post("/console/participants", {"count": "1"}).status_code == 429
    assert _participants(app) == 60

    with app.extensions["hcss_db"].session_scope() as session:
        audits = session.scalars(
            select(AuditRecord).where(AuditRecord.action == "link_limit")
        ).all()
        assert [(a.experimenter, a.row_counts["requested"]) for a in audits] == [
            ("alice", 11),
            ("alice", 1),
        ]
    assert "link_limit" in console.get("/console/").get_data(as_text=True)

    # Another account has its own allowance; the window passes for the first.
    with app.extensions["hcss_db"].session_scope() as session:
        create_experimenter(session, "bob", "another long password")
    bob = Console(app=app, client=app.test_client())
    assert sign_in(bob.client, "bob", "another long password").status_code == 302
    bob.get("/console/")
    assert bob.post("/console/participants", {"count": "5"}).status_code == 303
    app.extensions["hcss_runner"].clock.now += 3601.0
    assert console.post("/console/participants", {"count": "50"}).status_code == 303
    assert _participants(app) == 115


def test_a_batch_over_the_whole_limit_is_refused_and_no_limit_means_none(app, console) -> None:
    app.config["LINKS_PER_EXPERIMENTER"] = (3, 60.0)
    refused = console.post("/console/participants", {"count": "4"})
    assert refused.status_code == 429 and "3 participant links per minute" in (
        refused.get_data(as_text=True)
    )
    app.config["LINKS_PER_EXPERIMENTER"] = None
    for _ in range(3):
        assert console.post("/console/participants", {"count": "50"}).status_code == 303
    assert _participants(app) == 150


def test_twenty_batches_at_once_never_pass_the_limit(app, console) -> None:
    """20 batches of 50 sent together against a limit of 500: exactly 500 links, each batch
    whole or refused whole (the count and the inserts are one step per account)."""
    app.config["LINKS_PER_EXPERIMENTER"] = (500, 3600.0)
    clients = []
    for _ in range(20):
        client = app.test_client()
        for cookie in console.client._cookies.values():  # the same signed-in session
            client.set_cookie(cookie.key, cookie.value, domain=cookie.domain)
        clients.append(client)
    start = threading.Barrier(len(clients))
    answers: list[int] = []

    def create(client) -> None:
        start.wait()
        answer = client.post(
            "/console/participants", data={"csrf_token": console.csrf, "count": "50"}
        )
        answers.append(answer.status_code)

    threads = [threading.Thread(target=create, args=(client,)) for client in clients]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(60)
    assert sorted(answers) == [303] * 10 + [429] * 10, answers
    assert _participants(app) == 500
