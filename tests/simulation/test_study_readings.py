"""The readings of the study's scenario, label and M2 wait (issue 28): each does what it says.

Shared by M1, M2 and M3: they are Params, which every model of a trial uses.
"""

from __future__ import annotations

import numpy as np
import pytest

from hcss.experiments import experiment as exp
from hcss.simulation import Params, Scenario, Simulation
from hcss.simulation.decisions import difficulty, label_distance
from hcss.simulation.presets import PRESETS
from hcss.simulation.rules import discovery_gap
from tests.support.worlds import lay_out, make_sim

STRICT = Params().with_changes(easy_layout_others="strictly_farther")
SEEDS = range(100, 112)


def _easy_distances(scenario: Scenario) -> list[tuple[float, list[float]]]:
    """Per collective of each easy section: the best site's distance and the others'."""
    out = []
    for section in scenario.sections:
        for c, kind in enumerate(section.kinds):
            if kind != "easy":
                continue
            hub = np.array(scenario.hubs[c])
            own = [t for t in section.targets if t.around == c]
            d = {t.value: float(np.hypot(*(np.array([t.x, t.y]) - hub))) for t in own}
            out.append((d[1.0], [d[v] for v in (0.7, 0.8, 0.9)]))
    return out


def test_strictly_farther_easy_layouts_put_every_other_site_beyond_the_best() -> None:
    for seed in SEEDS:
        for best, others in _easy_distances(Scenario.generate(seed, params=STRICT)):
            assert best == pytest.approx(150.0, abs=0.01)
            assert min(others) > 150.0 + 1.0  # 250 or 350 m
    # "anywhere" (the default) ties the best at 150 m in many easy layouts.
    ties = [
        min(others) < 150.01
        for seed in SEEDS
        for _, others in _easy_distances(Scenario.generate(seed))
    ]
    assert 0 < sum(ties) < len(ties)


def test_the_default_layout_reading_leaves_scenarios_as_they_were() -> None:
    assert Scenario.generate(7) == Scenario.generate(7, params=Params())
    # The difficult section is strict under both readings: identical draws are not
    # promised (the easy section's draws come first), the rule is.
    for seed in SEEDS:
        scenario = Scenario.generate(seed, first_section="difficult", params=STRICT)
        section = scenario.sections[0]
        for c in range(4):
            hub = np.array(scenario.hubs[c])
            d = {
                t.value: float(np.hypot(t.x - hub[0], t.y - hub[1]))
                for t in section.targets
                if t.around == c
            }
            assert d[1.0] == pytest.approx(350.0, abs=0.01)
            assert max(d[v] for v in (0.7, 0.8, 0.9)) < 349.0


def test_the_experiment_draws_its_scenarios_under_the_runs_params() -> None:
    drawn = exp.experiment_scenarios(2, 500, STRICT)
    assert drawn == [
        Scenario.generate(500, "easy", scenario_id="exp01", params=STRICT),
        Scenario.generate(501, "difficult", scenario_id="exp02", params=STRICT),
    ]
    assert drawn != exp.experiment_scenarios(2, 500)


@pytest.mark.parametrize(
    ("targets", "label", "distances", "expected"),
    [
        # best at 250 m, a poorer site nearer (150) and one farther (350)
        ([(250, 1.0), (150, 0.9), (350, 0.8)], "best_nearest", "exact", "difficult"),
        ([(250, 1.0), (150, 0.9), (350, 0.8)], "best_not_furthest", "exact", "easy"),
        # best the furthest: difficult under both labels
        ([(350, 1.0), (150, 0.9), (250, 0.8)], "best_nearest", "exact", "difficult"),
        ([(350, 1.0), (150, 0.9), (250, 0.8)], "best_not_furthest", "exact", "difficult"),
        # 230 m and 280 m share the 200-300 m ring: not nearer by ring, nearer exactly
        ([(280, 1.0), (230, 0.9)], "best_nearest", "exact", "difficult"),
        ([(280, 1.0), (230, 0.9)], "best_nearest", "ring", "easy"),
        # by ring the 340 m site is not farther than the best at 310 m: best is furthest
        ([(310, 1.0), (150, 0.9), (340, 0.8)], "best_not_furthest", "exact", "easy"),
        ([(310, 1.0), (150, 0.9), (340, 0.8)], "best_not_furthest", "ring", "difficult"),
    ],
)
def test_the_label_reading_and_its_distances(targets, label, distances, expected) -> None:
    sim = make_sim("M1", difficulty_label=label, label_distances=distances)
    lay_out(sim, 0, targets)
    assert difficulty(sim.world, 0, sim.params) == expected


def test_rings_are_100_m_from_the_current_hub_and_kept_at_their_edges() -> None:
    ring = Params().with_changes(label_distances="ring")
    assert [label_distance(d, ring) for d in (99.9, 150.0, 199.9996, 250.0, 350.0)] == [
        0.0,
        1.0,
        2.0,  # 199.9996 is 200.000 to the millimetre of stored coordinates
        2.0,
        3.0,
    ]
    assert label_distance(123.4, Params()) == 123.4


def test_a_sections_first_decisions_keep_their_layouts_kind_under_the_loose_label() -> None:
    params = Params().with_changes(difficulty_label="best_not_furthest", foreign_targets="eligible")
    for kind in ("easy", "difficult"):
        sim = Simulation(Scenario.generate(5, first_section=kind, params=params), "M1", params)
        assert [d.difficulty for d in sim.open] == [kind] * 4


def test_the_wait_scale_scales_m2s_discovery_wait_only() -> None:
    d = np.array([150.0, 250.0, 350.0])
    base = Params()
    tenth = base.with_changes(m2_discovery_wait_scale=0.1)
    # 1/g(d) = (d/100)·e^(0.29·d/100)/0.058; d_max = 500 m under the literal preset
    inv_g = (d / 100) * np.exp(0.29 * d / 100) / 0.058
    inv_g_max = 5.0 * np.exp(0.29 * 5.0) / 0.058
    assert discovery_gap(d, base) == pytest.approx(inv_g_max - inv_g)
    assert discovery_gap(d, tenth) == pytest.approx(0.1 * (inv_g_max - inv_g))
    with pytest.raises(ValueError, match="m2_discovery_wait_scale"):
        base.with_changes(m2_discovery_wait_scale=0.0)


@pytest.mark.parametrize("field", ["easy_layout_others", "difficulty_label", "label_distances"])
def test_an_unknown_reading_is_refused_with_its_name(field: str) -> None:
    with pytest.raises(ValueError, match=field):
        Params().with_changes(**{field: "bogus"})


def test_presets_carry_the_readings_and_round_trip() -> None:
    for params in PRESETS.values():
        assert Params.from_dict(params.to_dict()) == params
        assert params.easy_layout_others in ("anywhere", "strictly_farther")
