"""Stages the experimenter skipped, from the console to the report: the answers the
participant is told "were kept" are in the export's `late_answers` table, and the report's
attrition table counts the skipped stages as skipped (never a negative "did not submit")."""

from __future__ import annotations

import re

import pandas as pd
from click.testing import CliRunner

from hcss.cli import main
from tests.support.study import visitor

LINK = re.compile(r'value="(http://localhost/p/[A-Za-z0-9_-]+)"')


def test_skipped_stages_keep_their_late_answers_and_never_count_negative(
    app, console, database_url, tmp_path
) -> None:
    console.post("/console/participants", {"count": "1", "study": "demo"})
    (code,) = console.progress()
    (link,) = LINK.findall(console.get("/console/links").get_data(as_text=True))
    guest = visitor(app, link.rsplit("/", 1)[-1])
    guest.submit({"decision": "agree"})
    demographics = guest.page()
    assert 'data-stage="demographics"' in guest.html
    page = console.get(f"/console/participants/{code}").get_data(as_text=True)
    options = {
        label: number
        for number, label in re.findall(r'<option value="(\d+)">([^<]+)</option>', page)
    }
    target = next(label for label in options if "screen_check" in label)
    skipped = console.post(
        f"/console/participants/{code}/skip_stage", {"to_stage": options[target]}
    )
    assert skipped.status_code == 303
    # The demographics page was still open: its Continue sends answers after the skip.
    guest.submit({"age_band": "18-30", "gender": "woman"}, page=demographics)
    assert "The answers you gave on it were kept." in guest.html

    export = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(export), "--database-url", database_url])
    assert result.exit_code == 0, result.output
    late = pd.read_csv(export / "late_answers.csv", dtype=str)
    assert late[["participant", "stage", "item", "value"]].values.tolist() == [
        [code, "demographics", "age_band", "18-30"],
        [code, "demographics", "gender", "woman"],
    ]
    assert late["step"].notna().all() and late["answered_at"].str.endswith("Z").all()
    timings = pd.read_csv(export / "stage_timings.csv")
    never_entered = timings[timings["entered_at"].isna()]
    assert len(never_entered) >= 2 and never_entered["skipped"].all()

    report = tmp_path / "report"
    analysed = CliRunner().invoke(
        main, ["analyze", str(export), "--out", str(report), "--include-pilot", "--quiet"]
    )
    assert analysed.exit_code == 0, analysed.output
    attrition = pd.read_csv(report / "tables" / "attrition.csv").set_index("stage")
    counts = attrition[["entered", "submitted", "skipped", "lost"]]
    assert (counts >= 0).all().all(), attrition
    assert attrition.loc["consent"].tolist() == [1, 1, 0, 0]
    assert attrition.loc["demographics"].tolist() == [1, 0, 1, 0]
    assert attrition.loc["mental_rotation"].tolist() == [0, 0, 1, 0]
    html = (report / "report.html").read_text(encoding="utf-8")
    assert "<th>Skipped by the experimenter</th>" in html
