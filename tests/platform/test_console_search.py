"""The console's search looks through every participant on the server, not the page shown:
by code, recruitment id, recruiter session id and status, with the match marked."""

from __future__ import annotations

from sqlalchemy import select

from hcss.platform.models import Participant, Recruitment


def _two_hundred(app) -> tuple[str, str]:
    """200 participants; the first made (the last page, newest first) came from Prolific."""
    with app.extensions["hcss_db"].session_scope() as session:
        people = [Participant(study="demo") for _ in range(200)]
        session.add_all(people)
        session.flush()
        session.add(
            Recruitment(
                participant_id=people[0].id,
                study="demo",
                source="prolific",
                recruitment_id="5f8a1b2c3d4e5f6a7b8c9d0e",
                recruiter_study_id="STUDY77",
                recruiter_session_id="sess-9q8w7e",
            )
        )
        return people[0].code, people[1].code


def test_a_participant_on_the_last_page_is_found_from_page_one(app, console) -> None:
    oldest, _ = _two_hundred(app)
    first_page = console.client.get("/console/progress.json").get_json()
    assert first_page["pages"] == 8 and oldest not in {
        p["code"] for p in first_page["participants"]
    }
    for search in (oldest, oldest.lower()[2:], "5F8A1B2C", "sess-9q8", "prolific 5f8a"):
        answer = console.client.get("/console/progress.json", query_string={"q": search})
        found = answer.get_json()
        assert [p["code"] for p in found["participants"]] == [oldest], search
        assert (found["total"], found["pages"], found["everyone"]) == (1, 1, 200)
    # The page itself, as a link with ?q= is opened: the match is marked.
    html = console.client.get("/console/", query_string={"q": "5f8a1b"}).text
    assert "<mark>5f8a1b</mark>2c3d4e5f6a7b8c9d0e" in html and html.count('<tr data-code="') == 1
    assert "matching “5f8a1b”" in html
    nothing = console.client.get("/console/progress.json", query_string={"q": "no-such-id"})
    assert nothing.get_json()["participants"] == [] and nothing.get_json()["total"] == 0


def test_a_search_for_a_status_finds_it_on_every_page(app, console) -> None:
    _, second_oldest = _two_hundred(app)
    with app.extensions["hcss_db"].session_scope() as session:
        token = session.scalars(
            select(Participant.token).where(Participant.code == second_oldest)
        ).one()
    assert app.test_client().get(f"/p/{token}", follow_redirects=True).status_code == 200
    assert console.act(second_oldest, "pause").status_code == 303
    for search in ("paused", "in progress", "PAUSED"):
        found = console.client.get("/console/progress.json", query_string={"q": search})
        assert [p["code"] for p in found.get_json()["participants"]] == [second_oldest], search
    started = console.client.get("/console/progress.json", query_string={"q": "not started"})
    assert started.get_json()["total"] == 199 and started.get_json()["pages"] == 8
    last = console.client.get(
        "/console/progress.json", query_string={"q": "not started", "page": "8"}
    ).get_json()
    assert len(last["participants"]) == 199 - 7 * 25
    assert (
        console.client.get(
            "/console/progress.json", query_string={"q": "demo not started"}
        ).get_json()["total"]
        == 199
    )
    assert (
        console.client.get(
            "/console/progress.json", query_string={"q": "original not started"}
        ).get_json()["total"]
        == 0
    )
