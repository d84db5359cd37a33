"""The export: a real recorded trial becomes the data dictionary's tables, and the analysis reads them."""

from __future__ import annotations

import zipfile
from io import BytesIO

import pytest
from click.testing import CliRunner
from sqlalchemy import select

from hcss.analysis.load import AnalysisInputError, load_inputs
from hcss.cli import main
from hcss.platform.export.tables import TABLES
from hcss.platform.export.writer import DICTIONARY
from hcss.platform.models import AuditRecord, Participant
from hcss.simulation import DECISION_COLUMNS
from tests.support.console import code_of, play_trial
from tests.support.exports import dictionary_columns, read_csv


@pytest.fixture
def exported(app, make_trial, database_url, tmp_path):
    """One participant with a played 10-minute trial and a training trial, exported by the CLI."""
    trial = make_trial(seed=3, duration_s=600.0)
    play_trial(trial, 600.0)
    training = make_trial(seed=4, kind="training", duration_s=60.0)
    training.run_to(60.0)
    outdir = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    assert result.exit_code == 0, result.output
    return outdir, trial, training


def test_export_tables_match_the_data_dictionary(exported) -> None:
    outdir, trial, _ = exported
    expected = dictionary_columns()
    assert set(expected) == set(TABLES)
    for table, names in expected.items():
        header, _rows = read_csv(outdir / f"{table}.csv")
        assert header == names, table
    decisions_header, decisions = read_csv(outdir / "decisions.csv")
    assert tuple(decisions_header) == DECISION_COLUMNS
    assert decisions and {d["source"] for d in decisions} == {"study"}
    assert {d["trial_id"] for d in decisions} == {str(trial.trial_id)}
    assert (outdir / "data-dictionary.md").read_text().startswith(DICTIONARY.read_text().rstrip())


def test_export_rows_carry_the_recorded_trial(exported, app) -> None:
    outdir, trial, training = exported
    code = code_of(app, trial.token)
    _, requests = read_csv(outdir / "requests.csv")
    assert [(r["kind"], r["accepted"]) for r in requests][-1] == ("decide", "false")
    assert requests[-1]["reason"] and requests[-1]["request_id"] == ""
    assert all(r["participant"] == code and r["model"] == "M1" for r in requests)
    _, observations = read_csv(outdir / "observations.csv")
    assert {(o["kind"], o["button"]) for o in observations} == {
        ("collective", "right"),
        ("target", "left"),
    }
    assert observations[0]["collective"] == "III"
    _, probes = read_csv(outdir / "probes.csv")
    assert len(probes) >= 5 and [p["probe_index"] for p in probes] == [
        str(i) for i in range(1, len(probes) + 1)
    ]
    answered = [p for p in probes if p["answer"]]
    assert len(answered) == 3 and all(float(p["ready_latency_ms"]) >= 0 for p in answered)
    assert all(p["timed_out"] == "true" for p in probes if not p["answer"])
    _, participants = read_csv(outdir / "participants.csv")
    row = next(p for p in participants if p["participant"] == code)
    assert (row["is_bot"], row["is_pilot"], row["is_demo"]) == ("true", "false", "false")
    # Outside the study flow (no enrolment): completed once the participant's trials ended.
    assert row["model_order"] == "M1" and row["status"] == "completed"
    # The training trial is kept, apart: never in the tables the analysis reads.
    _, training_decisions = read_csv(outdir / "training" / "decisions.csv")
    _, training_probes = read_csv(outdir / "training" / "probes.csv")
    assert str(training.trial_id) not in {
        r["trial_id"] for r in read_csv(outdir / "decisions.csv")[1]
    }
    assert all(
        r["trial_id"] == str(training.trial_id) for r in training_decisions + training_probes
    )


def test_export_holds_no_token(exported, app) -> None:
    outdir, _, _ = exported
    with app.extensions["hcss_db"].session_scope() as session:
        tokens = list(session.scalars(select(Participant.token)))
    files = [p for p in outdir.rglob("*") if p.is_file()]
    assert any(p.suffix == ".parquet" for p in files)
    for path in files:
        content = path.read_bytes()
        for token in tokens:
            assert token.encode() not in content, path


