"""The console's live table and batches: the study chosen, links to hand out, actions that apply."""

from __future__ import annotations

import csv
import io
import re

import pytest
from sqlalchemy import select

from hcss.platform.bots.participant import run_bots
from hcss.platform.console.interventions import ConsoleError, change_participant_state
from hcss.platform.console.participant_table import progress_page
from hcss.platform.models import ConsoleAction, Participant, StudyEnrolment
from hcss.platform.study.stages import sequence
from hcss.platform.study.studyfile import load_study

LINK = re.compile(r'value="(http://localhost/p/[A-Za-z0-9_-]+)"')


def _enrolment(app, code: str) -> StudyEnrolment | None:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalars(
            select(StudyEnrolment)
            .join(Participant, Participant.id == StudyEnrolment.participant_id)
            .where(Participant.code == code)
        ).first()


def test_a_batch_on_a_chosen_study_lists_every_link_and_a_csv(app, console) -> None:
    assert app.config.get("STUDY") in (None, "original")  # the server's default is not demo
    index = console.get("/console/").get_data(as_text=True)
    assert '<option value="demo">' in index and 'value="original"' in index

    response = console.post("/console/participants", {"study": "demo", "count": "3"})
    assert response.status_code == 303
    page = console.get(response.headers["Location"])
    html = page.get_data(as_text=True)
    links = LINK.findall(html)
    assert len(links) == 3 and html.count('class="copy"') == 3
    codes = set(console.progress())
    assert len(codes) == 3
    rows = {row["code"]: row for row in console.progress().values()}
    assert {(r["study"], r["cell"], r["stage"]) for r in rows.values()} == {
        ("demo", None, "not started")
    }

    csv_url = re.search(r'href="(/console/links\.csv\?[^"]+)"', html).group(1)
    download = console.client.get(csv_url.replace("&amp;", "&"))
    assert download.status_code == 200 and download.mimetype == "text/csv"
    assert "attachment" in download.headers["Content-Disposition"]
    table = list(csv.DictReader(io.StringIO(download.get_data(as_text=True))))
    assert {row["code"] for row in table} == codes
    assert sorted(row["link"] for row in table) == sorted(links)
    assert {(row["study"], row["cell"], row["pilot"]) for row in table} == {("demo", "", "no")}

    # The participant's first visit enrols them in the chosen study, not the default one.
    first = table[0]
    participant = app.test_client()
    assert participant.get(first["link"], follow_redirects=True).status_code == 200
    enrolment = _enrolment(app, first["code"])
    assert enrolment is not None and enrolment.study == "demo"
    row = console.progress()[first["code"]]
    assert (row["study"], row["cell"]) == ("demo", enrolment.cell)
    count = len(sequence(load_study("demo"), enrolment))
    assert (row["stage"], row["stage_number"], row["stage_count"]) == ("consent", 1, count)


@pytest.mark.parametrize(
    "fields",
    [
        {"study": "nope", "count": "1"},
        {"study": "../original", "count": "1"},
        {"study": "demo\x00", "count": "1"},
        {"study": "demo", "count": "1", "cell": "99"},  # demo has 8 cells
    ],
)
def test_an_unknown_study_or_cell_creates_nobody(app, console, fields) -> None:
    response = console.post("/console/participants", fields)
    if (
        "\x00" in fields["study"]
    ):  # refused before the form sees it (hcss.platform.guards.hardening)
        assert response.status_code == 400
    else:
        assert response.status_code == 303 and response.headers["Location"] == "/console/"
    assert console.progress() == {}
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalars(select(ConsoleAction)).first() is None


@pytest.mark.parametrize(
    ("query", "status"),
    [
        ("codes=P0000000%00", 400),
        ("codes=" + ",".join(["PAAAAAAAA"] * 501), 400),
        ("codes=PFFFFFFFF", 404),
        ("codes=<script>", 400),
    ],
)
def test_the_links_page_refuses_bad_code_lists(console, query, status) -> None:
    assert console.client.get(f"/console/links?{query}").status_code == status
    assert console.client.get(f"/console/links.csv?{query}").status_code == status


def test_the_links_page_needs_a_signed_in_experimenter(app, console) -> None:
    console.post("/console/participants", {"count": "2"})
    codes = ",".join(console.progress())
    stranger = app.test_client()
    for path in ("/console/links", "/console/links.csv"):
        response = stranger.get(f"{path}?codes={codes}")
        assert response.status_code == 302 and "/console/login" in response.headers["Location"]


