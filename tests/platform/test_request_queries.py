"""What one request reads: the per-request work the study load benchmark found repeated.

Under load (benchmarks/study.py, 24 bots) the server is one process bound to
one core, so a query or a session repeated in every command or page load
makes every answer wait longer. These tests count the SQL statements a
request sends, by table, so a lookup done twice shows up here first.
"""

from __future__ import annotations

import re
import uuid
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager

from sqlalchemy import event, select

from hcss.platform.bots.participant import parse_page
from hcss.platform.models import QuestionnaireItem
from tests.support.study import new_participant, visitor, walk_to
from tests.support.trials import investigate_request

CLICK = {"kind": "collective", "collective": 0, "button": "left"}


@contextmanager
def tables_read(app) -> Iterator[Counter[str]]:
    """How many SELECT statements name each table (FROM or JOIN) while the block runs."""
    counts: Counter[str] = Counter()

    def count(_conn, _cursor, statement: str, *_args) -> None:
        if statement.lstrip().upper().startswith("SELECT"):
            counts.update(set(re.findall(r"(?:FROM|JOIN) \"?(\w+)", statement)))

    engine = app.extensions["hcss_db"].engine
    event.listen(engine, "before_cursor_execute", count)
    try:
        yield counts
    finally:
        event.remove(engine, "before_cursor_execute", count)


def test_a_keyed_command_to_a_held_trial_reads_its_key_once_and_no_owner_row(make_trial) -> None:
    trial = make_trial()
    body = investigate_request(trial)
    with tables_read(trial.app) as counts:
        answer = trial.client.post(
            trial.api + "/requests",
            json=body,
            headers={"X-CSRFToken": trial.csrf, "Idempotency-Key": str(uuid.uuid4())},
        )
    assert answer.status_code == 200 and answer.get_json()["accepted"] is True
    # The trial is held in memory, its owner's token with it: no participant or trial row.
    assert (counts["participant"], counts["trial"], counts["command_key"]) == (0, 0, 1)


def test_a_state_look_at_a_held_trial_reads_no_participant_or_trial(make_trial) -> None:
    trial = make_trial()
    assert trial.app.extensions["hcss_runner"].loaded(trial.trial_id) is not None
    with tables_read(trial.app) as counts:
        trial.state()
    assert (counts["participant"], counts["trial"]) == (0, 0)


def test_a_trial_not_held_is_checked_in_the_database_and_loaded(make_trial) -> None:
    trial = make_trial()
    runner = trial.app.extensions["hcss_runner"]
    runner.forget(trial.trial_id)
    assert trial.state()["trial"]["id"] == trial.trial_id
    assert runner.loaded(trial.trial_id) is not None


def test_a_held_trial_answers_only_its_own_token(make_trial) -> None:
    mine, theirs = make_trial(), make_trial()
    api = f"/api/live/{mine.token}/trials/{theirs.trial_id}"
    assert mine.client.get(api + "/state").status_code == 404
    keyed = {"X-CSRFToken": mine.csrf, "Idempotency-Key": str(uuid.uuid4())}
    for headers in (keyed, {"X-CSRFToken": mine.csrf}):
        answer = mine.client.post(api + "/observations", json=CLICK, headers=headers)
        assert answer.status_code == 404


def test_a_stage_page_reads_the_participant_and_the_consent_once(demo_app) -> None:
    token = new_participant(demo_app)
    client = demo_app.test_client()
    assert client.get(f"/p/{token}/stage").status_code == 200  # consent: entered, shown
    with tables_read(demo_app) as counts:
        page = client.get(f"/p/{token}/stage")  # a reload
    assert page.status_code == 200 and 'data-stage="consent"' in page.get_data(as_text=True)
    assert (counts["participant"], counts["consent_record"], counts["stage_event"]) == (1, 1, 1)


@contextmanager
def statements_sent(app) -> Iterator[Counter[str]]:
    """Every SQL statement sent while the block runs, by its first word, and the COMMITs."""
    counts: Counter[str] = Counter()

    def statement(_conn, _cursor, text: str, *_args) -> None:
        counts[text.split(None, 1)[0].upper()] += 1

    def commit(_conn) -> None:
        counts["COMMIT"] += 1

    engine = app.extensions["hcss_db"].engine
    event.listen(engine, "before_cursor_execute", statement)
    event.listen(engine, "commit", commit)
    try:
        yield counts
    finally:
        event.remove(engine, "before_cursor_execute", statement)
        event.remove(engine, "commit", commit)


def test_the_personal_link_reads_the_participant_and_enrolment_only(demo_app) -> None:
    """It redirects to the stage page, which locates the step: nothing else to read or write.

    The demo study has no [timeouts], so there is no one to time out either, and
    no trial to end (the stage page looks for one only past a step's deadline).
    """
    token = new_participant(demo_app)
    client = demo_app.test_client()
    with tables_read(demo_app) as tables, statements_sent(demo_app) as sent:
        answer = client.get(f"/p/{token}")
    assert answer.status_code == 302 and answer.location.endswith(f"/p/{token}/stage")
    assert set(tables) == {"participant", "study_enrolment"}
    assert sent == Counter({"SELECT": 2, "COMMIT": 1})


def test_a_stage_page_commits_once_when_it_records_the_entry(demo_app) -> None:
    """No step's deadline has passed, so no trial can be overdue: the live service's
    unit of work (and the request's connection handed back for it) is not needed."""
    token = new_participant(demo_app)
    client = demo_app.test_client()
    with statements_sent(demo_app) as sent:
        page = client.get(f"/p/{token}/stage")  # consent: its entry recorded, then shown
    assert page.status_code == 200 and 'data-stage="consent"' in page.get_data(as_text=True)
    assert (sent["SELECT"], sent["INSERT"], sent["COMMIT"]) == (5, 1, 1)
    with statements_sent(demo_app) as sent:
        page = client.get(f"/p/{token}/stage")  # a reload: read only
    assert page.status_code == 200 and 'data-stage="consent"' in page.get_data(as_text=True)
    assert (sent["SELECT"], sent["INSERT"], sent["COMMIT"]) == (5, 0, 1)


def test_an_answer_is_written_in_one_commit(demo_app) -> None:
    token = new_participant(demo_app)
    client = demo_app.test_client()
    page = parse_page(client.get(f"/p/{token}/stage").get_data(as_text=True))
    assert page.stage == "consent"
    with statements_sent(demo_app) as sent:
        answer = client.post(page.action, data={"decision": "agree", **page.hidden})
    assert answer.status_code == 302
    assert (sent["SELECT"], sent["INSERT"], sent["COMMIT"]) == (5, 2, 1)  # consent, submitted


def test_an_mrt_answer_reads_the_answers_so_far_once(demo_app) -> None:
    """Which item is current, whether this is it, and whether the part is done are all
    read from the stage's answers: one SELECT, kept up to date as the answer is written."""
    v = visitor(demo_app, new_participant(demo_app, is_bot=True))
    page = walk_to(v, "mental_rotation", "part_1")
    first = page.mrt_item
    with tables_read(demo_app) as counts:
        answer = v.client.post(page.action, data={**page.hidden, "chosen": ["0", "1"]})
    assert answer.status_code == 302
    assert counts["questionnaire_item"] == 1
    after = v.page()  # the next item, or the part's end when this was its last
    assert (after.step, after.mrt_item) != ("part_1", first)
    with demo_app.app_context(), demo_app.extensions["hcss_db"].session_scope() as session:
        stored = session.scalars(
            select(QuestionnaireItem.value).where(QuestionnaireItem.item == first)
        )
        assert list(stored) == ["0,1"]
