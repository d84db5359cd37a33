"""Forms: invalid answers re-render with messages and keep the rest; no resubmission, no skipping.

Also consent: declining keeps nothing but the refusal; a token opens only its
own participant's pages; models are never named on a participant's page.
"""

from __future__ import annotations

import re

from sqlalchemy import func, select

from hcss.platform.models import (
    ConsentRecord,
    Participant,
    QuestionnaireItem,
    StageEvent,
    StudyEnrolment,
)
from hcss.platform.study import load_study
from hcss.platform.study.enrolment import cell_counts
from tests.support.counting import count_rows
from tests.support.study import errors_in, events, new_participant, visitor


def _checked(html: str, name: str) -> str | None:
    for tag in re.findall(r"<input[^>]*>", html):
        if f'name="{name}"' in tag and " checked" in tag:
            return re.search(r'value="([^"]*)"', tag).group(1)
    return None


def _agree(v) -> None:
    assert v.submit({"decision": "agree"}).status_code == 302


def test_invalid_demographics_rerender_with_messages_and_keep_answers(demo_app) -> None:
    v = visitor(demo_app, new_participant(demo_app))
    _agree(v)
    page = v.page()
    assert page.stage == "demographics"
    response = v.submit(
        {
            "gender": "dragon",
            "education": "master",
            "colour_vision": "no",
            "video_games": "9",
            "robots": "3",
        },
        page,
    )
    assert response.status_code == 200
    messages = errors_in(v.html)
    assert "This question needs an answer." in messages  # age_band missing
    assert any(m.startswith("Please choose one of:") for m in messages)  # gender
    assert "Must be between 1 and 5, got 9." in messages  # video_games
    assert _checked(v.html, "education") == "master" and _checked(v.html, "robots") == "3"
    assert count_rows(demo_app, QuestionnaireItem) == 0
    assert v.page().stage == "demographics"  # still here, nothing recorded


def test_nasa_tlx_and_ranking_errors_come_from_the_instruments(demo_app) -> None:
    from tests.support.study import walk_to

    token = new_participant(demo_app, is_bot=True)
    v = visitor(demo_app, token)
    walk_to(v, "nasa_tlx", "ratings")
    ratings = {
        "mental_demand": "33",
        "physical_demand": "10",
        "temporal_demand": "50",
        "performance": "100",
        "effort": "0",
        "frustration": "5",
    }
    assert v.submit(ratings).status_code == 200
    assert "Must be a multiple of 5, got 33." in errors_in(v.html)
    assert _checked(v.html, "performance") == "100"
    assert v.submit(ratings | {"mental_demand": "35"}).status_code == 302
    page = v.page()
    assert page.step == "comparisons" and len(page.radios) == 15
    walk_to(v, "ranking", "form")
    ranks = {
        f"{d}_{label}": "1"
        for d in ("responsiveness", "performance", "comprehension")
        for label in ("first", "second", "third")
    }
    ranks |= {
        "performance_second": "2",
        "performance_third": "3",
        "comprehension_second": "2",
        "comprehension_third": "3",
    }
    assert v.submit(ranks).status_code == 200
    assert errors_in(v.html) == [
        "Each collective type needs a different rank: use 1, 2 and 3 once each."
    ]
    assert _checked(v.html, "comprehension_third") == "3"
    assert "first collective type" in v.html and not re.search(r"\bM[123]\b", v.html)


def test_resubmission_and_skipping_are_refused_and_change_nothing(demo_app) -> None:
    token = new_participant(demo_app)
    v = visitor(demo_app, token)
    consent_page = v.page()
    _agree(v)
    again = v.submit({"decision": "agree"}, consent_page)
    assert again.status_code == 409
    assert "already been submitted" in v.html
    assert count_rows(demo_app, ConsentRecord) == 1
    before = len(events(demo_app, token))
    skip = v.client.post(
        f"/p/{token}/stage/2/instructions", data={"csrf_token": consent_page.hidden["csrf_token"]}
    )
    assert skip.status_code == 409 and "must be done in order" in skip.get_data(as_text=True)
    assert len(events(demo_app, token)) == before
    assert v.page().stage == "demographics"


def test_declining_consent_keeps_only_the_refusal(demo_app) -> None:
    token = new_participant(demo_app)
    v = visitor(demo_app, token)
    page = v.page()
    assert page.stage == "consent" and "Consent to take part" in v.html
    assert v.submit({"decision": "decline"}, page).status_code == 200  # asked to confirm
    confirmed = {"decision": "decline", "confirm_decline": "yes"}
    assert v.submit(confirmed, page).status_code == 302
    assert v.page().stage == "declined" and "chosen not to take part" in v.html
    assert v.submit({"decision": "agree"}, page).status_code == 409  # no change of mind by replay
    with demo_app.extensions["hcss_db"].session_scope() as session:
        (record,) = session.scalars(select(ConsentRecord))
        assert (record.version, record.decision) == ("v1", "decline") and record.at is not None
        assert session.scalar(select(func.count()).select_from(QuestionnaireItem)) == 0
        kinds = [(e.stage, e.kind) for e in session.scalars(select(StageEvent))]
        assert kinds == [("consent", "entered"), ("consent", "submitted")]
        assert sum(cell_counts(session, load_study("demo"), "real").values()) == 0


def test_a_token_opens_only_its_own_pages(demo_app) -> None:
    a, b = new_participant(demo_app), new_participant(demo_app)
    assert demo_app.test_client().get("/p/not-a-token").status_code == 404
    va, vb = visitor(demo_app, a), visitor(demo_app, b)
    page_a = va.page()
    _agree(va)
    # B's browser replaying A's consent form at B's own URL answers for B only, as B.
    vb.page()
    with demo_app.extensions["hcss_db"].session_scope() as session:
        ids = {p.token: p.id for p in session.scalars(select(Participant))}
        consents = {c.participant_id for c in session.scalars(select(ConsentRecord))}
        assert consents == {ids[a]}
        assert session.scalar(select(func.count()).select_from(StudyEnrolment)) == 2
    assert f"/p/{a}/" in page_a.action and b not in va.html


def test_tlx_pairs_keep_their_random_order_and_it_is_stored(demo_app) -> None:
    from hcss.questionnaires import tlx
    from tests.support.study import walk_to

    token = new_participant(demo_app, is_bot=True)
    v = visitor(demo_app, token)
    walk_to(v, "nasa_tlx", "comparisons")
    shown = list(v.page().radios)
    assert sorted(shown) == list(tlx.PAIR_KEYS) and shown != list(tlx.PAIR_KEYS)
    (entered,) = [
        e for e in events(demo_app, token) if e.step == "comparisons" and e.kind == "entered"
    ]
    record = entered.detail["presentation"]
    assert [p.pair.key for p in tlx.order_from_record(record)] == shown
    first = tlx.order_from_record(record)[0]
    assert v.page().radios[first.pair.key] == [first.left, first.right]  # sides as stored
    assert list(v.page().radios) == shown  # a refresh shows the same order
    choices = {key: v.page().radios[key][0] for key in shown}
    assert v.submit(choices).status_code == 302
    with demo_app.extensions["hcss_db"].session_scope() as session:
        stored = {
            r.item: r.value
            for r in session.scalars(
                select(QuestionnaireItem).where(QuestionnaireItem.instrument == "nasa_tlx")
            )
        }
    assert {k: stored[k] for k in record} == record and {k: stored[k] for k in choices} == choices
