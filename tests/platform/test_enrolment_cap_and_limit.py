"""The study's recruitment cap and the per-client limit on the study link compose.

The limit bounds the participants one address can make; the cap says the
study needs no one more. A visitor to a full study is told it is full (no
wait helps), not 429 "wait a few minutes"; a Start that creates no one (the
study is full, or the visitor is already enrolled) does not use the
address's allowance; and a returning participant always gets back in.
"""

from __future__ import annotations

import re

from sqlalchemy import func, select

from hcss.platform.models import Participant
from tests.support.recruitment import LAPTOP, join


def start(app, study: str, **params: str):
    """Press Start on a first page opened earlier (or post it as a script does)."""
    client = app.test_client()
    page = client.get("/join/demo").get_data(as_text=True)
    csrf = re.search(r'name="csrf_token" value="([^"]+)"', page)
    assert csrf
    return client.post(f"/join/{study}", data={"csrf_token": csrf.group(1), **params, **LAPTOP})


def _participants(app) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return int(session.scalar(select(func.count()).select_from(Participant)) or 0)


def _capped_study(tmp_path, monkeypatch, target: int) -> str:
    from hcss.platform.study.files import STUDIES_ENV, study_text

    text = study_text("demo")[1].decode()
    text = text.replace('name = "demo"', 'name = "capped"')
    text = text.replace("[online]\n", f"[online]\ntarget = {target}\n")
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies" / "capped.toml").write_text(text)
    monkeypatch.setenv(STUDIES_ENV, str(tmp_path / "studies"))
    return "capped"


def test_a_full_study_says_full_not_429_and_uses_no_allowance(app, tmp_path, monkeypatch) -> None:
    study = _capped_study(tmp_path, monkeypatch, target=2)
    app.config["JOIN_PER_CLIENT"] = (3, 600.0)
    first = join(app.test_client(), study, PROLIFIC_PID="p1")
    assert first.status_code == 302
    assert join(app.test_client(), study, PROLIFIC_PID="p2").status_code == 302
    for number in range(3, 9):  # Starts pressed on pages opened before the study filled
        full = start(app, study, PROLIFIC_PID=f"p{number}")
        assert full.status_code == 200, (number, full.status_code)
        assert 'data-stage="study_full"' in full.get_data(as_text=True)
    for _ in range(3):  # enrolled: back to their own link, whatever the address sent
        assert start(app, study, PROLIFIC_PID="p1").location == first.location
    assert _participants(app) == 2
    # The full study's Starts and the returns used none of the allowance: one is left.
    assert join(app.test_client(), "demo").status_code == 302
    assert join(app.test_client(), "demo").status_code == 429
    assert _participants(app) == 3


def test_a_returning_participant_gets_back_in_past_the_limit(app) -> None:
    app.config["JOIN_PER_CLIENT"] = (2, 600.0)
    first = join(app.test_client(), "demo", PROLIFIC_PID="p1")
    assert join(app.test_client(), "demo", PROLIFIC_PID="p2").status_code == 302
    refused = join(app.test_client(), "demo", PROLIFIC_PID="p3")
    assert refused.status_code == 429 and int(refused.headers["Retry-After"]) > 0
    for _ in range(3):  # a second Start of an enrolled participant creates no one
        assert start(app, "demo", PROLIFIC_PID="p1").location == first.location
    assert _participants(app) == 2
