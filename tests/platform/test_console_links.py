"""The links page and links.csv: batches with their created and opened counts, each link's
batch, creation, first visit and status, "Copy all" of the usable links only, and a cost in
queries that does not grow with the number of participants."""

from __future__ import annotations

import csv
import io
import re
import threading

import httpx

from tests.support.console import statements, writers_held
from tests.support.inprocess import serving
from tests.support.trials import csrf_token_of

LINK = re.compile(r'data-copy="(http://localhost/p/[A-Za-z0-9_-]+)" data-usable="([01])"')


def _batch(console, count: int) -> list[str]:
    created = console.post("/console/participants", {"study": "demo", "count": str(count)})
    assert created.status_code == 303
    html = console.get(created.headers["Location"]).get_data(as_text=True)
    return [link for link, _ in LINK.findall(html)]


def test_batches_and_links_show_created_opened_and_status(app, console) -> None:
    first, second = _batch(console, 3), _batch(console, 2)
    visitor = app.test_client()
    for link in (first[0], second[1]):
        assert visitor.get(link, follow_redirects=True).status_code == 200
    (aborted_code,) = [
        code for code, row in console.progress().items() if row["stage"] == "not started"
    ][:1]
    assert console.act(aborted_code, "abort").status_code == 303

    html = console.get("/console/links").get_data(as_text=True)
    batches = re.findall(
        r'<tr data-batch="(\d)">.*?class="created-count">(\d+)</td><td class="opened-count">(\d+)',
        html,
        re.S,
    )
    assert batches == [("1", "3", "1"), ("2", "2", "1")]
    rows = list(csv.DictReader(io.StringIO(console.client.get("/console/links.csv").text)))
    assert [r["batch"] for r in rows] == ["batch 2"] * 2 + ["batch 1"] * 3  # newest first
    by_code = {r["code"]: r for r in rows}
    opened = [r for r in rows if r["opened"]]
    assert sorted(r["link"] for r in opened) == sorted([first[0], second[1]])
    assert {r["status"] for r in opened} == {"in_progress"}
    assert by_code[aborted_code]["status"] == "aborted" and not by_code[aborted_code]["opened"]
    assert all(r["created"] for r in rows)
    # Copy all: every link but the aborted one.
    usable = [link for link, flag in LINK.findall(html) if flag == "1"]
    assert len(usable) == 4 and by_code[aborted_code]["link"] not in usable


def test_the_links_page_costs_the_same_queries_for_5_or_60_participants(app, console) -> None:
    _batch(console, 5)
    with statements(app) as few:
        assert console.client.get("/console/links").status_code == 200
    with statements(app) as few_csv:
        assert console.client.get("/console/links.csv").status_code == 200
    for _ in range(11):
        _batch(console, 5)
    with statements(app) as many:
        html = console.client.get("/console/links").text
    with statements(app) as many_csv:
        assert console.client.get("/console/links.csv").status_code == 200
    assert html.count('class="copy"') == 60
    assert many["all"] == few["all"] <= 20, (few, many)
    assert many_csv["all"] == few_csv["all"] <= 20, (few_csv, many_csv)


FORM_KEY = re.compile(r'name="form_key" type="hidden" value="([A-Za-z0-9_-]+)"')


def _participants(app) -> int:
    from sqlalchemy import func, select

    from hcss.platform.models import Participant

    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalar(select(func.count()).select_from(Participant))


