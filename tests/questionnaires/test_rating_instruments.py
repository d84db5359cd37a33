"""3-D SART and the post-trial questionnaire, against hand-worked values."""

from __future__ import annotations

import pytest

from hcss.questionnaires import post_trial, sart
from hcss.questionnaires.definitions import InvalidAnswers


def sart_answers(understanding: int, demand: int, supply: int) -> dict[str, int]:
    return {
        "situational_understanding": understanding,
        "attentional_demand": demand,
        "attentional_supply": supply,
    }


def test_sart_minimum_maximum_and_middle() -> None:
    assert sart.score(sart_answers(1, 7, 1)).overall == -5
    assert sart.score(sart_answers(7, 1, 7)).overall == 13
    middle = sart.score(sart_answers(5, 4, 3))  # 5 - (4 - 3) = 4
    assert middle.overall == 4
    assert {row.scale: row.score for row in middle.rows()} == {
        "overall": 4.0,
        "SU": 5.0,
        "DAR": 4.0,
        "SAR": 3.0,
    }
    assert {row.instrument for row in middle.rows()} == {"sart"}


def test_sart_accepts_posted_strings_and_rejects_out_of_range() -> None:
    assert (
        sart.score(
            {
                "situational_understanding": "6",
                "attentional_demand": " 2",
                "attentional_supply": "3",
            }
        ).overall
        == 7
    )
    errors = sart.validate(sart_answers(0, 8, 4) | {"attentional_supply": True})
    assert errors == {
        "situational_understanding": ["Must be between 1 and 7, got 0."],
        "attentional_demand": ["Must be between 1 and 7, got 8."],
        "attentional_supply": ["Please give a whole number from 1 to 7."],
    }
    with pytest.raises(InvalidAnswers, match="attentional_demand"):
        sart.score(sart_answers(4, 9, 4))


def test_post_trial_effectiveness_is_the_mean_of_the_three_request_ratings() -> None:
    answers = {
        "investigate_effectiveness": 6,
        "abandon_effectiveness": 3,
        "decide_effectiveness": 4,
        "responsiveness": 5,
        "performance": 2,
        "comprehension": 7,
    }
    result = post_trial.score(answers)
    rows = {row.scale: row.score for row in result.rows()}
    assert rows["effectiveness"] == pytest.approx(13 / 3)
    assert rows["responsiveness"] == 5.0
    assert rows["performance"] == 2.0
    assert rows["comprehension"] == 7.0
    assert rows["abandon_effectiveness"] == 3.0
    assert len(rows) == 7


def test_post_trial_validation() -> None:
    assert post_trial.POST_TRIAL.item_keys() == (
        "investigate_effectiveness",
        "abandon_effectiveness",
        "decide_effectiveness",
        "responsiveness",
        "performance",
        "comprehension",
    )
    errors = post_trial.validate({"investigate_effectiveness": 8, "colour": 3})
    assert errors["investigate_effectiveness"] == ["Must be between 1 and 7, got 8."]
    assert errors["responsiveness"] == ["This question needs an answer."]
    assert errors["colour"] == ["Not a question of this form."]
