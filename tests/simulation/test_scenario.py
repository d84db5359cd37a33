"""Scenario placement rules and their save/load round trip (spec §2)."""

from __future__ import annotations

import json
from itertools import combinations

import numpy as np
import pytest

from hcss.simulation import Params, Scenario, ScenarioError


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("first", ["easy", "difficult"])
def test_every_section_places_four_targets_per_hub_by_the_rules(seed, first):
    scenario = Scenario.generate(seed, first_section=first)
    params = Params()
    assert [s.kinds for s in scenario.sections] == [
        (first,) * 4,
        (("difficult" if first == "easy" else "easy"),) * 4,
    ]
    for section in scenario.sections:
        points = [(t.x, t.y) for t in section.targets]
        assert len(points) == 16
        for c, hub in enumerate(scenario.hubs):
            own = [t for t in section.targets if t.around == c]
            assert sorted(t.value for t in own) == [0.7, 0.8, 0.9, 1.0]
            distance = {t.value: np.hypot(t.x - hub[0], t.y - hub[1]) for t in own}
            assert all(min(abs(d - r) for r in (150, 250, 350)) < 0.01 for d in distance.values())
            if section.kinds[c] == "easy":
                assert distance[1.0] == pytest.approx(150, abs=0.01)
            else:
                assert distance[1.0] == pytest.approx(350, abs=0.01)
                assert all(d < 349 for v, d in distance.items() if v < 1.0)
        half = params.arena_side_m / 2
        assert all(abs(x) <= half and abs(y) <= half for x, y in points)
        for a, b in combinations(points + list(scenario.hubs), 2):
            assert np.hypot(a[0] - b[0], a[1] - b[1]) >= 50.0 - 1e-6
    ids = [t.id for s in scenario.sections for t in s.targets]
    assert ids == list(range(1, 33))


def test_scenarios_save_and_load_through_json():
    scenario = Scenario.generate(99, first_section="difficult")
    assert Scenario.from_dict(json.loads(json.dumps(scenario.to_dict()))) == scenario


def test_training_has_two_collectives_one_easy_one_difficult():
    training = Scenario.training(5)
    assert training.n_collectives == 2 and len(training.sections) == 1
    assert training.sections[0].kinds == ("easy", "difficult")


def test_bad_scenarios_are_refused_clearly():
    with pytest.raises(ScenarioError, match="first_section"):
        Scenario.generate(1, first_section="medium")
    with pytest.raises(ScenarioError, match="not a scenario"):
        Scenario.from_dict({"seed": 1})
