"""Outcomes per reason, on each recruitment site's study link: completed, declined,
screened out, study full, ended by the experimenter (returned, or paid as the study file
decides) and timed out each show their own code and URL, and the console counts each
recruitment id once (a phone opening the link twice, a full study visited twice)."""

from __future__ import annotations

import json
import re
from urllib.parse import urlencode

import pytest
from sqlalchemy import select

from hcss.platform.bots.participant import parse_page
from hcss.platform.models import Participant, Recruitment
from tests.support.recruitment import console_outcomes, demo_variant

LAPTOP = {"width": "1366", "height": "657", "mobile": "0", "missing": ""}
PHONE = {"width": "375", "height": "812", "mobile": "1", "missing": ""}
HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')
#: The study file's key of each way out besides completion.
KEYS = ("declined", "full", "ended", "timeout", "screenout")


def _prolific(n: int) -> dict[str, str]:
    return {"PROLIFIC_PID": f"pid{n}", "STUDY_ID": "st1", "SESSION_ID": f"se{n}"}


def _sona(n: int) -> dict[str, str]:
    return {"id": f"{4100 + n}"}


def _mturk(n: int) -> dict[str, str]:
    return {
        "workerId": f"W{n}",
        "assignmentId": f"A{n}",
        "hitId": "H1",
        "turkSubmitTo": "https://www.mturk.com",
    }


PROLIFIC = "https://app.prolific.com/submissions/complete?cc="
SONA = "https://uni.sona-systems.com/webstudy_credit.aspx?experiment_id=9&credit_token=t&survey_code={id}"
#: Per site: its visitors' ids, the study file's [online] keys, and whether the
#: experimenter's end is paid (SONA: credit for the time given; MTurk: the completion code).
PLATFORMS = {
    "prolific": (
        _prolific,
        {
            "completion_code": "PDONE",
            "completion_url": PROLIFIC + "PDONE",
            **{f"{key}_code": f"P{key.upper()}" for key in KEYS},
            **{f"{key}_url": PROLIFIC + f"P{key.upper()}" for key in KEYS},
        },
        False,
    ),
    "sona": (
        _sona,
        {
            **dict.fromkeys(["completion_code", "screenout_code", "timeout_code"], ""),
            **dict.fromkeys(["return_code", "return_url"], ""),
            "completion_url": SONA,
            "screenout_url": SONA.replace("credit_token=t", "credit_token=screen"),
            "declined_url": SONA.replace("credit_token=t", "credit_token=declined"),
            "full_url": "https://uni.sona-systems.com/all_exp.aspx",
            "timeout_url": SONA.replace("credit_token=t", "credit_token=timeout"),
            "ended_url": SONA.replace("credit_token=t", "credit_token=ended"),
            "ended_paid": "true",
        },
        True,
    ),
    "mturk": (
        _mturk,
        {
            "mturk": "true",
            **dict.fromkeys(["completion_url", "screenout_url", "timeout_url"], ""),
            **dict.fromkeys(["return_code", "return_url"], ""),
            "completion_code": "MDONE",
            "screenout_code": "MSCREEN",
            "declined_code": "MDECLINED",
            "full_code": "MFULL",
            "timeout_code": "MTIMEOUT",
            "ended_paid": "true",  # no ended code: the completion code pays them
        },
        True,
    ),
}


def _toml(online: dict[str, str]) -> dict[str, str]:
    return {
        key: value if value in ("true", "false") or value.isdigit() else json.dumps(value)
        for key, value in online.items()
    }


def _first_page(client, study: str, params: dict[str, str], device=LAPTOP):
    first = client.get(f"/join/{study}?{urlencode(params)}")
    if 'id="join-form"' not in first.get_data(as_text=True):
        return first
    fields = dict(HIDDEN.findall(first.get_data(as_text=True)))
    return client.post(f"/join/{study}", data=fields | device)


def _consent(client, location: str, decision: str) -> str:
    page = parse_page(client.get(location, follow_redirects=True).get_data(as_text=True))
    assert page.stage == "consent"
    answer = client.post(page.action, data=page.hidden | {"decision": decision})
    if decision == "decline":  # the page asks once for confirmation
        confirm = parse_page(answer.get_data(as_text=True))
        client.post(confirm.action, data=confirm.hidden | {"decision": "decline"})
    return client.get(location, follow_redirects=True).get_data(as_text=True)