def test_each_row_offers_only_the_actions_that_apply(app, console) -> None:
    console.post("/console/participants", {"count": "1", "study": "demo"})
    (code,) = console.progress()
    # Not started: nothing to pause; an abort keeps the link from opening.
    assert console.progress()[code]["actions"] == ["abort", "mark_pilot"]
    assert console.progress()[code]["time_in_stage_s"] is None
    (link,) = LINK.findall(console.get("/console/links").get_data(as_text=True))
    app.test_client().get(link, follow_redirects=True)  # the first visit
    offered = ["pause", "abort", "skip_stage", "mark_pilot"]
    assert console.progress()[code]["actions"] == offered
    index = console.get("/console/").get_data(as_text=True)
    row = index[index.index(f'<tr data-code="{code}"') :]
    row = row[: row.index("</tr>")]
    assert re.findall(r'data-action="(\w+)"', row) == offered

    # A button in the table comes back to the table.
    response = console.post(f"/console/participants/{code}/pause", {"next": "/console/"})
    assert response.status_code == 303 and response.headers["Location"] == "/console/"
    assert console.progress()[code]["actions"] == ["resume", "abort", "skip_stage", "mark_pilot"]
    # ... and a "next" leading elsewhere is not followed.
    response = console.post(f"/console/participants/{code}/resume", {"next": "https://evil/"})
    assert response.headers["Location"] == "/console/"
    assert console.progress()[code]["state"] == "active"
    console.act(code, "abort")
    row = console.progress()[code]
    assert (row["state"], row["actions"]) == ("aborted", ["mark_pilot"])
    page = console.get(f"/console/participants/{code}").get_data(as_text=True)
    assert re.findall(r'data-action="(\w+)"', page) == ["mark_pilot"]


@pytest.mark.slow  # a bot walks the whole demo study (about 10 s)
def test_a_participant_who_finished_shows_completed_and_cannot_be_paused(demo_app) -> None:
    (report,) = run_bots(demo_app, 1)
    database = demo_app.extensions["hcss_db"]
    with demo_app.app_context(), database.session_scope() as session:
        (row,) = progress_page(session, demo_app.extensions["hcss_runner"].clock()).rows
        participant = session.scalars(select(Participant)).one()
    assert row.code == report.code
    assert (row.status, row.state, row.stage) == ("completed", "active", "completed")
    assert row.stage_number == row.stage_count and row.study == "demo" and row.cell is not None
    assert row.actions == ["mark_pilot"] and row.is_bot
    with demo_app.app_context():
        for action in ("pause", "abort"):
            with pytest.raises(ConsoleError, match="completed the study"):
                change_participant_state(
                    database, demo_app.extensions["hcss_live"], participant, None, action
                )
    with database.session_scope() as session:
        assert session.scalars(select(ConsoleAction)).first() is None


def test_every_link_can_be_listed_again_and_the_console_script_runs_once(console) -> None:
    console.post("/console/participants", {"count": "2", "study": "demo"})
    console.post("/console/participants", {"count": "2"})
    codes = set(console.progress())
    for query in ("", "?codes="):
        page = console.get(f"/console/links{query}")
        assert page.status_code == 200
        assert set(re.findall(r'<tr data-code="([A-Z0-9]+)"', page.get_data(as_text=True))) == codes
    download = console.client.get("/console/links.csv")
    assert {
        row["code"] for row in csv.DictReader(io.StringIO(download.get_data(as_text=True)))
    } == codes
    index = console.get("/console/").get_data(as_text=True)
    assert 'id="all-links"' in index
    # One copy of the table's script: two would poll twice and ask every question twice.
    assert index.count("console.js") == 1


def test_a_stuck_participant_is_moved_past_their_step_audited(app, console, tmp_path) -> None:
    from click.testing import CliRunner

    from hcss.cli import main
    from tests.support.study import visitor

    console.post("/console/participants", {"count": "1", "study": "demo"})
    (code,) = console.progress()
    (link,) = LINK.findall(console.get("/console/links").get_data(as_text=True))
    guest = visitor(app, link.rsplit("/", 1)[-1])
    guest.page()
    refused = console.act(code, "skip_stage")  # consent: never skipped
    assert refused.status_code == 303
    assert "cannot be skipped" in console.get("/console/").get_data(as_text=True)
    assert console.progress()[code]["stage"] == "consent"

    guest.submit({"decision": "agree"})
    guest.page()
    assert 'data-stage="demographics"' in guest.html
    assert console.act(code, "skip_stage").status_code == 303
    assert "skipped stage 2 demographics" in console.get("/console/").get_data(as_text=True)
    assert console.progress()[code]["stage"].startswith("mental_rotation")
    guest.page()
    assert 'data-stage="mental_rotation"' in guest.html
    with app.extensions["hcss_db"].session_scope() as session:
        (action,) = session.scalars(
            select(ConsoleAction).where(ConsoleAction.action == "skip_stage")
        ).all()
        assert action.detail == "stage 2 demographics form" and action.experimenter_id is not None
    out = tmp_path / "export"
    url = app.config["DATABASE_URL"]
    assert CliRunner().invoke(main, ["export", str(out), "--database-url", url]).exit_code == 0
    timings = {r["stage"]: r for r in csv.DictReader((out / "stage_timings.csv").open())}
    assert timings["demographics"]["skipped"] == "true" and timings["demographics"]["submitted_at"]
    assert timings["consent"]["skipped"] == "false"


