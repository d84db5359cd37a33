"""Demographics validation and the post-experiment ranking by order met."""

from __future__ import annotations

import pytest

from hcss.questionnaires import demographics, ranking
from hcss.questionnaires.definitions import ChoiceItem, InvalidAnswers, RatingItem

VALID_DEMOGRAPHICS = {
    "age_band": "31-50",
    "gender": "woman",
    "education": "master",
    "colour_vision": "unsure",
    "video_games": 2,
    "robots": "5",
}


def test_demographics_items_match_the_data_dictionary() -> None:
    assert demographics.ITEM_KEYS == (
        "age_band",
        "gender",
        "education",
        "colour_vision",
        "video_games",
        "robots",
    )
    age = demographics.DEMOGRAPHICS.item("age_band")
    assert isinstance(age, ChoiceItem) and age.values() == ("18-30", "31-50", "51+", "not_said")
    vision = demographics.DEMOGRAPHICS.item("colour_vision")
    assert isinstance(vision, ChoiceItem) and vision.values() == ("yes", "no", "unsure", "not_said")
    games = demographics.DEMOGRAPHICS.item("video_games")
    assert isinstance(games, RatingItem) and games.points() == (1, 2, 3, 4, 5)
    assert len(games.point_labels) == 5


def test_demographics_validation() -> None:
    assert demographics.validate(VALID_DEMOGRAPHICS) == {}
    errors = demographics.validate(
        {**VALID_DEMOGRAPHICS, "age_band": "17", "robots": 6, "gender": ""} | {"name": "Ann"}
    )
    assert errors["age_band"] == ["Please choose one of: 18-30, 31-50, 51+, not_said."]
    assert errors["robots"] == ["Must be between 1 and 5, got 6."]
    assert errors["gender"] == ["This question needs an answer."]
    assert errors["name"] == ["Not a question of this form."]
    assert set(errors) == {"age_band", "robots", "gender", "name"}


def ranks(responsiveness, performance, comprehension) -> dict[str, int]:
    answers = {}
    for dimension, values in zip(
        ("responsiveness", "performance", "comprehension"),
        (responsiveness, performance, comprehension),
        strict=True,
    ):
        for label, rank in zip(ranking.ORDER_LABELS, values, strict=True):
            answers[ranking.item_key(dimension, label)] = rank
    return answers


def test_order_labels_map_back_to_models() -> None:
    order = ["M2", "M1", "M3"]
    assert ranking.model_for_label("first", order) == "M2"
    assert ranking.model_for_label("second", order) == "M1"
    assert ranking.model_for_label("third", order) == "M3"
    with pytest.raises(ValueError, match="unknown order label"):
        ranking.model_for_label("M1", order)
    with pytest.raises(ValueError):
        ranking.model_for_label("first", ["M1", "M2"])


def test_ranking_scores_are_attributed_to_models() -> None:
    result = ranking.score(ranks((2, 1, 3), (1, 2, 3), (3, 2, 1)), ["M2", "M1", "M3"])
    assert result.rank("responsiveness", "M1") == 1
    assert result.rank("responsiveness", "M2") == 2
    assert result.rank("comprehension", "M3") == 1
    rows = {(row.scale, row.model): row.score for row in result.rows()}
    assert rows[("performance", "M2")] == 1.0
    assert rows[("performance", "M3")] == 3.0
    assert len(rows) == 9
    assert {row.instrument for row in result.rows()} == {"ranking"}


def test_ranking_validation_requires_a_permutation_per_dimension() -> None:
    assert ranking.validate(ranks((1, 2, 3), (3, 1, 2), (2, 3, 1))) == {}
    errors = ranking.validate(ranks((1, 1, 3), (1, 2, 4), (2, 3, 1)))
    assert errors["responsiveness"] == [
        "Each collective type needs a different rank: use 1, 2 and 3 once each."
    ]
    assert errors["performance_third"] == ["Give the third collective type a rank from 1 to 3."]
    assert "comprehension" not in errors
    with pytest.raises(InvalidAnswers):
        ranking.score(ranks((1, 1, 3), (1, 2, 3), (1, 2, 3)), ["M1", "M2", "M3"])


def test_participants_never_see_model_codes() -> None:
    shown = [ranking.INSTRUCTIONS, *(d.prompt for d in ranking.DIMENSIONS)]
    shown += [ranking.display_name(label) for label in ranking.ORDER_LABELS]
    assert ranking.display_name("second") == "second collective type"
    assert not any(code in text for text in shown for code in ("M1", "M2", "M3"))
