"""Issue 13 §2 and §4: arrivals at the same moment, on SQLite and PostgreSQL.

48 participants opening their links at once fill the 8 cells 6 each (SQLite
gave 3/3/13/5/4/13/3/3: its reads did not wait for each other). Eight tabs
opening one participant's link at once make one enrolment and one entry of
the first page, and every tab gets its page (no IntegrityError, no 500).
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Callable
from typing import Any

from sqlalchemy import select

from hcss.platform.models import Participant, StageEvent, StudyEnrolment


def _at_once(calls: list[Callable[[], Any]]) -> list[Any]:
    """Run every call in its own thread, released together by a barrier."""
    barrier = threading.Barrier(len(calls))
    results: list[Any] = [None] * len(calls)

    def run(index: int) -> None:
        barrier.wait()
        try:
            results[index] = calls[index]()
        except Exception as error:  # noqa: BLE001 - reported by the assertion below
            results[index] = error

    threads = [threading.Thread(target=run, args=(i,)) for i in range(len(calls))]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    return results


def _new_participants(app, count: int) -> list[str]:
    with app.extensions["hcss_db"].session_scope() as session:
        made = [Participant() for _ in range(count)]
        session.add_all(made)
        session.flush()
        return [p.token for p in made]


def _visit(app, path: str) -> Callable[[], int]:
    return lambda: app.test_client().get(path).status_code


def test_48_simultaneous_arrivals_fill_each_cell_six_times(study_app) -> None:
    tokens = _new_participants(study_app, 48)

    statuses = _at_once([_visit(study_app, f"/p/{token}") for token in tokens])

    assert statuses == [302] * 48, statuses
    with study_app.extensions["hcss_db"].session_scope() as session:
        cells = Counter(session.scalars(select(StudyEnrolment.cell)))
    assert cells == {cell: 6 for cell in range(1, 9)}


def test_eight_simultaneous_first_visits_of_one_link_enrol_once(study_app) -> None:
    (token,) = _new_participants(study_app, 1)

    statuses = _at_once([_visit(study_app, f"/p/{token}/stage") for _ in range(8)])

    assert statuses == [200] * 8, statuses
    with study_app.extensions["hcss_db"].session_scope() as session:
        enrolments = session.scalars(select(StudyEnrolment)).all()
        entered = session.scalars(select(StageEvent).where(StageEvent.kind == "entered")).all()
    assert len(enrolments) == 1
    assert [(e.stage_index, e.step) for e in entered] == [(0, entered[0].step)]
