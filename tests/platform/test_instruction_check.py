"""The instruction check over HTTP: a wrong try, the pages to re-read, a right try, the export.

The demo study declares three questions and two tries. The participant walks
there with the bots' answers, answers one question wrongly, is shown the
introduction page that explains it, then answers rightly; the export's tables
hold both tries, the scores (passed, tries) and the stage's timing. A study
file that declares the check badly is refused with its line.
"""

from __future__ import annotations

import tomllib

import pytest
from sqlalchemy import select

from hcss.platform.export.writer import write_export
from hcss.platform.study.instruction_check import stored_key
from hcss.platform.study.studyfile import StudyFileError, load_study, parse_study
from tests.support.exports import read_csv
from tests.support.study import errors_in, new_participant, visitor, walk_to


def right_answers() -> dict[str, str]:
    check = load_study("demo").instruction_check
    assert check is not None
    return {item.key: item.answer for item in check.items}


def test_a_wrong_try_shows_the_page_to_reread_then_a_right_try_passes_and_is_exported(
    demo_bot_app, tmp_path
) -> None:
    guest = visitor(demo_bot_app, new_participant(demo_bot_app))
    page = walk_to(guest, "instruction_check", "try_1")
    assert "Checking the instructions" in guest.html

    # Nothing answered: refused with a message per question, nothing stored.
    guest.submit({}, page)
    assert errors_in(guest.html).count("This question needs an answer.") == 3
    assert 'data-step="try_1"' in guest.html
    # An answer that is not a choice is refused too.
    guest.submit(right_answers() | {"blue_half": "green"}, page)
    assert 'data-step="try_1"' in guest.html and errors_in(guest.html)

    wrong = right_answers() | {"blue_half": "How valuable it is"}
    guest.submit(wrong, page)
    reread = guest.page()
    assert (reread.stage, reread.step) == ("instruction_check", "reread_1")
    assert "What does the blue bottom half of a target show?" in guest.html
    assert "The bottom half is blue" in guest.html.replace("<strong>", "").replace("</strong>", "")
    assert "Sending requests" not in guest.html  # only the page of the question missed
    assert (
        "How much support it has"
        not in guest.html.split("read this again")[1].split("The part of the introduction")[0]
    )  # the answer itself is not given away
    guest.submit({}, reread)

    second = guest.page()
    assert (second.stage, second.step) == ("instruction_check", "try_2")
    assert "Try 2 of 2: 1 of your answers was not right" in guest.html
    guest.submit(right_answers(), second)
    assert guest.page().stage == "screen_check"

    with demo_bot_app.app_context():
        database = demo_bot_app.extensions["hcss_db"]
        with database.session_scope() as session:
            counts = write_export(session, tmp_path / "export")
    assert counts
    _, items = read_csv(tmp_path / "export" / "questionnaire_items.csv")
    check_items = {r["item"]: r["value"] for r in items if r["instrument"] == "instruction_check"}
    assert check_items == {f"{key}_try_1": value for key, value in wrong.items()} | {
        f"{key}_try_2": value for key, value in right_answers().items()
    }
    _, scores = read_csv(tmp_path / "export" / "scores.csv")
    assert {
        r["scale"]: float(r["score"]) for r in scores if r["instrument"] == "instruction_check"
    } == {"passed": 1.0, "tries": 2.0}
    _, timings = read_csv(tmp_path / "export" / "stage_timings.csv")
    (timing,) = [r for r in timings if r["stage"] == "instruction_check"]
    assert timing["entered_at"] and timing["submitted_at"], timing  # on the bots' still clock


def test_two_wrong_tries_go_on_to_training_and_are_exported_as_not_passed(demo_bot_app) -> None:
    guest = visitor(demo_bot_app, new_participant(demo_bot_app))
    page = walk_to(guest, "instruction_check", "try_1")
    wrong = right_answers() | {"send_request": "Drag the collective's hub onto the target"}
    guest.submit(wrong, page)
    guest.submit({}, guest.page())  # the page re-read
    guest.submit(wrong, guest.page())
    assert guest.page().stage == "screen_check"
    from hcss.platform.models import Score

    with demo_bot_app.extensions["hcss_db"].session_scope() as session:
        scores = {
            s.scale: s.score
            for s in session.scalars(select(Score).where(Score.instrument == "instruction_check"))
        }
    assert scores == {"passed": 0.0, "tries": 2.0}
    assert stored_key(load_study("demo").instruction_check.items[0], 2) == "send_request_try_2"


def _demo_file() -> dict:
    from hcss.platform.study.files import study_text

    _, raw = study_text("demo")
    return tomllib.loads(raw.decode("utf-8"))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d: d["instruction_check"]["items"][0].update(answer="Fly there"), "not one of"),
        (lambda d: d["instruction_check"]["items"][1].update(page=9), "introduction page"),
        (lambda d: d["instruction_check"].update(tries=0), "greater than or equal to 1"),
        (lambda d: d["instruction_check"].update(after_wrong="end"), "'reread' or 'retry'"),
        (lambda d: d["instruction_check"]["items"][2].update(key="blue_half"), "must differ"),
        (lambda d: d.pop("instruction_check"), "declare [instruction_check]"),
    ],
)
def test_a_badly_declared_check_is_refused_with_a_clear_message(change, message) -> None:
    doc = _demo_file()
    change(doc)
    with pytest.raises(StudyFileError) as refused:
        parse_study(doc, source="demo.toml")
    assert message in str(refused.value), str(refused.value)


def test_a_declared_check_the_sequence_leaves_out_is_not_asked() -> None:
    doc = _demo_file()
    doc["sequence"]["before"].remove("instruction_check")
    study = parse_study(doc, source="demo.toml")
    assert study.instruction_check is not None
    assert "instruction_check" not in study.sequence.before


def test_after_wrong_retry_asks_again_at_once_with_the_missed_question_marked(
    database_url, tmp_path, monkeypatch
) -> None:
    from hcss.platform.bots.participant import bot_app
    from hcss.platform.models import Score
    from hcss.platform.study.files import STUDIES_ENV, study_text

    text = study_text("demo")[1].decode()
    text = text.replace('name = "demo"', 'name = "retrying"')
    text = text.replace('after_wrong = "reread"', 'after_wrong = "retry"').replace(
        "tries = 2", "tries = 3"
    )
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies" / "retrying.toml").write_text(text)
    monkeypatch.setenv(STUDIES_ENV, str(tmp_path / "studies"))
    app = bot_app(database_url, "retrying")
    app.extensions["hcss_db"].create_all()
    try:
        guest = visitor(app, new_participant(app))
        page = walk_to(guest, "instruction_check", "try_1")
        wrong = right_answers() | {"decide_when": "At any time"}
        guest.submit(wrong, page)
        again = guest.page()
        assert (again.stage, again.step) == ("instruction_check", "try_2")  # no re-read
        assert "Try 2 of 3: 1 of your answers was not right" in guest.html
        assert guest.html.count('class="check-missed"') == 1
        guest.submit(wrong, again)
        third = guest.page()
        assert third.step == "try_3"
        guest.submit(right_answers(), third)
        assert guest.page().stage == "screen_check"
        with app.extensions["hcss_db"].session_scope() as session:
            scores = {
                s.scale: s.score
                for s in session.scalars(
                    select(Score).where(Score.instrument == "instruction_check")
                )
            }
        assert scores == {"passed": 1.0, "tries": 3.0}
    finally:
        app.extensions["hcss_db"].engine.dispose()
