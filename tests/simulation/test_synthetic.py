"""The synthetic operator acts on what the interface shows, never on the simulation's truth."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.experiments.synthetic_trials import run_trial
from hcss.simulation import Scenario, Simulation
from hcss.simulation.presets import preset_params
from hcss.simulation.synthetic import Population, SyntheticOperator, Traits
from hcss.simulation.view import Truth

PARAMS = preset_params()
BUSY = Traits(
    glance_interval_s=2.0,
    investigate_prob=0.9,
    stalled_investigate_prob=1.0,
    decide_prob=0.9,
    abandon_prob=0.9,
    abandon_support=0.05,
    abandon_gap=0.05,
    slip_prob=0.2,
    observe_collective_prob=0.5,
    observe_target_prob=0.5,
)


def _scenario(seed: int = 11) -> Scenario:
    return Scenario.generate(seed, first_section="difficult", params=PARAMS)


def test_a_planted_truth_changes_no_look() -> None:
    """Two simulations alike in all the display shows, with the true values planted
    otherwise in one: the same operator clicks the same, look after look."""
    sim = Simulation(_scenario(), "M1", PARAMS)
    sim.step(240)
    planted = Simulation.restore(sim.snapshot())
    w = planted.world
    w.target_value[:] = w.target_value[::-1].copy()  # the truth only: no agent has moved
    assert not np.array_equal(planted.truth().values, sim.truth().values)
    assert planted.truth().best_target.tolist() != sim.truth().best_target.tolist()
    a, b = SyntheticOperator(BUSY, 3), SyntheticOperator(BUSY, 3)
    clicks = 0
    for _ in range(12):
        first, second = a.look(sim.display()), b.look(planted.display())
        assert first == second
        clicks += len(first.commands) + len(first.observations)
    assert clicks > 0  # it did act: the equality is about actions, not about silence


def test_a_planted_truth_changes_no_request_in_a_whole_trial(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A whole operated trial, then again with `Simulation.truth` planted (reversed values,
    no best target): the probes' truths change, the requests and decisions do not."""
    scenario = _scenario(12)
    _, honest = run_trial(scenario, "M1", PARAMS, SyntheticOperator(BUSY, 5), "p", "t", 600.0)

    def planted(self: Simulation) -> Truth:
        values = np.array(self.world.target_value[::-1], dtype=float)
        return Truth(values, np.zeros(self.world.n_collectives, dtype=np.int64))

    monkeypatch.setattr(Simulation, "truth", planted)
    _, fooled = run_trial(scenario, "M1", PARAMS, SyntheticOperator(BUSY, 5), "p", "t", 600.0)
    assert honest.requests and honest.requests == fooled.requests
    assert honest.observations == fooled.observations
    assert honest.decisions == fooled.decisions
    assert [p["truth"] for p in honest.probes] != [p["truth"] for p in fooled.probes]


def test_slips_are_refused_and_every_kind_of_action_happens() -> None:
    _, rows = run_trial(_scenario(13), "M1", PARAMS, SyntheticOperator(BUSY, 7), "p", "t", 900.0)
    kinds = {(r["kind"], r["accepted"]) for r in rows.requests}
    assert {("investigate", True), ("abandon", True)} <= kinds
    assert any(not r["accepted"] for r in rows.requests)  # its slips
    assert {o["kind"] for o in rows.observations} == {"collective", "target"}
    assert rows.probes and all(p["answer"] for p in rows.probes if not p["timed_out"])


def test_a_population_draws_valid_people_that_differ() -> None:
    population = Population(spread=0.8)
    people = [population.participant(seed) for seed in range(50)]
    assert len({p.glance_interval_s for p in people}) == 50
    assert all(p.decide_support >= 0.30 for p in people)
    assert all(0.0 <= p.investigate_prob <= 1.0 for p in people)
    assert population.participant(7) == population.participant(7)
    median = Population(spread=0.0).participant(3).to_dict()
    assert median == pytest.approx(Traits().to_dict())  # no spread: everyone is the median


def test_a_decide_threshold_below_the_interfaces_floor_is_refused() -> None:
    with pytest.raises(ValueError, match="decide_support"):
        Traits(decide_support=0.2)
