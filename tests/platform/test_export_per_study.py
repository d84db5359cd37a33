"""`hcss export --study NAME`: one study's participants, their trials and link rows only."""

from __future__ import annotations

import csv

from click.testing import CliRunner

from hcss.cli import main
from hcss.platform.models import Participant, Recruitment
from hcss.platform.study.enrolment import assign_cell
from hcss.platform.study.studyfile import load_study


def _participants(app) -> dict[str, str]:
    """Two demo participants (one through the study link), one original, one never started."""
    codes = {}
    with app.app_context(), app.extensions["hcss_db"].session_scope() as session:
        for label, study in (("demo", "demo"), ("linked", "demo"), ("original", "original")):
            participant = Participant()
            session.add(participant)
            session.flush()
            assign_cell(session, participant, study=study)
            codes[label] = participant.code
            if label == "linked":
                session.add(
                    Recruitment(
                        participant_id=participant.id,
                        study="demo",
                        source="sona",
                        recruitment_id="77",
                    )
                )
        waiting = Participant(study="original")  # created in the console, link not yet opened
        session.add(waiting)
        session.flush()
        codes["waiting"] = waiting.code
    return codes


def _rows(path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


def test_export_of_one_study(app, database_url, tmp_path) -> None:
    codes = _participants(app)
    result = CliRunner().invoke(
        main, ["export", str(tmp_path / "demo"), "--study", "demo", "--database-url", database_url]
    )
    assert result.exit_code == 0, result.output
    assert "exported 2 participants of study demo" in result.output
    rows = _rows(tmp_path / "demo" / "participants.csv")
    assert sorted(r["participant"] for r in rows) == sorted([codes["demo"], codes["linked"]])
    assert {(r["study"], r["study_digest"]) for r in rows} == {("demo", load_study("demo").digest)}
    assert [r["recruitment_id"] for r in _rows(tmp_path / "demo" / "recruitment.csv")] == ["77"]

    everyone = CliRunner().invoke(
        main, ["export", str(tmp_path / "all"), "--database-url", database_url]
    )
    assert everyone.exit_code == 0, everyone.output
    studies = {
        r["participant"]: (r["study"], r["study_digest"])
        for r in _rows(tmp_path / "all" / "participants.csv")
    }
    assert len(studies) == 4
    assert studies[codes["waiting"]] == ("original", "")  # never started: the chosen study
    # The MRT's range is the study file's: the demo's one part of 4, the original's 12 and 12.
    part_items = {
        r["participant"]: r["mrt_part_items"] for r in _rows(tmp_path / "all" / "participants.csv")
    }
    assert part_items == {
        codes["demo"]: "4",
        codes["linked"]: "4",
        codes["original"]: "12,12",
        codes["waiting"]: "12,12",
    }

    unknown = CliRunner().invoke(
        main, ["export", str(tmp_path / "x"), "--study", "pilot-2", "--database-url", database_url]
    )
    assert unknown.exit_code == 1
    assert (
        "no participant belongs to study 'pilot-2'; studies in this database: demo, original"
        in unknown.output
    )
    assert not (tmp_path / "x").exists()


def test_the_console_lists_the_studies_participants_belong_to_now(app) -> None:
    """The export's study list (every console page) is asked in the database, and names
    each participant's study as the export assigns it: the newest enrolment's, else the
    study chosen at creation; a study left by its only participant is not listed."""
    from hcss.platform.export.selection import participant_studies, present_studies

    def listed(session) -> list[str]:
        assigned = sorted({name for name in participant_studies(session).values() if name})
        assert present_studies(session) == assigned
        return assigned

    with app.extensions["hcss_db"].session_scope() as session:
        moved, stayed = Participant(), Participant()
        session.add_all([moved, stayed])
        session.flush()
        assign_cell(session, moved, override=1, study="demo")
        assign_cell(session, moved, override=1, study="original")  # left demo
        assign_cell(session, stayed, override=1, study="original")
        assert listed(session) == ["original"]
        session.add(Participant(study="demo"))  # invited to demo, link not opened yet
        session.flush()
        assert listed(session) == ["demo", "original"]
