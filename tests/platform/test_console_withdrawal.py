"""Withdrawal: every row of the participant goes, in one transaction, and an audit row stays."""

from __future__ import annotations

import pytest
from sqlalchemy import func, select

from hcss.platform.console import withdrawal
from hcss.platform.console.withdrawal import participant_tables
from hcss.platform.models import AuditRecord, Base, Participant
from tests.support.console import cells_containing, code_of, play_trial, rows_referencing


def _participant_id(app, code: str) -> int | None:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.scalar(select(Participant.id).where(Participant.code == code))


def _two_participants_with_data(app, make_trial, console):
    """A withdrawn-to-be participant with a played trial and console actions, and a bystander."""
    leaving = make_trial(seed=3, duration_s=900.0)
    play_trial(leaving, 500.0)  # still live when withdrawn
    code = code_of(app, leaving.token)
    console.act(code, "pause")
    console.act(code, "resume")
    console.act(code, "mark_pilot")
    staying = make_trial(seed=5, duration_s=120.0)
    play_trial(staying, 120.0)
    return leaving, code, code_of(app, staying.token)


def test_withdrawal_deletes_every_row_of_the_participant_and_audits_it(
    app, make_trial, console
) -> None:
    leaving, code, other = _two_participants_with_data(app, make_trial, console)
    leaving_id, other_id = _participant_id(app, code), _participant_id(app, other)
    with app.extensions["hcss_db"].session_scope() as session:
        before = rows_referencing(session, leaving_id)
        other_before = rows_referencing(session, other_id)
    # The fixture reached the tables that matter, so the check below means something.
    for table in ("trial", "command", "command_outcome", "observation", "probe", "probe_event"):
        assert before[table] > 0, table
    for table in ("decision", "snapshot", "sim_event", "console_action", "request_status_change"):
        assert before[table] > 0, table
    # Every table with a foreign-key path to the participant is covered.
    assert set(before) == {t.name for t in participant_tables()}

    refused = console.post(f"/console/participants/{code}/withdraw", {"confirm_code": other})
    assert refused.status_code == 303
    with app.extensions["hcss_db"].session_scope() as session:
        assert rows_referencing(session, leaving_id) == before  # wrong code: nothing deleted

    response = console.post(f"/console/participants/{code}/withdraw", {"confirm_code": code})
    assert response.status_code == 303
    leaving.run_to(600.0)  # the runner carries on without writing for them
    with app.extensions["hcss_db"].session_scope() as session:
        after = rows_referencing(session, leaving_id)
        assert all(count == 0 for count in after.values()), after
        assert rows_referencing(session, other_id) == other_before
        # Nothing anywhere names them (decision records hold the code in JSON),
        # except the audit row that records the deletion.
        assert cells_containing(session, code, skip=("audit_record",)) == []
        assert cells_containing(session, leaving.token) == []
        (audit,) = session.scalars(select(AuditRecord)).all()
        assert (audit.action, audit.experimenter, audit.participant_code) == (
            "withdrawal",
            "alice",
            code,
        )
        assert audit.row_counts == {table: n for table, n in before.items() if n}
    assert leaving.runner.host(leaving.trial_id) is None
    assert console.get(f"/console/participants/{code}").status_code == 404
    assert code not in console.progress() and other in console.progress()
    assert leaving.client.get(f"/live/{leaving.token}").status_code == 404


def test_a_failed_withdrawal_deletes_nothing(app, make_trial, console, monkeypatch) -> None:
    leaving, code, _ = _two_participants_with_data(app, make_trial, console)
    participant_id = _participant_id(app, code)
    with app.extensions["hcss_db"].session_scope() as session:
        before = rows_referencing(session, participant_id)

    def broken_audit(**_fields):
        raise RuntimeError("audit store unavailable")

    monkeypatch.setattr(withdrawal, "AuditRecord", broken_audit)
    with pytest.raises(RuntimeError):
        withdrawal.withdraw(app.extensions["hcss_db"], app.extensions["hcss_live"], code, "alice")
    with app.extensions["hcss_db"].session_scope() as session:
        assert rows_referencing(session, participant_id) == before
        assert session.scalar(select(func.count()).select_from(AuditRecord)) == 0


def test_withdrawing_an_unknown_code_is_refused(app, console) -> None:
    with pytest.raises(withdrawal.WithdrawalError, match="no participant"):
        withdrawal.withdraw(
            app.extensions["hcss_db"], app.extensions["hcss_live"], "PNOBODY", "alice"
        )
    assert (
        console.post(
            "/console/participants/PNOBODY/withdraw", {"confirm_code": "PNOBODY"}
        ).status_code
        == 303
    )
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(func.count()).select_from(AuditRecord)) == 0


def test_the_schema_walk_finds_tables_added_later() -> None:
    """A table the withdrawal module never heard of is covered through its foreign key."""
    from sqlalchemy import Column, ForeignKey, Integer, MetaData, Table

    metadata = MetaData()
    for table in Base.metadata.sorted_tables:
        table.to_metadata(metadata)
    Table(
        "future_answer",
        metadata,
        Column("id", Integer, primary_key=True),
        Column("probe_event_id", Integer, ForeignKey("probe_event.id")),
    )
    Table("unrelated", metadata, Column("id", Integer, primary_key=True))
    names = [t.name for t in participant_tables(metadata)]
    assert "future_answer" in names and "unrelated" not in names
    assert "audit_record" not in names and "experimenter" not in names
    assert names.index("future_answer") < names.index("probe_event") < names.index("probe")
    assert names[-1] == "participant"


def test_withdrawal_reaches_the_study_flow_records(app, console) -> None:
    from tests.support.exports import record_study

    with app.extensions["hcss_db"].session_scope() as session:
        participant = Participant()
        session.add(participant)
        session.flush()
        record_study(session, participant)
        participant_id, code = participant.id, participant.code
    with app.extensions["hcss_db"].session_scope() as session:
        before = rows_referencing(session, participant_id)
    for table in ("study_enrolment", "stage_event", "questionnaire_item", "score"):
        assert before[table] > 0, table
    console.post(f"/console/participants/{code}/withdraw", {"confirm_code": code})
    with app.extensions["hcss_db"].session_scope() as session:
        assert not any(rows_referencing(session, participant_id).values())
        assert cells_containing(session, code, skip=("audit_record",)) == []
        audit = session.scalars(select(AuditRecord)).one()
        assert audit.row_counts["stage_event"] == before["stage_event"]
