"""An abort whose commit fails leaves the trial running, so the abort can be retried.

The abort's rows (the console action, the open probe's timeout, the last
snapshot, the ended status) are one transaction. When its commit fails, the
trial in memory must still say what the database says: running, with its
probe open. Otherwise the runner forgets a trial the database calls running,
the participant's page is told it ended, and a retried abort finds nothing to
end.
"""

from __future__ import annotations

from sqlalchemy import event, select
from sqlalchemy.exc import OperationalError

from hcss.platform.live.trials import latest_status
from hcss.platform.models import ConsoleAction, Probe, ProbeEvent, TrialStatusChange
from hcss.platform.models.vocabularies import TrialStatus
from tests.support.console import code_of


def test_an_abort_whose_commit_fails_is_retried_without_lost_or_doubled_rows(
    app, make_trial, console
) -> None:
    trial = make_trial(duration_s=600.0)
    code = code_of(app, trial.token)
    live = trial.live()
    first_probe = live.probes.plan[0].at_s
    trial.run_to(first_probe + 1.0)
    assert live.probes.current is not None  # the abort must close it
    probe_id = live.probes.current.id

    database = app.extensions["hcss_db"]
    failures = []

    flushed_aborts: set[int] = set()  # sessions that flushed an abort's row before committing

    def note_an_abort(session, _context) -> None:
        if any(isinstance(o, ConsoleAction) and o.action == "abort" for o in session.new):
            flushed_aborts.add(id(session))

    def fail_the_abort(session, *_args) -> None:
        aborting = id(session) in flushed_aborts or any(
            isinstance(o, ConsoleAction) and o.action == "abort" for o in session.new
        )
        flushed_aborts.discard(id(session))
        if aborting and not failures:
            failures.append(1)
            raise OperationalError("COMMIT", {}, Exception("server closed the connection"))

    event.listen(database.sessions, "after_flush", note_an_abort)
    event.listen(database.sessions, "before_commit", fail_the_abort)
    try:
        refused = console.act(code, "abort")
    finally:
        event.remove(database.sessions, "before_commit", fail_the_abort)
        event.remove(database.sessions, "after_flush", note_an_abort)
    assert failures and refused.status_code == 503, refused.status_code

    # Nothing was written, and the trial in memory says so.
    assert not live.ended and not live.end_reason
    assert live.probes.current is not None and live.probes.current.id == probe_id
    assert trial.runner.loaded(trial.trial_id) is live
    trial.run_to(first_probe + 2.0)  # a tick does not forget it
    assert trial.runner.loaded(trial.trial_id) is live
    with database.session_scope() as session:
        assert latest_status(session, trial.trial_id) == TrialStatus.RUNNING

    assert console.act(code, "abort").status_code == 303
    assert live.ended and live.end_reason == "aborted"
    with database.session_scope() as session:
        ended = session.scalars(
            select(TrialStatusChange).where(
                TrialStatusChange.trial_id == trial.trial_id,
                TrialStatusChange.status == TrialStatus.ENDED,
            )
        ).all()
        assert [e.reason for e in ended] == ["aborted"]
        actions = session.scalars(select(ConsoleAction.action)).all()
        assert actions == ["abort"]
        timeouts = session.scalars(
            select(ProbeEvent).where(ProbeEvent.probe_id == probe_id, ProbeEvent.kind == "timeout")
        ).all()
        assert len(timeouts) == 1
        assert session.scalars(select(Probe.id).where(Probe.trial_id == trial.trial_id)).all() == [
            probe_id
        ]
