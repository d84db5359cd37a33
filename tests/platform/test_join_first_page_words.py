"""The study link's first page says what its check records, and that is what a screen-out
records; in MTurk's frame, which checks nothing, no sentence about a check is shown."""

from __future__ import annotations

import re
from urllib.parse import urlencode

from sqlalchemy import select

from hcss.platform.models import ScreenOut
from tests.support.recruitment import demo_variant

HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')
PHONE = {"width": "375", "height": "812", "mobile": "1", "missing": "eventsource"}
HIT = {
    "workerId": "W1",
    "assignmentId": "A1",
    "hitId": "H1",
    "turkSubmitTo": "https://www.mturk.com",
}


def test_the_first_page_names_what_a_screen_out_keeps_and_that_is_all_it_keeps(app) -> None:
    client = app.test_client()
    first = client.get("/join/demo?PROLIFIC_PID=phone1&STUDY_ID=s&SESSION_ID=x")
    text = " ".join(first.get_data(as_text=True).split())
    assert "Nothing about you is recorded by this check" not in text
    said = (
        "the study keeps a note of the visit (your recruitment id, your window's size, "
        "whether the device is a phone or tablet and which browser features are missing)"
    )
    assert said in text
    fields = dict(HIDDEN.findall(first.get_data(as_text=True)))
    client.post("/join/demo", data=fields | PHONE)
    with app.extensions["hcss_db"].session_scope() as session:
        (row,) = session.scalars(select(ScreenOut))
        kept = {
            "recruitment id": row.recruitment_id,
            "window's size": (row.width, row.height),
            "phone or tablet": row.mobile,
            "browser features": row.missing,
        }
        assert kept == {
            "recruitment id": "phone1",
            "window's size": (375, 812),
            "phone or tablet": True,
            "browser features": "eventsource",
        }
        # Besides those, the row holds only where it came from and why it was turned away.
        named = {"recruitment_id", "width", "height", "mobile", "missing"}
        rest = {c.name for c in ScreenOut.__table__.columns} - named
        assert rest == {"id", "created_at", "study", "source", "reasons"}


def test_the_mturk_frame_says_nothing_about_a_check(app, tmp_path, monkeypatch) -> None:
    name = demo_variant(tmp_path / "studies", monkeypatch, "hitwords", {"mturk": "true"})
    framed = app.test_client().get(
        f"/join/{name}?{urlencode(HIT)}", headers={"Sec-Fetch-Dest": "iframe"}
    )
    page = framed.get_data(as_text=True)
    assert 'id="join-framed"' in page
    assert "check" not in " ".join(re.sub(r"<[^>]+>", " ", page).split()).lower()
