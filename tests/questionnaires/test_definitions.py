"""The shared item types and generic validation that every form relies on."""

from __future__ import annotations

import pytest

from hcss.questionnaires.definitions import (
    Choice,
    ChoiceItem,
    InvalidAnswers,
    Questionnaire,
    RatingItem,
    ScoreRow,
    parse_int,
    ratings,
    validate,
)

FORM = Questionnaire(
    instrument="example",
    title="Example",
    instructions="",
    items=(
        RatingItem("slider", "How much?", 0, 100, "None", "All", step=5),
        ChoiceItem("colour", "Which?", (Choice("red", "Red"), Choice("blue", "Blue"))),
    ),
)


def test_parse_int_accepts_ints_and_integer_text_only() -> None:
    assert parse_int(5) == 5
    assert parse_int(" -3 ") == -3
    assert parse_int("2.5") is None
    assert parse_int(True) is None
    assert parse_int(None) is None


def test_generic_validation_messages() -> None:
    assert validate(FORM, {"slider": "35", "colour": "red"}) == {}
    assert validate(FORM, {"slider": 33, "colour": "green", "extra": 1}) == {
        "slider": ["Must be a multiple of 5, got 33."],
        "colour": ["Please choose one of: red, blue."],
        "extra": ["Not a question of this form."],
    }
    assert validate(FORM, {}) == {
        "slider": ["This question needs an answer."],
        "colour": ["This question needs an answer."],
    }


def test_ratings_raise_with_the_messages() -> None:
    with pytest.raises(InvalidAnswers) as caught:
        ratings(FORM, {"slider": 101, "colour": "red"})
    assert caught.value.errors == {"slider": ["Must be between 0 and 100, got 101."]}
    assert "slider" in str(caught.value)


def test_point_labels_must_match_the_scale() -> None:
    with pytest.raises(ValueError, match="one label per scale point"):
        RatingItem("x", "?", 1, 5, "lo", "hi", point_labels=("a", "b"))


def test_score_rows_take_a_model_without_changing_the_score() -> None:
    row = ScoreRow("sart", "overall", 4.0)
    assert row.model == ""
    assert row.for_model("M1") == ScoreRow("sart", "overall", 4.0, "M1")