def test_bulk_actions_on_ticked_rows_are_audited_one_by_one(app, console) -> None:
    console.post("/console/participants", {"count": "3"})
    first, second, third = sorted(console.progress())
    response = console.client.post(
        "/console/bulk",
        data={"csrf_token": console.csrf, "action": "mark_pilot", "codes": [first, second]},
    )
    assert response.status_code == 303
    rows = console.progress()
    assert (rows[first]["is_pilot"], rows[second]["is_pilot"], rows[third]["is_pilot"]) == (
        True,
        True,
        False,
    )
    console.client.post(
        "/console/bulk",
        data={"csrf_token": console.csrf, "action": "abort", "codes": [first, third]},
    )
    assert [console.progress()[c]["state"] for c in (first, second, third)] == [
        "aborted",
        "active",
        "aborted",
    ]
    with app.extensions["hcss_db"].session_scope() as session:
        kinds = sorted(
            a.action for a in session.scalars(select(ConsoleAction)) if a.action != "create"
        )
    assert kinds == ["abort", "abort", "mark_pilot", "mark_pilot"]
    # Bad input changes nothing: an unknown action, a malformed code, no CSRF token.
    for data in (
        {"csrf_token": console.csrf, "action": "withdraw", "codes": [second]},
        {"csrf_token": console.csrf, "action": "abort", "codes": ["<x>"]},
        {"action": "abort", "codes": [second]},
    ):
        assert console.client.post("/console/bulk", data=data).status_code == 400
    assert console.progress()[second]["state"] == "active"
    index = console.get("/console/").get_data(as_text=True)
    assert index.count('form="bulk-form"') == 3 and 'id="bulk-apply"' in index


def test_bulk_pause_and_resume(app, console) -> None:
    console.post("/console/participants", {"count": "2", "study": "demo"})
    links = LINK.findall(console.get("/console/links").get_data(as_text=True))
    for link in links:
        assert app.test_client().get(link, follow_redirects=True).status_code == 200
    codes = sorted(console.progress())
    for action, state in (("pause", "paused"), ("resume", "active")):
        answer = console.client.post(
            "/console/bulk", data={"csrf_token": console.csrf, "action": action, "codes": codes}
        )
        assert answer.status_code == 303
        assert {row["state"] for row in console.progress().values()} == {state}
    with app.extensions["hcss_db"].session_scope() as session:
        kinds = [a.action for a in session.scalars(select(ConsoleAction)) if a.action != "create"]
    assert sorted(kinds) == ["pause", "pause", "resume", "resume"]


@pytest.mark.parametrize("action", ["pause", "mark_pilot"])
def test_two_experimenters_acting_at_once_on_a_session_between_trials_write_one_action(
    app, console, experimenter, monkeypatch, action
) -> None:
    """Two experimenters, each signed in to the console, press Pause (or Mark pilot) for one
    participant on a questionnaire page at the same instant: one action is written, and the
    other's page says it was done already. No trial runs, so no trial's lock orders them;
    both read the session's state before either writes (held together at a barrier, which
    times out when the second cannot read yet)."""
    import contextlib
    import html
    import threading

    from hcss.platform.console import interventions
    from tests.support.console import Console, sign_in
    from tests.support.study import visitor

    console.post("/console/participants", {"count": "1", "study": "demo"})
    (code,) = console.progress()
    (link,) = LINK.findall(console.get("/console/links").get_data(as_text=True))
    guest = visitor(app, link.rsplit("/", 1)[-1])
    guest.page()
    guest.submit({"decision": "agree"})
    assert action in console.progress()[code]["actions"]
    other = Console(app=app, client=app.test_client())
    assert sign_in(other.client, *experimenter).status_code == 302
    other.get("/console/")

    together = threading.Barrier(2, timeout=1.0)
    read = "participant_state" if action == "pause" else "is_pilot"
    real = getattr(interventions, read)

    def read_together(*args):
        state = real(*args)
        with contextlib.suppress(threading.BrokenBarrierError):
            together.wait()
        return state

    monkeypatch.setattr(interventions, read, read_together)
    pages: list[str] = []

    def press(experimenter_s: Console) -> None:
        pressed = experimenter_s.act(code, action)
        assert pressed.status_code == 303
        page = experimenter_s.get(pressed.headers["Location"]).get_data(as_text=True)
        pages.append(html.unescape(page))

    consoles = [threading.Thread(target=press, args=(each,)) for each in (console, other)]
    for thread in consoles:
        thread.start()
    for thread in consoles:
        thread.join(timeout=30)
    done = f"{code}: {action.replace('_', ' ')} done"
    already = {
        "pause": f"{code}'s session is already paused",
        "mark_pilot": f"{code} is already a pilot",
    }[action]
    assert len(pages) == 2
    assert sorted(done in page for page in pages) == [False, True]
    assert sorted(already in page for page in pages) == [False, True]
    with app.extensions["hcss_db"].session_scope() as session:
        written = session.scalars(select(ConsoleAction).where(ConsoleAction.action == action)).all()
    assert len(written) == 1
