"""NASA-TLX against a hand-worked example and its invariants."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from hcss.questionnaires import tlx
from hcss.questionnaires.definitions import InvalidAnswers

#: A dominance order, most to least often chosen: every pair goes to the
#: subscale listed first here, so the weights are 5, 4, 3, 2, 1, 0 down the list.
DOMINANCE = (
    "mental_demand",
    "effort",
    "temporal_demand",
    "performance",
    "frustration",
    "physical_demand",
)
RATINGS = {
    "mental_demand": 70,
    "physical_demand": 20,
    "temporal_demand": 50,
    "performance": 30,
    "effort": 60,
    "frustration": 40,
}


def choices_from(order) -> dict[str, str]:
    return {pair.key: min(pair.sides(), key=order.index) for pair in tlx.PAIRS}


def test_hand_worked_example() -> None:
    """Weights 5,0,3,2,4,1; overall = (350 + 0 + 150 + 60 + 240 + 40) / 15 = 56; raw = 270 / 6 = 45."""
    result = tlx.score({**RATINGS, **choices_from(DOMINANCE)})
    assert dict(result.weights) == {
        "mental_demand": 5,
        "physical_demand": 0,
        "temporal_demand": 3,
        "performance": 2,
        "effort": 4,
        "frustration": 1,
    }
    weighted = dict(result.weighted)
    assert weighted["mental_demand"] == pytest.approx(70 / 3)
    assert weighted["physical_demand"] == 0
    assert weighted["temporal_demand"] == pytest.approx(10)
    assert weighted["performance"] == pytest.approx(4)
    assert weighted["effort"] == pytest.approx(16)
    assert weighted["frustration"] == pytest.approx(8 / 3)
    assert result.overall == pytest.approx(56)
    assert result.raw_tlx == pytest.approx(45)
    rows = {row.scale: row.score for row in result.rows()}
    assert rows["overall"] == pytest.approx(56)
    assert rows["raw_tlx"] == pytest.approx(45)
    assert rows["effort_weight"] == 4
    assert rows["effort_weighted"] == pytest.approx(16)
    assert {row.instrument for row in result.rows()} == {"nasa_tlx"}
    assert {row.for_model("M2").model for row in result.rows()} == {"M2"}


def test_invariants_on_random_answers() -> None:
    rng = np.random.default_rng(11)
    for _ in range(200):
        ratings = {key: int(rng.integers(0, 21)) * 5 for key in tlx.SUBSCALE_KEYS}
        choices = {pair.key: pair.sides()[int(rng.integers(2))] for pair in tlx.PAIRS}
        result = tlx.score({**ratings, **choices})
        weights = dict(result.weights)
        assert sum(weights.values()) == 15
        assert all(0 <= weight <= 5 for weight in weights.values())
        assert sum(dict(result.weighted).values()) == pytest.approx(result.overall)
        assert 0 <= result.overall <= 100
        assert result.raw_tlx == pytest.approx(np.mean(list(ratings.values())))


def test_pairs_cover_every_combination_once_with_stable_keys() -> None:
    assert len(tlx.PAIRS) == 15
    assert {frozenset(pair.sides()) for pair in tlx.PAIRS} == {
        frozenset(pair) for pair in itertools.combinations(tlx.SUBSCALE_KEYS, 2)
    }
    assert tlx.PAIRS[2].key == "pair_03"
    assert tlx.PAIRS[2].sides() == ("mental_demand", "performance")


def test_comparison_order_is_random_complete_and_reproducible() -> None:
    shown = tlx.comparison_order(np.random.default_rng(5))
    assert [p.position for p in shown] == list(range(1, 16))
    assert sorted(p.pair.key for p in shown) == list(tlx.PAIR_KEYS)
    for presented in shown:
        expected = presented.pair.sides()[::-1] if presented.swapped else presented.pair.sides()
        assert (presented.left, presented.right) == expected
    assert shown == tlx.comparison_order(np.random.default_rng(5))
    orders = {
        tuple(p.pair.key for p in tlx.comparison_order(np.random.default_rng(s))) for s in range(20)
    }
    assert len(orders) > 15
    swaps = [p.swapped for s in range(20) for p in tlx.comparison_order(np.random.default_rng(s))]
    assert 0.3 < np.mean(swaps) < 0.7


def test_validation_rejects_bad_answers_with_clear_messages() -> None:
    answers = {**RATINGS, **choices_from(DOMINANCE)}
    assert tlx.validate(answers) == {}
    bad = {**answers, "mental_demand": 42, "effort": 105, "frustration": "lots"}
    bad["pair_01"] = "effort"
    del bad["pair_15"]
    errors = tlx.validate(bad)
    assert errors["mental_demand"] == ["Must be a multiple of 5, got 42."]
    assert errors["effort"] == ["Must be between 0 and 100, got 105."]
    assert errors["frustration"] == ["Please give a whole number from 0 to 100."]
    assert errors["pair_01"] == ["Choose either Mental demand or Physical demand."]
    assert errors["pair_15"] == ["Please choose one of the two."]
    assert set(errors) == {"mental_demand", "effort", "frustration", "pair_01", "pair_15"}
    with pytest.raises(InvalidAnswers):
        tlx.score(bad)


def test_performance_is_anchored_good_to_poor() -> None:
    item = tlx.RATINGS.item("performance")
    assert (item.low_anchor, item.high_anchor) == ("Good", "Poor")
    assert item.points() == tuple(range(0, 101, 5))


def test_presentation_record_round_trips() -> None:
    shown = tlx.comparison_order(np.random.default_rng(9))
    record = tlx.presentation_record(shown)
    assert len(record) == 30
    first = shown[0]
    assert record[f"{first.pair.key}_position"] == "1"
    assert record[f"{first.pair.key}_left"] == first.left
    assert tlx.order_from_record(record) == shown
