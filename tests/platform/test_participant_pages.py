"""The participant's pages around the questionnaires: declining, errors and stray addresses."""

from __future__ import annotations

from sqlalchemy import func, select

from hcss.platform.bots.participant import parse_page
from hcss.platform.models import ConsentRecord
from hcss.platform.study import views
from tests.support.study import new_participant, visitor


def _consents(app) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalar(select(func.count()).select_from(ConsentRecord))


def test_declining_asks_once_for_confirmation(demo_app) -> None:
    guest = visitor(demo_app, new_participant(demo_app))
    page = guest.page()
    first = guest.submit({"decision": "decline"}, page)
    assert first.status_code == 200 and 'id="confirm-decline"' in guest.html
    assert "If that is right, press Confirm" in guest.html
    assert _consents(demo_app) == 0  # nothing recorded yet
    # The page carries the question; confirming records the decline and ends the study.
    confirm_page = parse_page(guest.html)
    assert confirm_page.hidden.get("confirm_decline") == "yes"
    guest.submit({"decision": "decline"}, confirm_page)
    assert _consents(demo_app) == 1
    assert "You have chosen not to take part" in guest.client.get(
        f"/p/{guest.token}/stage"
    ).get_data(as_text=True)


def test_changing_ones_mind_on_the_confirmation_agrees(demo_app) -> None:
    guest = visitor(demo_app, new_participant(demo_app))
    guest.submit({"decision": "decline"})
    guest.submit({"decision": "agree"}, parse_page(guest.html))
    with demo_app.extensions["hcss_db"].session_scope() as session:
        (record,) = session.scalars(select(ConsentRecord))
        assert record.decision == "agree"
    assert 'data-stage="demographics"' in guest.client.get(f"/p/{guest.token}/stage").get_data(
        as_text=True
    )


def test_a_get_on_a_forms_post_address_goes_to_the_stage(demo_app) -> None:
    guest = visitor(demo_app, new_participant(demo_app))
    page = guest.page()
    response = guest.client.get(page.action)
    assert response.status_code == 302 and response.headers["Location"].endswith(
        f"/p/{guest.token}/stage"
    )
    stale = guest.client.get(f"/p/{guest.token}/stage/7/page_3")
    assert stale.status_code == 302


def test_error_pages_use_the_study_look_and_say_what_to_do(demo_app, monkeypatch) -> None:
    client = demo_app.test_client()
    token = new_participant(demo_app)

    bad_link = client.get("/p/not-a-real-token")
    html = bad_link.get_data(as_text=True)
    assert bad_link.status_code == 404
    assert 'class="page study" data-stage="error"' in html and "study.css" in html
    assert "There is no participant with this link" in html
    assert "Go to your current page" not in html  # there is no such page to offer

    nowhere = client.get("/no/such/page")
    assert nowhere.status_code == 404 and "Page not found" in nowhere.get_data(as_text=True)

    wrong_method = client.delete(f"/p/{token}")
    html = wrong_method.get_data(as_text=True)
    assert wrong_method.status_code == 405 and "cannot be opened like that" in html
    assert f'href="/p/{token}"' in html  # the way back to the participant's page

    no_csrf = client.post(f"/p/{token}/stage/0/consent", data={"decision": "agree"})
    html = no_csrf.get_data(as_text=True)
    assert no_csrf.status_code == 400 and "This page could not be sent" in html
    assert _consents(demo_app) == 0

    def broken(token: str):
        raise RuntimeError("database on fire")

    monkeypatch.setattr(views, "_flow", broken)
    demo_app.config["PROPAGATE_EXCEPTIONS"] = False
    failed = client.get(f"/p/{token}/stage")
    html = failed.get_data(as_text=True)
    assert failed.status_code == 500
    assert "Pages you finished earlier are saved" in html and "database on fire" not in html
    assert "Traceback" not in html and f'href="/p/{token}"' in html


def test_the_screen_check_refuses_a_small_or_bogus_window_on_the_server(demo_app) -> None:
    from tests.support.study import walk_to

    guest = visitor(demo_app, new_participant(demo_app))
    page = walk_to(guest, "screen_check", "form")
    assert "at least\n1024 x 620 pixels" in guest.html
    for width, height in (
        ("800", "600"),
        ("1024", "619"),
        ("abc", "900"),
        ("", ""),
        ("1" * 40, "900"),
        ("-5", "900"),
    ):
        response = guest.submit({"width": width, "height": height}, page)
        assert response.status_code == 200, (width, height)
        assert 'class="error' in guest.html and 'data-stage="screen_check"' in guest.html
    # A NUL byte is refused before the form sees it (hcss.platform.guards.hardening).
    assert guest.submit({"width": "1280\x00", "height": "900"}, page).status_code == 400
    assert "Your window is 800 x 600 pixels" in guest.client.post(
        page.action, data=dict(page.hidden) | {"width": "800", "height": "600"}
    ).get_data(as_text=True)
    assert guest.submit({"width": "1280", "height": "800"}, page).status_code == 302
    assert guest.page().stage == "training"


def test_the_site_without_a_link_sends_the_visitor_to_theirs(demo_app) -> None:
    response = demo_app.test_client().get("/")
    assert response.status_code == 200
    assert "Please open the personal link you were given." in response.get_data(as_text=True)