def test_a_create_form_sent_twice_makes_one_batch(app, console) -> None:
    """The Create form carries a key of its page: sent again (a double click past the page, a
    resend, a proxy's retry), it is answered with the batch the first sending made, and
    nothing new is created; a fresh page's form creates anew."""
    (key,) = FORM_KEY.findall(console.get("/console/").get_data(as_text=True))
    fields = {"study": "demo", "count": "3", "form_key": key}
    first = console.post("/console/participants", fields)
    assert first.status_code == 303 and "/console/links?codes=" in first.headers["Location"]
    again = console.post("/console/participants", fields)
    assert again.status_code == 303 and again.headers["Location"] == first.headers["Location"]
    assert _participants(app) == 3
    page = console.get(again.headers["Location"]).get_data(as_text=True)
    assert "this form was already sent, and nothing new was created" in page
    assert len(LINK.findall(page)) == 3
    # the links page itself is the batch: its batch list names one batch of 3
    assert len(LINK.findall(console.get("/console/links").get_data(as_text=True))) == 3

    (fresh,) = FORM_KEY.findall(console.get("/console/").get_data(as_text=True))
    assert fresh != key
    one = console.post("/console/participants", {"study": "demo", "count": "1", "form_key": fresh})
    assert "/console/participants/P" in one.headers["Location"]
    repeat = console.post(
        "/console/participants", {"study": "demo", "count": "1", "form_key": fresh}
    )
    assert repeat.headers["Location"] == one.headers["Location"]
    assert _participants(app) == 4


def test_a_create_form_key_that_is_malformed_or_another_accounts_creates_nothing(
    app, console
) -> None:
    from hcss.platform.console.accounts import create_experimenter
    from tests.support.console import Console, sign_in

    (key,) = FORM_KEY.findall(console.get("/console/").get_data(as_text=True))
    assert console.post("/console/participants", {"study": "demo", "count": "2", "form_key": key})
    for bad in (
        "short",
        "x" * 65,
        "x" * 100_000,
        "no spaces allowed here",
        "<script>alert(1)</script>",
    ):
        refused = console.post(
            "/console/participants", {"study": "demo", "count": "2", "form_key": bad}
        )
        assert refused.status_code == 303
        assert "not a form key" in console.get("/console/").get_data(as_text=True)
    # a NUL byte is refused before the form is read, as in every form of the platform
    nul = console.post(
        "/console/participants", {"study": "demo", "count": "2", "form_key": "a" * 20 + "\x00"}
    )
    assert nul.status_code == 400
    assert console.get("/console/").status_code == 200  # and the console still works
    assert _participants(app) == 2

    with app.extensions["hcss_db"].session_scope() as session:
        create_experimenter(session, "second", "another long password")
    other = Console(app=app, client=app.test_client())
    assert sign_in(other.client, "second", "another long password").status_code == 302
    other.get("/console/")
    taken = other.post("/console/participants", {"study": "demo", "count": "2", "form_key": key})
    assert taken.status_code == 409
    text = taken.get_data(as_text=True)
    assert "sent from another account" in text and "/p/" not in text  # none of its links
    assert _participants(app) == 2


def test_one_create_form_sent_twice_at_once_makes_one_batch(app, experimenter) -> None:
    """Two sendings of one form reach the server together, while another writer holds the
    database: both wait, one batch is stored, and both answers lead to it. Over HTTP to the
    served app, as a double click past the page sends them, on SQLite and PostgreSQL."""
    username, password = experimenter
    with serving(app) as base, httpx.Client(base_url=base) as client:
        login = client.get("/console/login").text
        signed = client.post(
            "/console/login",
            data={"csrf_token": csrf_token_of(login), "username": username, "password": password},
        )
        assert signed.status_code == 302
        page = client.get("/console/").text
        (key,) = FORM_KEY.findall(page)
        fields = {"csrf_token": csrf_token_of(page), "study": "demo", "count": "3"}
        answers: list[httpx.Response] = []

        def send() -> None:
            answers.append(client.post("/console/participants", data={**fields, "form_key": key}))

        senders = [threading.Thread(target=send) for _ in range(2)]
        with writers_held(app.extensions["hcss_db"]):
            for sender in senders:
                sender.start()
            threading.Event().wait(0.5)  # both are at the server, waiting for the database
        for sender in senders:
            sender.join(timeout=30)
    assert sorted(a.status_code for a in answers) == [303, 303], [a.text for a in answers]
    assert answers[0].headers["Location"] == answers[1].headers["Location"]
    assert _participants(app) == 3
