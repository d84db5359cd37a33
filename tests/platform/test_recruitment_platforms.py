"""Each recruitment site's side of the study link, over HTTP (MTurk in a browser: test_mturk_browser).

- SONA: its client-side completion URL ends in `survey_code=XXXX`, XXXX being the
  id it sent as `?id=` (sona-systems.com, "External Study Credit Granting"); the
  study file writes `survey_code={id}` and each participant's debrief carries
  their own code, URL-encoded. An unknown placeholder stops the file loading.
- Prolific: a full study asks the visitor to return the submission, with the
  study's return code, not the screen-out code; a timed-out participant gets the
  time-out code, their participant code and the link back; one whose session the
  experimenter ended is asked to return the submission.
- MTurk: only an MTurk study's link may be framed, by MTurk's origins; every
  other page refuses frames. `turkSubmitTo` is MTurk's or the visit is refused;
  the debrief's form posts to its externalSubmit, which its CSP allows.
"""

from __future__ import annotations

import html
import re
from urllib.parse import urlencode

import pytest
from sqlalchemy import func, select

from hcss.platform.bots.participant import parse_page
from hcss.platform.models import Participant, Recruitment
from hcss.platform.study.studyfile import StudyFileError, load_study
from tests.support.recruitment import console_outcomes, demo_variant

LAPTOP = {"width": "1366", "height": "657", "mobile": "0", "missing": ""}
HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')
SONA_CREDIT = (
    '"https://uni.sona-systems.com/webstudy_credit.aspx'
    '?experiment_id=123&credit_token=4e48f9b638a&survey_code={id}"'
)
MTURK = "https://www.mturk.com"


def _short(directory, monkeypatch, name: str, online: dict[str, str]) -> str:
    """A demo variant that goes from consent straight to the debrief."""
    demo_variant(directory, monkeypatch, name, online)
    path = directory / f"{name}.toml"
    text = path.read_text(encoding="utf-8")
    text = re.sub(r"before = \[[^\]]*\]", 'before = ["consent"]', text, count=1)
    text = re.sub(r"per_model = \[[^\]]*\]", "per_model = []", text, count=1)
    text = re.sub(r"after = \[[^\]]*\]", 'after = ["debrief"]', text, count=1)
    path.write_text(text, encoding="utf-8")
    return name


def _start(client, study: str, **params: str):
    """The study link's first page, then Start as a maximised laptop browser posts it."""
    first = client.get(f"/join/{study}?{urlencode(params)}")
    if 'id="join-form"' not in first.get_data(as_text=True):
        return first
    fields = dict(HIDDEN.findall(first.get_data(as_text=True)))
    return client.post(f"/join/{study}", data=fields | LAPTOP)


def _consent_to_debrief(client, study: str, **params: str) -> str:
    """Join, agree to consent; the debrief's HTML."""
    joined = _start(client, study, **params)
    assert joined.status_code == 302, joined.get_data(as_text=True)
    consent = parse_page(client.get(joined.location, follow_redirects=True).get_data(as_text=True))
    assert consent.stage == "consent"
    assert (
        client.post(consent.action, data=consent.hidden | {"decision": "agree"}).status_code == 302
    )
    page = client.get(joined.location, follow_redirects=True).get_data(as_text=True)
    assert 'data-stage="debrief"' in page
    return page


