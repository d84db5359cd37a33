"""The study flow's records in the export and the live table."""

from __future__ import annotations

from click.testing import CliRunner
from sqlalchemy import select

from hcss.cli import main
from hcss.platform.models import Participant, study
from tests.support.exports import T0, read_csv, record_study


def test_study_records_fill_the_participant_and_study_tables(app, database_url, tmp_path) -> None:
    with app.extensions["hcss_db"].session_scope() as session:
        participant = Participant()
        session.add(participant)
        session.flush()
        record_study(session, participant)
        code = participant.code
    outdir = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    assert result.exit_code == 0, result.output

    _, participants = read_csv(outdir / "participants.csv")
    (row,) = participants
    assert row["participant"] == code
    assert (row["study"], row["cell"], row["model_order"]) == ("original", "3", "M2,M1,M3")
    assert (row["age_band"], row["gender"], row["video_games"], row["robots"]) == (
        "18-30",
        "female",
        "3",
        "",
    )
    assert (row["mrt_score"], row["tlx_overall_M2"], row["sart_M2"], row["sart_M1"]) == (
        "17",
        "48.5",
        "6.0",
        "",
    )
    assert row["status"] == "in_progress"

    _, items = read_csv(outdir / "questionnaire_items.csv")
    assert [(i["item"], i["value"]) for i in items if i["item"] == "video_games"] == [
        ("video_games", "3")
    ]
    assert {i["model"] for i in items} == {"", "M2"}
    _, scores = read_csv(outdir / "scores.csv")
    assert {(s["instrument"], s["model"], s["scale"]) for s in scores} == {
        ("mrt", "", "total"),
        ("mrt", "", "part_1"),
        ("nasa_tlx", "M2", "overall"),
        ("sart", "M2", "overall"),
    }
    _, timings = read_csv(outdir / "stage_timings.csv")
    by_stage = {t["stage"]: t for t in timings}
    assert list(by_stage) == ["consent", "demographics", "mental_rotation", "post_trial"]
    mrt = by_stage["mental_rotation"]
    assert mrt["entered_at"] == "2026-11-22T09:01:05.000Z"
    assert mrt["submitted_at"] == "2026-11-22T09:06:40.000Z" and mrt["timed_out"] == "true"
    assert by_stage["demographics"]["timed_out"] == "false"
    assert by_stage["post_trial"]["submitted_at"] == "" and by_stage["post_trial"]["model"] == "M2"


def test_declined_and_aborted_participants_are_told_apart(
    app, console, database_url, tmp_path
) -> None:
    """Status is the study engine's; `completed` is checked by the bot run (test_export_bots)."""
    with app.extensions["hcss_db"].session_scope() as session:
        declined, aborted, waiting = Participant(), Participant(), Participant()
        session.add_all([declined, aborted, waiting])
        session.flush()
        session.add(
            study.ConsentRecord(participant_id=declined.id, version="v1", decision="decline", at=T0)
        )
        codes = {declined.code: "declined", aborted.code: "aborted", waiting.code: "not_started"}
    assert console.act(aborted.code, "abort").status_code == 303
    outdir = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    assert result.exit_code == 0, result.output
    _, participants = read_csv(outdir / "participants.csv")
    assert {p["participant"]: p["status"] for p in participants} == codes


def test_the_live_table_shows_the_study_engines_stage(app, console) -> None:
    clock = app.extensions["hcss_runner"].clock
    clock.now = T0.timestamp()
    console.post("/console/participants", {"count": "1"})
    (code,) = console.progress()
    assert console.progress()[code]["stage"] == "not started"
    with app.extensions["hcss_db"].session_scope() as session:
        token = session.scalars(select(Participant.token).where(Participant.code == code)).one()
    participant = app.test_client()
    assert participant.get(f"/p/{token}", follow_redirects=True).status_code == 200
    clock.now += 30.0
    row = console.progress()[code]
    assert (row["stage"], row["time_in_stage_s"], row["trial_clock_s"]) == ("consent", 30.0, None)


def test_a_cell_override_enrols_through_the_study_engine(app, console) -> None:
    response = console.post("/console/participants", {"count": "1", "cell": "5"})
    assert response.status_code == 303
    code = response.headers["Location"].rsplit("/", 1)[-1]
    with app.extensions["hcss_db"].session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.code == code)).one()
        (enrolment,) = session.scalars(
            select(study.StudyEnrolment).where(
                study.StudyEnrolment.participant_id == participant.id
            )
        ).all()
        assert (enrolment.cell, enrolment.override) == (5, True)
    page = console.get(f"/console/participants/{code}").get_data(as_text=True)
    assert "cell_override" in page and "cell 5" in page
    # A cell the design does not have: refused, nobody created.
    before = len(console.progress())
    console.post("/console/participants", {"count": "1", "cell": "9"})
    assert len(console.progress()) == before
