"""Counterbalancing: the 8 cells of the original design, filled evenly; pilots apart; overrides."""

from __future__ import annotations

from collections import Counter

import pytest
from sqlalchemy import select

from hcss.platform.models import ConsentRecord, Participant, StudyEnrolment
from hcss.platform.study import StudyFileError, assign_cell, load_study
from hcss.platform.study.enrolment import cell_counts
from hcss.platform.study.studyfile import parse_study


def _enrol(session, **flags):
    participant = Participant(**flags)
    session.add(participant)
    session.flush()
    return assign_cell(session, participant)


def test_the_original_design_has_the_eight_cells_of_the_spec() -> None:
    study = load_study("original")
    cells = {(c.model_order, tuple(sorted(c.first_sections.items()))) for c in study.cells}
    assert len(study.cells) == len(cells) == 8
    for cell in study.cells:
        assert cell.model_order[2] == "M3" and cell.first_sections["M3"] == "easy"
    assert Counter(c.model_order[0] for c in study.cells) == {"M1": 4, "M2": 4}
    for model in ("M1", "M2"):
        assert Counter(c.first_sections[model] for c in study.cells) == {"easy": 4, "difficult": 4}


def test_sixteen_participants_fill_each_cell_twice_and_pilots_do_not_count(study_app) -> None:
    database = study_app.extensions["hcss_db"]
    with study_app.app_context(), database.session_scope() as session:
        pilots = [_enrol(session, is_pilot=True) for _ in range(5)]
        bots = [_enrol(session, is_bot=True) for _ in range(3)]
        real = []
        for _ in range(16):
            real.append(_enrol(session))
            if len(real) == 4:  # a pilot and a bot arriving midway change nothing
                pilots.append(_enrol(session, is_pilot=True))
                bots.append(_enrol(session, is_bot=True))
        assert Counter(e.cell for e in real) == {cell: 2 for cell in range(1, 9)}
        assert len({e.cell for e in pilots}) == 6 and len({e.cell for e in bots}) == 4
        assert {e.pool for e in real} == {"real"} and {e.time_acceleration for e in real} == {1.0}
        assert all(
            e.model_order == ",".join(load_study("original").cell(e.cell).model_order) for e in real
        )


def test_declined_participants_free_their_cell(study_app) -> None:
    database = study_app.extensions["hcss_db"]
    study = load_study("original")
    with study_app.app_context(), database.session_scope() as session:
        first = [_enrol(session) for _ in range(8)]
        session.add(
            ConsentRecord(
                participant_id=first[0].participant_id,
                version="v1",
                decision="decline",
                at=database.now(),
            )
        )
        session.flush()
        assert cell_counts(session, study, "real")[first[0].cell] == 0
        assert _enrol(session).cell == first[0].cell


def test_an_override_is_recorded_and_a_bad_cell_changes_nothing(study_app) -> None:
    database = study_app.extensions["hcss_db"]
    with study_app.app_context(), database.session_scope() as session:
        participant = Participant()
        session.add(participant)
        session.flush()
        with pytest.raises(ValueError, match="no cell 9"):
            assign_cell(session, participant, override=9)
        assert session.scalars(select(StudyEnrolment)).first() is None
        enrolment = assign_cell(session, participant, override=3)
        assert (enrolment.cell, enrolment.override) == (3, True)
        again = assign_cell(session, participant, override=5)  # before any model stage: a new row
        rows = list(session.scalars(select(StudyEnrolment).order_by(StudyEnrolment.id)))
        assert [(r.cell, r.override) for r in rows] == [(3, True), (5, True)] and again is rows[-1]


def test_another_design_is_a_study_file_not_code() -> None:
    """Three models fully counterbalanced (6 orders) minus an excluded one, all easy first."""
    doc = {
        "name": "latin",
        "title": "t",
        "consent_version": "v1",
        "models": ["M1", "M2", "M3"],
        "sequence": {"before": ["consent"], "per_model": ["trial"], "after": ["debrief"]},
        "timing": {"training_s": 60, "trial_s": 60, "max_time_acceleration": 1},
        "mrt": {"practice_items": 0, "part_items": [2], "part_time_limit_s": 30, "break_s": 5},
        "probes": {"perception": 4, "comprehension": 5, "projection": 3},
        "counterbalancing": {
            "factors": {
                "model_order": [
                    ["M1", "M2", "M3"],
                    ["M1", "M3", "M2"],
                    ["M2", "M1", "M3"],
                    ["M2", "M3", "M1"],
                    ["M3", "M1", "M2"],
                    ["M3", "M2", "M1"],
                ],
            },
            "constants": {
                "first_section_M1": "easy",
                "first_section_M2": "easy",
                "first_section_M3": "easy",
            },
            "exclude": [{"model_order": ["M3", "M2", "M1"]}],
        },
    }
    study = parse_study(doc, source="latin.toml")
    assert [c.model_order for c in study.cells][-1] == ("M3", "M1", "M2") and len(study.cells) == 5
    doc["counterbalancing"]["constants"].pop("first_section_M2")
    with pytest.raises(StudyFileError, match="first_section_M2"):
        parse_study(doc, source="latin.toml")
    doc["counterbalancing"]["constants"]["first_section_M2"] = "easy"
    doc["sequence"]["before"] = ["consent", "post_trial"]
    with pytest.raises(StudyFileError, match="stage 'post_trial' belongs in sequence.per_model"):
        parse_study(doc, source="latin.toml")
    doc["sequence"]["before"] = ["consent", "quiz"]
    with pytest.raises(StudyFileError, match="unknown stage 'quiz'"):
        parse_study(doc, source="latin.toml")


def test_on_postgresql_concurrent_assignments_wait_for_each_other(study_app, database_url) -> None:
    """Two arrivals at once: the second sees the first's cell, so it cannot take it blindly."""
    import threading
    import time

    if not database_url.startswith("postgresql"):
        pytest.skip("SQLite serialises writes itself; the advisory lock is PostgreSQL's")
    database = study_app.extensions["hcss_db"]
    first_assigned, waited = threading.Event(), {}

    def first() -> None:
        with study_app.app_context(), database.session_scope() as session:
            _enrol(session)
            first_assigned.set()
            time.sleep(1.0)  # still uncommitted: the second must wait for this

    thread = threading.Thread(target=first)
    thread.start()
    assert first_assigned.wait(10)
    with study_app.app_context(), database.session_scope() as session:
        started = time.monotonic()
        second = _enrol(session)
        waited["s"] = time.monotonic() - started
    thread.join()
    assert waited["s"] >= 0.5
    with database.session_scope() as session:
        cells = [e.cell for e in session.scalars(select(StudyEnrolment))]
    assert len(set(cells)) == 2 and second.cell in cells