def test_each_sona_participant_is_sent_to_the_credit_url_with_their_own_survey_code(
    app, tmp_path, monkeypatch
) -> None:
    study = _short(
        tmp_path / "studies",
        monkeypatch,
        "sonastudy",
        {"completion_url": SONA_CREDIT, "redirect": "true", "mturk": "false"},
    )
    credit = "https://uni.sona-systems.com/webstudy_credit.aspx?experiment_id=123&amp;credit_token=4e48f9b638a&amp;survey_code="
    for survey_code in ("4123", "98765"):
        page = _consent_to_debrief(app.test_client(), study, id=survey_code)
        assert f'id="completion-link" href="{credit}{survey_code}"' in page
        assert f'content="5; url={credit}{survey_code}"' in page  # the redirect, too
    # Filled URL-encoded: an id with characters that mean something in a URL stays one value.
    prolific = _short(
        tmp_path / "studies",
        monkeypatch,
        "prolificstudy",
        {"completion_url": '"https://example.org/done?pid={PROLIFIC_PID}&s={SESSION_ID}"'},
    )
    page = _consent_to_debrief(
        app.test_client(), prolific, PROLIFIC_PID="p+1@x", STUDY_ID="s", SESSION_ID="a:b"
    )
    assert 'href="https://example.org/done?pid=p%2B1%40x&amp;s=a%3Ab"' in page


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ('"https://x.org/c?survey_code={survey_code}"', "unknown placeholder {survey_code}"),
        ('"https://x.org/c?survey_code={id:>4}"', "write it bare"),
        ('"https://x.org/c?survey_code={id"', "unbalanced braces"),
        ('"https://{id}.org/c"', "only after the host"),
    ],
)
def test_a_url_with_an_unusable_placeholder_stops_the_study_file_loading(
    tmp_path, monkeypatch, url: str, message: str
) -> None:
    demo_variant(tmp_path / "studies", monkeypatch, "badurl", {"completion_url": url})
    with pytest.raises(StudyFileError) as raised:
        load_study("badurl")
    assert "completion_url" in str(raised.value) and message in str(raised.value)
    assert "{PROLIFIC_PID}" in str(raised.value) or message != "unknown placeholder {survey_code}"


def test_prolific_outcomes_full_timed_out_and_ended_each_get_their_own_code(
    app, console, tmp_path, monkeypatch
) -> None:
    name = demo_variant(tmp_path / "studies", monkeypatch, "outcomes", {"target": "2"})
    path = tmp_path / "studies" / "outcomes.toml"
    path.write_text(path.read_text() + "\n[timeouts]\ninactivity_s = 600\n")
    phone = {"width": "375", "height": "812", "mobile": "1", "missing": ""}
    browser = app.test_client()
    first_page = browser.get(f"/join/{name}?PROLIFIC_PID=p0")
    fields = dict(HIDDEN.findall(first_page.get_data(as_text=True)))
    screened = browser.post(f"/join/{name}", data=fields | phone)
    assert 'data-stage="screened_out"' in screened.get_data(as_text=True)
    first = _start(app.test_client(), name, PROLIFIC_PID="p1", STUDY_ID="s", SESSION_ID="x1")
    second = _start(app.test_client(), name, PROLIFIC_PID="p2", STUDY_ID="s", SESSION_ID="x2")
    assert first.status_code == second.status_code == 302
    # Full: asked to return the submission, with the return code; nothing recorded.
    full = _start(app.test_client(), name, PROLIFIC_PID="p3").get_data(as_text=True)
    assert 'data-stage="study_full"' in full and "return your submission" in full
    assert 'id="return-code" class="code">DEMORETURN<' in full
    assert "DEMOSCREEN" not in full
    _start(app.test_client(), name, PROLIFIC_PID="p3")  # again: one visitor, counted once
    # Ended by the experimenter: asked to return the submission.
    code_of = {}
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 2
        for row in session.scalars(select(Recruitment)):
            code_of[row.recruitment_id] = session.get(Participant, row.participant_id).code
    assert console.act(code_of["p2"], "abort").status_code == 303
    ended = app.test_client().get(second.location, follow_redirects=True).get_data(as_text=True)
    assert "The experimenter has ended this session" in ended
    assert 'id="return-code" class="code">DEMORETURN<' in ended
    # Timed out: the time-out code, the link back, and the participant's own code.
    app.extensions["hcss_runner"].clock.now += 601.0
    timed = app.test_client().get(first.location, follow_redirects=True).get_data(as_text=True)
    assert "Your session has timed out" in timed
    assert 'id="screen-out-code" class="code">DEMOTIMEOUT<' in timed
    assert 'href="https://app.prolific.com/submissions/complete?cc=DEMOTIMEOUT"' in timed
    assert f'id="timed-out-code">{code_of["p1"]}<' in timed
    # The console counts each outcome of the study link.
    counts = console_outcomes(console.get("/console/").get_data(as_text=True), "outcomes")
    assert {outcome: row["count"] for outcome, row in counts.items()} == {
        "completed": 0,
        "in_progress": 0,
        "declined": 0,
        "screened_out": 1,
        "full": 1,
        "ended": 1,
        "timed_out": 1,
    }


def _csp(response) -> dict[str, str]:
    policy = response.headers["Content-Security-Policy"]
    return {d.split(" ", 1)[0]: d.split(" ", 1)[1] for d in policy.split("; ")}


