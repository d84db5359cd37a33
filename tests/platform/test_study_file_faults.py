"""A study file removed or changed under enrolled participants holds them with a clear
page, and the console and `hcss serve` say which study; nothing answers 500."""

from __future__ import annotations

from pathlib import Path

import pytest

from hcss.platform.models import Participant
from hcss.platform.study import assign_cell
from hcss.platform.study.files import STUDIES_ENV, bundled_directory
from hcss.platform.study.studyfile import _load_study
from hcss.platform.study.versions import study_problems


@pytest.fixture
def lab_study(tmp_path: Path, monkeypatch) -> Path:
    """The lab's own study file `lab.toml` (a copy of the demo) in HCSS_STUDIES."""
    directory = tmp_path / "studies"
    directory.mkdir()
    text = (bundled_directory() / "demo.toml").read_text(encoding="utf-8")
    (directory / "lab.toml").write_text(text.replace('name = "demo"', 'name = "lab"', 1))
    monkeypatch.setenv(STUDIES_ENV, str(directory))
    _load_study.cache_clear()
    yield directory / "lab.toml"
    _load_study.cache_clear()


def _enrolled(app) -> str:
    with app.extensions["hcss_db"].session_scope() as session:
        participant = Participant(study="lab")
        session.add(participant)
        session.flush()
        assign_cell(session, participant)
        return participant.token


def _restart() -> None:
    """A new server process reads the study files afresh."""
    _load_study.cache_clear()


@pytest.mark.parametrize("fault", ["changed", "removed"])
def test_participants_of_a_changed_or_removed_study_are_held_and_the_console_says_so(
    app, console, lab_study: Path, fault: str
) -> None:
    token = _enrolled(app)
    participant = app.test_client()
    assert participant.get(f"/p/{token}", follow_redirects=True).status_code == 200
    if fault == "changed":
        lab_study.write_text(lab_study.read_text() + "\n# a later edit\n")
    else:
        lab_study.rename(lab_study.with_suffix(".old"))
    _restart()

    held = participant.get(f"/p/{token}", follow_redirects=True)
    assert held.status_code == 503
    text = held.get_data(as_text=True)
    assert ("has changed" if fault == "changed" else "cannot be read") in text
    assert "Traceback" not in text
    page = console.get("/console/")
    assert page.status_code == 200 and "study lab" in page.get_data(as_text=True)
    rows = console.progress()
    assert any(row["stage"].startswith("held:") for row in rows.values())
    with app.extensions["hcss_db"].session_scope() as session:
        assert any("lab" in problem for problem in study_problems(session))