@pytest.mark.parametrize("site", list(PLATFORMS))
def test_each_outcome_has_its_own_code_and_url_and_counts_each_id_once(
    app, console, tmp_path, monkeypatch, site: str
) -> None:
    ids, online, ended_paid = PLATFORMS[site]
    name = demo_variant(
        tmp_path / "studies", monkeypatch, f"{site}out", _toml({**online, "target": "2"})
    )
    path = tmp_path / "studies" / f"{name}.toml"
    text = path.read_text()
    text = re.sub(r"before = \[[^\]]*\]", 'before = ["consent"]', text, count=1)
    text = re.sub(r"per_model = \[[^\]]*\]", "per_model = []", text, count=1)
    text = re.sub(r"after = \[[^\]]*\]", 'after = ["debrief"]', text, count=1)
    path.write_text(text + "\n[timeouts]\ninactivity_s = 600\n")
    client = app.test_client

    completed = _first_page(client(), name, ids(1))
    assert completed.status_code == 302, completed.get_data(as_text=True)[-1500:]
    debrief = _consent(app.test_client(), completed.location, "agree")
    assert 'data-stage="debrief"' in debrief
    ender = _first_page(client(), name, ids(2))
    assert ender.status_code == 302
    for _ in range(2):  # the study is full: one visitor, twice
        full = _first_page(client(), name, ids(3)).get_data(as_text=True)
        assert 'data-stage="study_full"' in full
    with app.extensions["hcss_db"].session_scope() as session:
        code_of = {
            row.recruitment_id: session.get(Participant, row.participant_id).code
            for row in session.scalars(select(Recruitment))
        }
    assert console.act(code_of[ids(2)[next(iter(ids(2)))]], "abort").status_code == 303
    ended = client().get(ender.location, follow_redirects=True).get_data(as_text=True)
    assert "The experimenter has ended this session" in ended
    assert ('id="ended-paid"' in ended) is ended_paid
    assert ("return your submission" in ended) is not ended_paid
    timing_out = _first_page(client(), name, ids(4))
    app.extensions["hcss_runner"].clock.now += 601.0
    timed = client().get(timing_out.location, follow_redirects=True).get_data(as_text=True)
    assert "Your session has timed out" in timed
    declined = _consent(client(), _first_page(client(), name, ids(5)).location, "decline")
    assert "You have chosen not to take part" in declined
    for _ in range(2):  # a phone opening the link twice: one visitor
        screened = _first_page(client(), name, ids(6), device=PHONE).get_data(as_text=True)
        assert 'data-stage="screened_out"' in screened

    table = console_outcomes(console.get("/console/").get_data(as_text=True), name)
    print(f"\n{site}: outcome | code | URL | count")
    for outcome, row in table.items():
        print(f"{site}: {outcome} | {row['code']} | {row['url']} | {row['count']}")
    assert {outcome: (row["count"], row.get(site, 0)) for outcome, row in table.items()} == {
        "completed": (1, 1),
        "in_progress": (0, 0),
        "declined": (1, 1),
        "screened_out": (1, 1),
        "full": (1, 1),
        "ended": (1, 1),
        "timed_out": (1, 1),
    }
    # Each page gave the code and the URL its row of the table names (the ids filled in).
    pages = {
        "completed": debrief,
        "full": full,
        "ended": ended,
        "timed_out": timed,
        "declined": declined,
        "screened_out": screened,
    }
    seen = {}
    for outcome, page in pages.items():
        row = table[outcome]
        if row["code"] != "—":
            assert f">{row['code']}<" in page, (outcome, row["code"])
        if row["url"] != "—":
            base = row["url"].split("{", 1)[0].replace("&", "&amp;")
            assert base in page, (outcome, base)
        seen[outcome] = (row["code"], row["url"])
    assert len(set(seen.values())) == len(seen) - (1 if ended_paid and site == "mturk" else 0)