def test_only_an_mturk_studys_link_may_be_framed_and_only_by_mturk(
    app, tmp_path, monkeypatch
) -> None:
    hit = {"workerId": "A2W", "hitId": "H1", "assignmentId": "AS1", "turkSubmitTo": MTURK}
    link = app.test_client().get(f"/join/demo?{urlencode(hit)}")
    assert link.status_code == 200 and "X-Frame-Options" not in link.headers
    assert _csp(link)["frame-ancestors"] == (
        "https://worker.mturk.com https://www.mturk.com https://workersandbox.mturk.com"
    )
    assert _csp(link)["form-action"] == "'self'"
    # Every other page, and another study's link, refuse every frame.
    demo_variant(tmp_path / "studies", monkeypatch, "nomturk", {"mturk": "false"})
    for path in ("/console/login", "/join/nomturk", "/", "/join/no-such-study"):
        response = app.test_client().get(path)
        assert response.headers["X-Frame-Options"] == "DENY", path
        assert _csp(response)["frame-ancestors"] == "'none'", path
    refused = app.test_client().get(f"/join/nomturk?{urlencode(hit)}")
    assert refused.status_code == 400 and "does not take part in MTurk" in refused.get_data(
        as_text=True
    )


@pytest.mark.parametrize(
    ("submit_to", "message"),
    [
        ("https://evil.example", "is not MTurk"),
        ("https://www.mturk.com.evil.example", "is not MTurk"),
        ("http://www.mturk.com", "is not MTurk"),
        ("https://www.mturk.com/mturk/externalSubmit", "not a web address"),
        ("javascript:alert(1)", "not a web address"),
        (None, "lacks MTurk's turkSubmitTo"),
    ],
)
def test_a_turk_submit_to_that_is_not_mturk_is_refused_and_records_nothing(
    app, submit_to: str | None, message: str
) -> None:
    hit = {"workerId": "A2W", "hitId": "H1", "assignmentId": "AS1"}
    if submit_to is not None:
        hit["turkSubmitTo"] = submit_to
    client = app.test_client()
    page = client.get(f"/join/demo?{urlencode(hit)}")
    assert page.status_code == 400 and message in html.unescape(page.get_data(as_text=True))
    csrf = re.search(r'name="csrf-token" content="([^"]+)"', page.get_data(as_text=True))
    posted = client.post("/join/demo", data=hit | LAPTOP | {"csrf_token": csrf.group(1)})
    assert posted.status_code == 400
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 0


def test_the_mturk_debrief_posts_the_assignment_to_turk_submit_to(
    app, tmp_path, monkeypatch
) -> None:
    name = _short(tmp_path / "studies", monkeypatch, "hitshort", {"mturk": "true"})
    preview = {"workerId": "A2W", "hitId": "H1", "assignmentId": "ASSIGNMENT_ID_NOT_AVAILABLE"}
    shown = app.test_client().get(f"/join/{name}?{urlencode(preview | {'turkSubmitTo': MTURK})}")
    assert shown.status_code == 200 and "accept the HIT" in shown.get_data(as_text=True)
    # Its own window's join page (Sec-Fetch-Dest: document) and the framed one (iframe).
    hit = preview | {"assignmentId": "AS1", "turkSubmitTo": MTURK + "/"}  # MTurk adds a slash
    framed = app.test_client().get(
        f"/join/{name}?{urlencode(hit)}", headers={"Sec-Fetch-Dest": "iframe"}
    )
    assert re.search(
        r'<section id="join-framed" class="completion" data-status-url="[^"]+">',
        framed.get_data(as_text=True),
    )
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(Participant)) == 0
    client = app.test_client()
    page = _consent_to_debrief(client, name, **hit)
    assert f'<form method="post" action="{MTURK}/mturk/externalSubmit" id="mturk-submit">' in page
    assert '<input type="hidden" name="assignmentId" value="AS1">' in page
    assert '<input type="hidden" name="completionCode" value="DEMO2026">' in page
    assert 'http-equiv="refresh"' not in page  # the worker submits; no redirect away first
    with app.extensions["hcss_db"].session_scope() as session:
        token = session.scalars(select(Participant.token)).one()
    debrief = client.get(f"/p/{token}", follow_redirects=True)
    # MTurk's answer to the post is a redirect to another of its hosts: allowed too.
    assert _csp(debrief)["form-action"] == f"'self' {MTURK} https://*.mturk.com"
    assert _csp(debrief)["frame-ancestors"] == "'none'"
