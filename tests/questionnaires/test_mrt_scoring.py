"""MRT credit rule: a point only for exactly the two correct alternatives."""

from __future__ import annotations

import pytest

from hcss.questionnaires.definitions import InvalidAnswers
from hcss.questionnaires.mrt import (
    NORMS_NOTE,
    format_selection,
    item_bank,
    mental_rotations_test,
    parse_selection,
    practice_feedback,
    practice_items,
    score,
    score_item,
    validate,
)


def wrong_alternatives(item) -> list[int]:
    return sorted(set(range(4)) - item.correct)


@pytest.mark.parametrize("item", item_bank()[:6], ids=lambda item: item.key)
def test_item_credit(item) -> None:
    right = sorted(item.correct)
    wrong = wrong_alternatives(item)
    assert score_item(item, right) == 1
    assert score_item(item, right[::-1]) == 1
    assert score_item(item, format_selection(right)) == 1
    assert score_item(item, right[:1]) == 0, "one correct only earns nothing"
    assert score_item(item, [*right, wrong[0]]) == 0, "three chosen earns nothing"
    assert score_item(item, range(4)) == 0
    assert score_item(item, wrong) == 0
    assert score_item(item, [right[0], wrong[0]]) == 0
    assert score_item(item, []) == 0


def test_total_over_the_24_items_hand_worked() -> None:
    """Items 1-10 right, 11-14 one correct, 15-18 three chosen, 19-20 all four, 21-24 unanswered.

    Expected by hand: 10 points, all in part 1 (items 1-12), none in part 2.
    """
    bank = item_bank()
    answers: dict[str, object] = {}
    for item in bank[:10]:
        answers[item.key] = sorted(item.correct)
    for item in bank[10:14]:
        answers[item.key] = sorted(item.correct)[:1]
    for item in bank[14:18]:
        answers[item.key] = format_selection([*item.correct, wrong_alternatives(item)[1]])
    for item in bank[18:20]:
        answers[item.key] = "0,1,2,3"
    result = score(answers)
    assert result.total == 10
    assert result.part_scores == (10, 0)
    assert dict(result.item_scores)["mrt_10"] == 1
    assert dict(result.item_scores)["mrt_11"] == 0
    assert dict(result.item_scores)["mrt_24"] == 0
    rows = {row.scale: row.score for row in result.rows()}
    assert rows == {"total": 10.0, "part_1": 10.0, "part_2": 0.0}
    assert {row.instrument for row in result.rows()} == {"mrt"}


def test_full_and_empty_tests() -> None:
    bank = item_bank()
    full = score({item.key: sorted(item.correct) for item in bank})
    assert (full.total, full.part_scores) == (24, (12, 12))
    empty = score({})
    assert (empty.total, empty.part_scores) == (0, (0, 0))


def test_validation_messages() -> None:
    errors = validate({"mrt_01": [0, 4], "mrt_02": "a,b", "mrt_03": [1, 1], "mrt_99": [0]})
    assert errors["mrt_01"] == ["Alternatives are numbered 0 to 3."]
    assert errors["mrt_02"] == ["Alternatives are identified by whole numbers."]
    assert errors["mrt_03"] == ["An alternative was chosen twice."]
    assert errors["mrt_99"] == ["Not an item of this test."]
    assert validate({"mrt_01": "", "mrt_02": [3, 0]}) == {}
    with pytest.raises(InvalidAnswers, match="mrt_01"):
        score({"mrt_01": [5]})


def test_selection_text_round_trip() -> None:
    assert format_selection({3, 0}) == "0,3"
    assert parse_selection("0,3") == frozenset({0, 3})
    assert parse_selection("") == frozenset()
    with pytest.raises(ValueError):
        parse_selection("0,7")


def test_practice_feedback_names_the_right_figures() -> None:
    item = practice_items()[0]
    letters = [chr(ord("A") + i) for i in sorted(item.correct)]
    good = practice_feedback(item, sorted(item.correct))
    assert good.correct and good.message.startswith("Correct")
    bad = practice_feedback(item, [*item.correct, wrong_alternatives(item)[0]])
    assert not bad.correct
    assert f"{letters[0]} and {letters[1]}" in bad.message
    assert "exactly two" in bad.message


def test_protocol_declares_parts_limits_practice_and_norms_caveat() -> None:
    test = mental_rotations_test()
    assert [part.number for part in test.parts] == [1, 2]
    assert [len(part.items) for part in test.parts] == [12, 12]
    assert all(part.time_limit_s == 180.0 for part in test.parts)
    assert len(test.practice) == 4
    assert test.max_score == 24
    assert test.item_keys() == tuple(f"mrt_{n:02d}" for n in range(1, 25))
    assert "not comparable with the norms of the published test" in NORMS_NOTE
