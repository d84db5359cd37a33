"""A database that turns read-only under a running trial is an outage, as one that is away.

PostgreSQL refuses writes on a standby (or with default_transaction_read_only)
with ReadOnlySqlTransaction, an InternalError to SQLAlchemy, not an
OperationalError: the runner must still stop the trial's clock, keep what it
holds, and record the interruption once writes are taken again.
"""

from __future__ import annotations

from psycopg.errors import ReadOnlySqlTransaction
from sqlalchemy import event, select
from sqlalchemy.exc import InternalError

from hcss.platform.models import Interruption


def test_a_read_only_database_under_a_running_trial_stops_its_clock(app, make_trial) -> None:
    trial = make_trial(duration_s=600.0)
    trial.run_to(30.0)
    live = trial.live()
    database = app.extensions["hcss_db"]

    def read_only(session, *_args) -> None:
        if session.new or session.dirty or session.deleted:
            refusal = ReadOnlySqlTransaction("cannot execute INSERT in a read-only transaction")
            raise InternalError("INSERT", {}, refusal)

    event.listen(database.sessions, "before_flush", read_only)
    try:
        trial.run_to(36.0)  # a snapshot is due: the runner writes
        assert live.trial_clock.database_away_since is not None  # held, as for an outage
        step = live.sim.step_count
        trial.run_to(60.0)
        assert live.sim.step_count == step  # the trial stands still
    finally:
        event.remove(database.sessions, "before_flush", read_only)
    trial.run_to(61.0)
    assert live.trial_clock.database_away_since is None and not live.ended
    with database.session_scope() as session:
        (interruption,) = session.scalars(select(Interruption)).all()
        assert interruption.trial_id == trial.trial_id and interruption.outage_s >= 24.0