def test_parquet_tables_have_the_csv_columns_and_rows(exported) -> None:
    pq = pytest.importorskip("pyarrow.parquet")
    outdir, _, _ = exported
    for table in TABLES:
        header, rows = read_csv(outdir / f"{table}.csv")
        parquet = pq.read_table(outdir / f"{table}.parquet")
        assert parquet.column_names == header and parquet.num_rows == len(rows)


def test_the_analysis_reads_the_export(exported, tmp_path) -> None:
    outdir, _, _ = exported
    tables = load_inputs([outdir], include_pilot=True)
    assert len(tables.decisions) > 0 and set(tables.decisions["group"]) == {"M1"}
    assert len(tables.requests) > 0 and len(tables.probes) > 0
    # The participant is a bot: a real-data analysis leaves them out.
    with pytest.raises(
        AnalysisInputError, match="every row belongs to a bot, pilot or demo participant"
    ):
        load_inputs([outdir])
    report = tmp_path / "report"
    result = CliRunner().invoke(
        main, ["analyze", str(outdir), "--out", str(report), "--include-pilot"]
    )
    assert result.exit_code == 0, result.output
    assert any(report.iterdir())


def test_export_refuses_a_directory_with_files_and_leaves_it(app, database_url, tmp_path) -> None:
    outdir = tmp_path / "taken"
    outdir.mkdir()
    (outdir / "notes.txt").write_text("mine")
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    assert result.exit_code != 0 and "not empty" in result.output
    assert [p.name for p in outdir.iterdir()] == ["notes.txt"]
    replaced = CliRunner().invoke(
        main, ["export", str(outdir), "--replace", "--database-url", database_url]
    )
    assert replaced.exit_code == 0, replaced.output
    assert (outdir / "decisions.csv").is_file() and not (outdir / "notes.txt").exists()


def test_console_download_is_the_export_as_a_zip(app, make_trial, console) -> None:
    trial = make_trial(seed=3, duration_s=300.0)
    play_trial(trial, 300.0)
    response = console.client.get("/console/export.zip")
    assert response.status_code == 200 and response.mimetype == "application/zip"
    archive = zipfile.ZipFile(BytesIO(response.data))
    names = archive.namelist()
    (root,) = {name.split("/")[0] for name in names}
    for table in TABLES:
        assert f"{root}/{table}.csv" in names
    assert f"{root}/data-dictionary.md" in names and f"{root}/training/decisions.csv" in names
    assert all(trial.token.encode() not in archive.read(name) for name in names)
    with app.extensions["hcss_db"].session_scope() as session:
        audit = session.scalars(select(AuditRecord)).one()
        assert (audit.action, audit.experimenter, audit.participant_code) == (
            "export",
            "alice",
            None,
        )
        assert audit.row_counts["participants"] == 1


def test_export_of_an_unmigrated_database_says_what_to_do(tmp_path) -> None:
    empty = f"sqlite:///{tmp_path / 'empty.sqlite3'}"
    outdir = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", empty])
    assert result.exit_code != 0 and "hcss db upgrade" in result.output
    assert not outdir.exists()


def test_the_stored_decision_is_the_record_and_the_export_adds_who_and_where(exported, app) -> None:
    """DecisionRow.record holds the simulation's record, not the participant's code (issue 10)."""
    from sqlalchemy import select

    from hcss.platform.models import DecisionRow

    outdir, trial, _ = exported
    code = code_of(app, trial.token)
    with app.extensions["hcss_db"].session_scope() as session:
        stored = [
            r.record
            for r in session.scalars(
                select(DecisionRow).where(DecisionRow.trial_id == trial.trial_id)
            )
        ]
    assert stored and all(
        not {"source", "participant", "trial_id", "run"} & set(record) for record in stored
    )
    _, decisions = read_csv(outdir / "decisions.csv")
    assert len(decisions) == len(stored)
    assert all(
        (d["participant"], d["trial_id"], d["run"]) == (code, str(trial.trial_id), "0")
        for d in decisions
    )
    assert [d["decision_index"] for d in decisions] == [str(r["decision_index"]) for r in stored]
