"""End to end: a participant bot walks the demo study, the export carries all of it, the analysis reads it."""

from __future__ import annotations

from click.testing import CliRunner
from sqlalchemy import select

from hcss.analysis.load import load_inputs
from hcss.cli import main
from hcss.platform.bots.participant import bot_app, run_bots
from hcss.platform.models import Participant
from tests.support.exports import dictionary_columns, read_csv


def test_a_bot_run_exports_every_table_with_rows(database_url, tmp_path) -> None:
    app = bot_app(database_url, "demo", SECRET_KEY="test-secret", TESTING=True)
    try:
        app.extensions["hcss_db"].create_all()
        (report,) = run_bots(app, 1)
        with app.extensions["hcss_db"].session_scope() as session:
            token = session.scalars(select(Participant.token)).one()
    finally:
        app.extensions["hcss_db"].engine.dispose()
    outdir = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    assert result.exit_code == 0, result.output

    # Empty in a healthy run: no restart, nothing the export could not read, no
    # recruitment ids, return visits or screen-outs (bots are enrolled directly, not
    # through a study link and its device check), no answers sent after the experimenter
    # skipped a stage.
    empty_when_healthy = {
        "late_answers",
        "interruptions",
        "export_problems",
        "recruitment",
        "return_visits",
        "screen_outs",
    }
    for table, names in dictionary_columns().items():
        header, rows = read_csv(outdir / f"{table}.csv")
        assert header == names and bool(rows) != (table in empty_when_healthy), table
    (row,) = read_csv(outdir / "participants.csv")[1]
    assert row["participant"] == report.code and row["status"] == "completed"
    assert row["is_bot"] == "true" and row["study"] == "demo"
    assert len(row["model_order"].split(",")) == 3
    for column in ("age_band", "mrt_score", "tlx_overall_M1", "sart_M3"):
        assert row[column] != "", column
    _, timings = read_csv(outdir / "stage_timings.csv")
    assert timings[0]["stage"] == "consent" and timings[-1]["stage"] == "debrief"
    assert all(t["entered_at"] for t in timings)
    for path in outdir.rglob("*"):
        if path.is_file():
            assert token.encode() not in path.read_bytes(), path

    tables = load_inputs([outdir], include_pilot=True)
    assert set(tables.decisions["participant"]) == {report.code}
    assert len(tables.questionnaire_items) > 0 and len(tables.scores) > 0
