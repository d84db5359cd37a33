"""The README's own commands, as written there: a demo participant walked to the debrief,
`hcss demo-trial`, then the README's export and analysis commands (run from the README's
text, so a change to either side is caught) exit 0 and report both participants."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.platform.bots.participant import ParticipantBot, bot_app
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.study.studyfile import load_study
from tests.support.console import Console, sign_in

README = Path(__file__).resolve().parents[2] / "README.md"


def readme_command(name: str) -> list[str]:
    """The README's `.venv/bin/hcss NAME ...` command of the demo walk-through, as words."""
    walkthrough = README.read_text(encoding="utf-8").split("## Running one demo participant")[1]
    found = re.findall(rf"`\.venv/bin/hcss ({name} [^`]+)`", walkthrough)
    assert found, f"the README's walk-through gives no `hcss {name}` command"
    return shlex.split(found[0])


@pytest.mark.slow  # a bot walks the demo study, then a whole report (about 10 s)
def test_the_readmes_analysis_of_a_walked_participant_and_a_demo_trial_exits_0(
    tmp_path: Path, monkeypatch
) -> None:
    database_url = f"sqlite:///{tmp_path / 'readme.sqlite3'}"
    app = bot_app(database_url, "demo", SECRET_KEY="test-secret", TESTING=True)
    app.extensions["hcss_db"].create_all()
    try:
        with app.extensions["hcss_db"].session_scope() as session:
            create_experimenter(session, "alice", "correct horse battery")
        client = app.test_client()
        assert sign_in(client, "alice", "correct horse battery").status_code == 302
        console = Console(app=app, client=client)
        console.get("/console/")
        created = console.post("/console/participants", {"study": "demo", "count": 1})
        assert created.status_code == 303
        page = console.get(created.headers["Location"]).get_data(as_text=True)
        (link,) = re.findall(r'data-copy="([^"]+)"', page)
        ParticipantBot(app, link.rsplit("/", 1)[-1], seed=1, tick_s=10.0, policy_every_s=30.0).run(
            load_study("demo")
        )  # raises unless it reaches the debrief
        monkeypatch.setenv("DATABASE_URL", database_url)
        monkeypatch.setenv("HCSS_STUDY", "demo")  # what `make run STUDY=demo` announces
        monkeypatch.chdir(tmp_path)
        runner = CliRunner()
        made = runner.invoke(main, ["demo-trial"])
        assert made.exit_code == 0, made.output

        exported = runner.invoke(main, readme_command("export"))
        assert exported.exit_code == 0, exported.output
        analysed = runner.invoke(main, [*readme_command("analyze"), "--quiet"])
        assert analysed.exit_code == 0, analysed.output

        report = tmp_path / "out" / "report"
        html = (report / "report.html").read_text(encoding="utf-8")
        digest = load_study("demo").digest
        assert (
            f"demo (file {digest[:12]}…): 2 participants (1 participant ran a trial outside "
            "the study flow"
        ) in html
        sample = pd.read_csv(report / "tables" / "sample.csv").set_index("row")["n"]
        assert sample["Completed"] == 1 and sample["Included: demos"] == 1
        # The demo trial is still running: its partial trial is analysed, and said so.
        assert (
            "1 analysed participant who did not complete (aborted, timed out, declined or in "
            "progress): their partial trials and answers enter the per-model measures" in html
        )
        # The demo's MRT is one part of 4 items: no label claims the original's two of 12.
        assert "total of both parts" not in html and "(0–24)" not in html
        assert "MRT score: items right over the study&#x27;s timed parts" in html or (
            "MRT score: items right over the study's timed parts" in html
        )
        assert "MRT score range: 0–4 in demo (one timed part of 4 items)" in html
        # An MRT family table over the "All" column names it as such.
        assert "mean (SD) per model (All: measured once per participant, not per model)" in html

        completers = tmp_path / "out" / "completers"
        words = readme_command("analyze")
        words[words.index("--out") + 1] = str(completers)
        only = runner.invoke(main, [*words, "--completers-only", "--quiet"])
        assert only.exit_code == 0, only.output
        html = (completers / "report.html").read_text(encoding="utf-8")
        assert "Completers only (--completers-only): 1 participant who did not complete" in html
        assert f"demo (file {digest[:12]}…): 1 participant." in html
    finally:
        app.extensions["hcss_db"].engine.dispose()
