"""Links nobody opened are no participants of a study: the README's export and analysis
commands work on a study with a batch of unused links and a demo trial beside it."""

from __future__ import annotations

import io
import re
import zipfile
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from flask import Flask

from hcss.analysis.load import load_inputs
from hcss.cli import main
from hcss.platform.bots.participant import ParticipantBot, bot_app
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.study.studyfile import load_study
from tests.support.console import Console, sign_in

UNUSED, WALKED = 6, 4


def _demo_study_with_unused_links(database_url: str, monkeypatch) -> tuple[Flask, Console]:
    """A batch of ten demo links from the console: four walked to the debrief by
    participant bots (as real participants: not flagged), six never opened; and a demo
    trial made by `hcss demo-trial`, still running."""
    app = bot_app(database_url, "demo", SECRET_KEY="test-secret", TESTING=True)
    app.extensions["hcss_db"].create_all()
    with app.extensions["hcss_db"].session_scope() as session:
        create_experimenter(session, "alice", "correct horse battery")
    console = _console(app)
    created = console.post("/console/participants", {"study": "demo", "count": UNUSED + WALKED})
    assert created.status_code == 303
    links = console.get(created.headers["Location"]).get_data(as_text=True)
    tokens = [line.rsplit("/", 1)[-1] for line in _links(links)]
    assert len(tokens) == UNUSED + WALKED
    study = load_study("demo")
    for number, token in enumerate(tokens[:WALKED]):
        bot = ParticipantBot(app, token, seed=number, tick_s=10.0, policy_every_s=30.0)
        bot.run(study)  # raises unless it reaches the debrief
    monkeypatch.setenv("DATABASE_URL", database_url)
    result = CliRunner().invoke(main, ["demo-trial", "--study", "demo"])
    assert result.exit_code == 0, result.output
    return app, console


def _console(app: Flask) -> Console:
    client = app.test_client()
    assert sign_in(client, "alice", "correct horse battery").status_code == 302
    console = Console(app=app, client=client)
    console.get("/console/")
    return console


def _links(html: str) -> list[str]:
    return re.findall(r'data-copy="([^"]+)"', html)


@pytest.mark.slow  # four bots walk the demo study, then a whole report (over a minute)
def test_export_and_analyze_study_demo_count_the_four_who_took_part(tmp_path, monkeypatch) -> None:
    database_url = f"sqlite:///{tmp_path / 'unused-links.sqlite3'}"  # the flow's SQL is
    # the same on PostgreSQL, where the test below runs too
    app, console = _demo_study_with_unused_links(database_url, monkeypatch)
    try:
        export = tmp_path / "e"
        result = CliRunner().invoke(
            main, ["export", str(export), "--study", "demo", "--database-url", database_url]
        )
        assert result.exit_code == 0, result.output
        participants = pd.read_csv(export / "participants.csv")
        statuses = participants.groupby("status")["participant"].count().to_dict()
        assert statuses == {"not_started": UNUSED, "completed": WALKED, "in_progress": 1}
        demo = participants[participants["is_demo"]]
        assert demo["status"].tolist() == ["in_progress"]  # the demo trial runs
        unused = participants[participants["status"] == "not_started"]
        assert unused["study_digest"].isna().all() and unused["cell"].isna().all()

        tables = load_inputs([export], study="demo")
        assert [(s.name, s.digest, s.participants) for s in tables.studies] == [
            ("demo", load_study("demo").digest, WALKED)
        ]
        assert tables.never_opened == UNUSED

        # The same from the console's zip.
        answer = console.get("/console/export.zip?study=demo")
        assert answer.status_code == 200
        with zipfile.ZipFile(io.BytesIO(answer.data)) as archive:
            archive.extractall(tmp_path / "zip")
        (unzipped,) = (tmp_path / "zip").iterdir()
        from_zip = load_inputs([unzipped], study="demo")
        assert [s.participants for s in from_zip.studies] == [WALKED]

        report = tmp_path / "r"
        analysed = CliRunner().invoke(
            main, ["analyze", str(export), "--study", "demo", "--out", str(report), "--quiet"]
        )
        assert analysed.exit_code == 0, analysed.output
        html = (report / "report.html").read_text(encoding="utf-8")
        assert f"demo (file {load_study('demo').digest[:12]}…): {WALKED} participants." in html
        assert f"{UNUSED} participant links were never opened (not started)" in html
        sample = pd.read_csv(report / "tables" / "sample.csv").set_index("row")["n"]
        assert sample["Enrolled (real participants)"] == WALKED
        assert sample["Completed"] == WALKED and sample["In progress"] == 0
    finally:
        app.extensions["hcss_db"].engine.dispose()


def test_a_link_never_opened_is_not_started_in_the_export(database_url, tmp_path: Path) -> None:
    """Without a walk: a batch's links, one opened (at consent), the rest not started."""
    app = bot_app(database_url, "demo", SECRET_KEY="test-secret", TESTING=True)
    app.extensions["hcss_db"].create_all()
    try:
        with app.extensions["hcss_db"].session_scope() as session:
            create_experimenter(session, "alice", "correct horse battery")
        console = _console(app)
        created = console.post("/console/participants", {"study": "demo", "count": 3})
        links = _links(console.get(created.headers["Location"]).get_data(as_text=True))
        opened = app.test_client().get(links[0].split("localhost", 1)[-1], follow_redirects=True)
        assert opened.status_code == 200
        result = CliRunner().invoke(
            main, ["export", str(tmp_path / "e"), "--database-url", database_url]
        )
        assert result.exit_code == 0, result.output
        rows = pd.read_csv(tmp_path / "e" / "participants.csv")
        assert sorted(rows["status"]) == ["in_progress", "not_started", "not_started"]
        assert rows.loc[rows["status"] == "in_progress", "study_digest"].notna().all()
    finally:
        app.extensions["hcss_db"].engine.dispose()
