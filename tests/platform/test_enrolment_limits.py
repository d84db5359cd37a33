"""Enrolment through the public link is limited per client, and the console's live table
costs a page, not the whole study, at 5,000 participants."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext

from sqlalchemy import event, func, select

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.console.participant_table import PER_PAGE
from hcss.platform.models import Participant, StudyEnrolment
from hcss.platform.serving.localserver import postgres_schema
from hcss.platform.study.studyfile import load_study
from tests.support.console import Console, sign_in
from tests.support.databases import PG_ENV
from tests.support.recruitment import join


def _participants(app) -> int:
    with app.extensions["hcss_db"].session_scope() as session:
        return int(session.scalar(select(func.count()).select_from(Participant)) or 0)


def test_one_client_cannot_enrol_without_limit_and_another_still_can(app) -> None:
    app.config["JOIN_PER_CLIENT"] = (5, 600.0)
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = "203.0.113.7"
    statuses = [join(client).status_code for _ in range(5)]
    assert statuses == [302] * 5
    refused = join(client)
    assert refused.status_code == 429 and int(refused.headers["Retry-After"]) > 0
    assert "Traceback" not in refused.get_data(as_text=True)
    assert _participants(app) == 5  # the refused Start wrote nothing
    other = app.test_client()
    other.environ_base["REMOTE_ADDR"] = "198.51.100.4"
    assert join(other).status_code == 302


def _enrol_5000(app, count: int = 5000) -> None:
    """5,000 participants enrolled in the demo study's cells, as 5,000 link visits leave them."""
    study = load_study("demo")
    cells = study.cells
    with app.extensions["hcss_db"].session_scope() as session:
        people = [
            Participant(code=f"L{number:07d}", is_bot=number % 500 == 0) for number in range(count)
        ]
        session.add_all(people)
        session.flush()
        session.add_all(
            StudyEnrolment(
                participant_id=person.id,
                study=study.name,
                study_digest=study.digest,
                cell=cells[number % len(cells)].number,
                model_order=",".join(cells[number % len(cells)].model_order),
                first_sections=dict(cells[number % len(cells)].first_sections),
                pool="real",
            )
            for number, person in enumerate(people)
        )


def _best_ms(consoles, path: str) -> list[tuple[float, object]]:
    """The fastest of 5 answers of each console, taken in turns: what the page costs on
    each, without the shared machine's spikes, and under the same load for both."""
    times: list[list[float]] = [[] for _ in consoles]
    answers: list[object] = [None for _ in consoles]
    for _ in range(5):
        for number, console in enumerate(consoles):
            started = time.perf_counter()
            answers[number] = response = console.get(path)
            times[number].append((time.perf_counter() - started) * 1000)
            assert response.status_code == 200
    return [(min(t), answer) for t, answer in zip(times, answers, strict=True)]


@contextmanager
def _one_page_console(database_url: str, tmp_path) -> Iterator[Console]:
    """A second server, on the same kind of database, holding one page of participants."""
    if database_url.startswith("postgresql"):
        schema = postgres_schema(os.environ[PG_ENV], "hcss_test")
    else:
        schema = nullcontext(f"sqlite:///{tmp_path / 'one-page.sqlite3'}")
    with schema as url:
        app = create_app({"DATABASE_URL": url, "SECRET_KEY": "s", "TESTING": True})
        app.extensions["hcss_db"].create_all()
        app.extensions["hcss_runner"].clock = ManualClock(0.0)
        try:
            _enrol_5000(app, PER_PAGE)
            with app.extensions["hcss_db"].session_scope() as session:
                create_experimenter(session, "alice", "correct horse battery")
            client = app.test_client()
            assert sign_in(client, "alice", "correct horse battery").status_code == 302
            yield Console(app=app, client=client)
        finally:
            app.extensions["hcss_db"].engine.dispose()


def _queries(app, console, path: str) -> int:
    engine = app.extensions["hcss_db"].engine
    count = [0]

    def counted(*_args) -> None:
        count[0] += 1

    event.listen(engine, "before_cursor_execute", counted)
    try:
        assert console.get(path).status_code == 200
    finally:
        event.remove(engine, "before_cursor_execute", counted)
    return count[0]


#: How many times the one-page table's cost the 5,000-participant table may take: measured
#: 0.6 to 1.2 at a load of 4 per core; with each participant's rows read into Python (the
#: console bar's study list and the time-out sweep did, on every page) it was 7 to 12.
SCAN_FACTOR = 4


def test_the_live_table_answers_in_under_300_ms_with_5000_participants(
    app, console, database_url, tmp_path
) -> None:
    """A page costs its own rows: as many queries with 5,000 participants as with one page
    of them, and under 300 ms.

    The machine is shared, so the 300 ms stretch only as far as a baseline measured
    here allows: the same pages of a second server holding one page of participants,
    timed in turns with the first, so under the same load. The 5,000-participant
    table may cost at most `SCAN_FACTOR` times the one-page table (the database's
    counts and sorts over 5,000 rows; per-participant work cost 200 times). While
    the one-page table answers within 300 ms / `SCAN_FACTOR`, that alone keeps the
    big one under 300 ms; only a machine slowed past it stretches the budget.
    """
    _enrol_5000(app)
    with _one_page_console(database_url, tmp_path) as one_page:
        queries = _queries(app, console, "/console/progress.json")
        baseline_queries = _queries(one_page.app, one_page, "/console/progress.json")
        assert queries <= baseline_queries + 2, (queries, baseline_queries)  # not per participant
        (json_ms, answer), (base_json_ms, _) = _best_ms(
            [console, one_page], "/console/progress.json"
        )
        (page_ms, page), (base_page_ms, _) = _best_ms([console, one_page], "/console/")
    print(
        f"progress.json {json_ms:.0f} ms with 5,000 participants, {base_json_ms:.0f} ms with "
        f"{PER_PAGE}; index {page_ms:.0f} ms, {base_page_ms:.0f} ms (best of 5, in turns); "
        f"{queries} queries, {baseline_queries} with one page"
    )
    for ms, base_ms in ((json_ms, base_json_ms), (page_ms, base_page_ms)):
        assert ms < max(300.0, SCAN_FACTOR * base_ms), (ms, base_ms)
    body = answer.get_json()
    assert body["total"] == 5000 and len(body["participants"]) == PER_PAGE
    assert body["pages"] == 5000 // PER_PAGE and len(page.get_data()) < 500_000
    filtered = console.get("/console/progress.json?page=9999&hide=bot").get_json()
    assert filtered["total"] == 4990 and not any(p["is_bot"] for p in filtered["participants"])
