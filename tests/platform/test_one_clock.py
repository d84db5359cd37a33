"""One clock stamps every row: the app's clock, which the runner and the study flow use.

In a server it is the wall clock; tests and bots give the app a `ManualClock`.
A participant's rows (created_at of every table, trial starts, stage events,
status changes, simulation events) then all lie on that clock's timeline, so
the order of the stamps is the order in which things happened to the
participant, whatever the real time was.
"""

from __future__ import annotations

from datetime import UTC, datetime

from sqlalchemy import select

from hcss.platform.bots.participant import ParticipantBot
from hcss.platform.models import (
    Base,
    CreatedAt,
    SimEvent,
    StageEvent,
    Trial,
    TrialStatusChange,
)
from hcss.platform.study import load_study
from tests.support.study import make_app, new_participant

#: A fixed instant far from the real time: a stamp from the real clock cannot fall near it.
START = datetime(2001, 2, 3, 4, 5, 6, tzinfo=UTC)


def stamped_tables() -> list[type]:
    return [
        mapper.class_ for mapper in Base.registry.mappers if issubclass(mapper.class_, CreatedAt)
    ]


def test_a_participant_s_rows_are_all_stamped_by_the_app_clock(database_url) -> None:
    app = make_app(database_url, "demo", now=START.timestamp())
    try:
        token = new_participant(app, is_bot=True)
        ParticipantBot(app, token, seed=4, tick_s=6.0).run(load_study("demo"))
        end = datetime.fromtimestamp(app.extensions["hcss_runner"].clock(), UTC)
        assert end > START

        with app.extensions["hcss_db"].session_scope() as session:
            stamps: dict[str, list[datetime]] = {}
            for table in stamped_tables():
                stamps[table.__name__] = list(session.scalars(select(table.created_at)))
            # The run wrote rows of each kind the participant's path goes through.
            for name in ("Participant", "StageEvent", "Trial", "TrialStatusChange", "SimEvent"):
                assert stamps[name], f"no {name} rows"
            outside = {
                name: [s.isoformat() for s in values if not START <= s <= end]
                for name, values in stamps.items()
            }
            assert not any(outside.values()), {n: v[:2] for n, v in outside.items() if v}

            trials = list(session.scalars(select(Trial)))
            assert all(START <= t.started_at == t.created_at <= end for t in trials)
            # A stage event is written when it happens, or later for a deadline that
            # passed unobserved; never before its study-clock time.
            events = list(session.scalars(select(StageEvent)))
            assert all(e.at <= e.created_at for e in events)
            # A trial starts when its run step is entered, on the same clock.
            runs = {
                e.detail["trial_id"]: e.at
                for e in events
                if e.step == "run" and e.kind == "entered"
            }
            assert runs == {t.id: t.started_at for t in trials}
            started = session.scalars(
                select(TrialStatusChange).where(TrialStatusChange.reason == "started")
            ).all()
            by_trial = {t.id: t for t in trials}
            # A simulation event is written once the runner, on that clock, reached its step.
            for event in session.scalars(select(SimEvent)):
                trial = by_trial[event.trial_id]
                due = trial.started_at.timestamp() + event.sim_time / trial.time_acceleration
                assert event.created_at.timestamp() >= due - 1e-3, (event.kind, event.sim_time)
            assert started and all(s.created_at == by_trial[s.trial_id].started_at for s in started)
    finally:
        app.extensions["hcss_db"].engine.dispose()
