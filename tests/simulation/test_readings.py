"""The named readings of the paper (params.py): each option changes only what it says."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.simulation import Params, Simulation
from hcss.simulation import states as S
from hcss.simulation.decisions import in_range_targets
from hcss.simulation.discovery import site_rates
from hcss.simulation.messaging import frequency_modulation
from hcss.simulation.rules import discoverable, discovery, discovery_gap, round_trip_gap
from tests.support.worlds import agents_of, make_sim, place


@pytest.mark.parametrize(
    "field", ["discovery", "m2_distance_bounds", "m2_beyond_dmax", "foreign_targets"]
)
def test_an_unknown_reading_is_refused_with_its_name(field: str) -> None:
    with pytest.raises(ValueError, match=field):
        Params().with_changes(**{field: "bogus"})


def test_readings_survive_the_params_round_trip() -> None:
    p = Params().with_changes(
        discovery="per_agent",
        m2_distance_bounds="search_space",
        m2_beyond_dmax="clamp",
        foreign_targets="own_only",
    )
    assert Params.from_dict(p.to_dict()) == p


def test_search_space_bounds_move_d_max_to_the_range() -> None:
    site = Params().with_changes(m2_distance_bounds="site_distances")
    space = Params().with_changes(m2_distance_bounds="search_space")
    assert (site.m2_d_min_m, site.m2_d_max_m) == (150.0, 350.0)
    assert (space.m2_d_min_m, space.m2_d_max_m) == (150.0, 500.0)
    # Under d_max = 500 m a site at 350 m waits; under 350 m it does not.
    assert discovery_gap(np.array([350.0]), space)[0] > 0
    assert discovery_gap(np.array([350.0]), site)[0] == pytest.approx(0.0)
    assert round_trip_gap(np.array([150.0]), space)[0] == pytest.approx(2 * 350 / space.speed_mps)


def test_clamp_caps_modulation_at_d_max_and_guard_does_not() -> None:
    d = np.array([100.0, 150.0, 350.0, 500.0])
    site = Params().with_changes(m2_distance_bounds="site_distances")
    guard = site.with_changes(m2_beyond_dmax="guard")
    clamp = site.with_changes(m2_beyond_dmax="clamp")
    assert frequency_modulation(d, guard) == pytest.approx(d / 150.0)
    assert frequency_modulation(d, clamp) == pytest.approx([1.0, 1.0, 350 / 150, 350 / 150])
    # Beyond d_max both readings skip the delays (gap ≤ 0 means leave at once).
    assert discovery_gap(np.array([500.0]), guard)[0] < 0
    assert discovery_gap(np.array([500.0]), clamp)[0] == pytest.approx(0.0)


def test_own_only_excludes_foreign_targets_from_discovery_and_best_choice() -> None:
    eligible = make_sim("M1", foreign_targets="eligible")
    own = make_sim("M1", foreign_targets="own_only")
    w = own.world
    for c in range(w.n_collectives):
        mine = set(np.flatnonzero(w.active & (w.target_around == c)))
        assert set(in_range_targets(w, c, own.params)) <= mine
        assert set(np.flatnonzero(discoverable(w, own.params)[c])) <= mine
    # The default reading lets some collective see a neighbour's target in range.
    we = eligible.world
    foreign = [
        t
        for c in range(we.n_collectives)
        for t in in_range_targets(we, c, eligible.params)
        if we.target_around[t] != c
    ]
    assert foreign


def test_per_agent_discovery_follows_g_of_d() -> None:
    """Explorers find sites at Σ g(d_i) per agent and second and adopt with probability v̂."""
    sim = make_sim("M1", discovery="per_agent")
    w, p = sim.world, sim.params
    explorers = agents_of(w, 0, 200)
    rates = site_rates(w, p)[0]
    # E[v̂] for v̂ = v·(1+e), e ~ U[-0.1, 0.1], clipped at 1 (only v = 1.0 is clipped: 0.975).
    mean_estimate = np.where(w.target_value >= 1.0, 0.975, w.target_value)
    expected = -np.expm1(-rates.sum() * p.dt_s) * np.sum(rates / rates.sum() * mean_estimate)
    adopted = 0
    trials = 60
    for _ in range(trials):
        place(w, explorers, S.U_L, leg=S.EXPLORING)
        discovery(w, p, "M1")
        adopted += int(np.sum(w.leg[explorers] == S.TO_HUB))
    share = adopted / (trials * explorers.size)
    # Binomial(12000, ~0.04): 4 standard errors is about 0.007.
    assert share == pytest.approx(expected, abs=0.007)


def test_per_agent_discovery_adopts_with_probability_v_hat() -> None:
    sim = make_sim("M2", discovery="per_agent")
    w, p = sim.world, sim.params
    explorers = agents_of(w, 0, 200)
    adopted: list[int] = []
    for _ in range(60):
        place(w, explorers, S.U_L, leg=S.EXPLORING)
        discovery(w, p, "M2")
        adopters = explorers[w.leg[explorers] == S.TO_HUB]
        assert np.all(w.state[adopters] == S.F_L)
        assert np.all(w.arrival_state[adopters] == S.F_D)
        adopted.extend(w.target[adopters].tolist())
    assert adopted
    assert set(adopted) <= set(np.flatnonzero(site_rates(w, p)[0] > 0))


def test_a_full_trial_runs_under_every_reading() -> None:
    p = Params().with_changes(
        discovery="per_agent",
        m2_distance_bounds="search_space",
        m2_beyond_dmax="clamp",
        foreign_targets="own_only",
        decisions_per_section=1,
    )
    sim = Simulation(make_sim("M2").scenario, "M2", p)
    sim.run_until_finished(max_steps=4 * 1800)
    assert sim.finished
    assert len(sim.decisions) == 2
