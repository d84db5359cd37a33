"""Rates and per-agent rules: M2's interaction delays, abandonment and discovery (spec §4, §5)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hcss.simulation import Params
from hcss.simulation import states as S
from hcss.simulation.rules import (
    abandon_probability,
    discovery,
    discovery_gap,
    leave_rate,
    per_step,
    rate_transitions,
    reach_target,
    round_trip_gap,
)
from tests.support.worlds import agents_of, make_sim, place

# These tests check spec §4-5's formulas as first written: spatial encounter,
# d_min, d_max = 150, 350 m and the guard beyond d_max. The other readings
# (params.py) are checked in test_readings.py.
FIRST_READING = {
    "discovery": "spatial",
    "m2_distance_bounds": "site_distances",
    "m2_beyond_dmax": "guard",
    "foreign_targets": "eligible",
}
SPEC5 = Params().with_changes(**FIRST_READING)


def g(d_m: float) -> float:
    """The study's fitted discovery rate, written out independently: d in 100 m units."""
    d = d_m / 100.0
    return 0.058 * math.exp(-0.29 * d) / d


def test_fitted_discovery_times_are_those_the_spec_quotes():
    assert 1 / g(150) == pytest.approx(40.0, abs=0.5)
    assert 1 / g(350) == pytest.approx(167.0, abs=0.5)
    assert 1 / Params().discovery_rate(150.0) == pytest.approx(1 / g(150))


@pytest.mark.parametrize("distance", [150.0, 250.0, 300.0])
def test_discovery_delay_rate_follows_its_formula(distance):
    estimate = np.array([0.85])
    expected = 0.85 / (1 / g(350) - 1 / g(distance))
    assert leave_rate(estimate, discovery_gap(np.array([distance]), SPEC5))[0] == pytest.approx(
        expected
    )


@pytest.mark.parametrize("distance", [150.0, 250.0])
def test_reassessment_delay_rate_follows_its_formula(distance):
    speed = 60 / 3.6
    expected = 0.9 / (2 * 350 / speed - 2 * distance / speed)
    assert leave_rate(np.array([0.9]), round_trip_gap(np.array([distance]), SPEC5))[
        0
    ] == pytest.approx(expected)


@pytest.mark.parametrize("distance", [350.0, 420.0])
def test_delay_is_skipped_at_or_beyond_d_max(distance):
    assert leave_rate(np.array([0.7]), discovery_gap(np.array([distance]), SPEC5))[0] == np.inf
    assert leave_rate(np.array([0.7]), round_trip_gap(np.array([distance]), SPEC5))[0] == np.inf


def _target_at(sim, collective, near):
    w = sim.world
    active = np.flatnonzero(w.active)
    d = w.hub_distance[collective, active]
    return int(active[np.argmin(d) if near else np.argmax(np.where(d <= 500, d, 0))])


def test_m2_agents_leave_discovery_delay_at_the_per_step_rate():
    sim = make_sim("M2", n_agents=4000, **FIRST_READING)
    w = sim.world
    t = _target_at(sim, 0, near=True)
    waiting = agents_of(w, 0, 3000)
    place(w, waiting, S.F_D, target=t, estimate=0.8)
    d = w.hub_distance[0, t]
    p = per_step(0.8 / (1 / g(350) - 1 / g(d)), sim.params)
    rate_transitions(w, sim.params, "M2")
    share = np.mean(w.state[waiting] == S.F_I)
    assert abs(share - p) < 4 * math.sqrt(p * (1 - p) / waiting.size)


def test_m2_agents_of_the_farthest_target_leave_the_delay_at_once():
    sim = make_sim("M2", **FIRST_READING)
    w = sim.world
    t = _target_at(sim, 0, near=False)
    assert w.hub_distance[0, t] >= 350.0 - 1e-6
    waiting = agents_of(w, 0, 20)
    place(w, waiting, S.F_R, target=t)
    rate_transitions(w, sim.params, "M2")
    assert np.all(w.state[waiting] == S.F_I)


def test_m1_has_no_delay_states():
    sim = make_sim("M1", **FIRST_READING)
    sim.step(400)
    assert not np.any(np.isin(sim.world.state, (S.F_D, S.F_R)))


def test_abandon_probability_grows_with_distance_and_falls_with_value():
    sim = make_sim("M1", **FIRST_READING)
    w = sim.world
    a = agents_of(w, 0, 2)
    t = _target_at(sim, 0, near=False)
    place(w, a, S.F_L, target=t, leg=S.TO_TARGET)
    w.estimate[a] = [0.5, 1.0]
    d = w.hub_distance[0, t]
    expected = [min(1, 0.05 * (d / 100) / 0.5), min(1, 0.05 * (d / 100) / 1.0)]
    assert abandon_probability(w, a, sim.params) == pytest.approx(expected)


def test_explorers_adopt_a_sensed_target_with_probability_of_their_estimate():
    sim = make_sim("M1", n_agents=3000, **FIRST_READING)
    w = sim.world
    t = _target_at(sim, 0, near=True)
    explorers = agents_of(w, 0, 3000)
    place(w, explorers, S.U_L, leg=S.EXPLORING)
    w.pos[explorers] = w.target_pos[t] + 2.0  # within the 4.5 m sensing radius
    discovery(w, sim.params, "M1")
    adopted = w.state[explorers] == S.F_L
    assert np.all(w.target[explorers[adopted]] == t) and np.all(
        w.leg[explorers[adopted]] == S.TO_HUB
    )
    assert np.all(w.target[explorers[~adopted]] == -1)
    value = w.target_value[t]  # v̂ is uniform in v·[0.9, 1.1], clipped to 1
    expected = np.mean(np.clip(value * (1 + np.linspace(-0.1, 0.1, 10001)), 0, 1))
    assert abs(adopted.mean() - expected) < 4 * math.sqrt(
        expected * (1 - expected) / explorers.size
    )


def test_explorers_ignore_targets_under_an_abandon_order():
    sim = make_sim("M1", **FIRST_READING)
    w = sim.world
    t = _target_at(sim, 0, near=True)
    explorers = agents_of(w, 0, 100)
    place(w, explorers, S.U_L, leg=S.EXPLORING)
    w.pos[explorers] = w.target_pos[t]
    w.abandon_order[0, t] = True
    discovery(w, sim.params, "M1")
    assert np.all(w.state[explorers] == S.U_L)


# ------------------------------------------- abandonment and g readings (fidelity)
@pytest.mark.parametrize("estimate", [0.5, 1.0])
def test_rate_abandonment_drops_hub_supporters_at_scale_alpha_over_v_hat(estimate):
    """Reading "rate": F_I agents in the hub leave for U_I at α·scale/v̂ per second."""
    sim = make_sim("M1", n_agents=4000, abandonment="rate", abandon_scale=2.0, **FIRST_READING)
    w = sim.world
    supporters = agents_of(w, 0, 3000)
    place(w, supporters, S.F_I, target=_target_at(sim, 0, near=True), estimate=estimate)
    rate_transitions(w, sim.params, "M1")
    p = per_step(2.0 * 0.05 / estimate, sim.params)
    share = np.mean(w.state[supporters] == S.U_I)
    assert abs(share - p) < 4 * math.sqrt(p * (1 - p) / supporters.size)
    assert np.all(w.target[supporters[w.state[supporters] == S.U_I]] == -1)


def test_rate_abandonment_is_value_only_and_per_visit_abandonment_is_not_a_rate():
    near = make_sim("M1", n_agents=4000, abandonment="rate", **FIRST_READING)
    far = make_sim("M1", n_agents=4000, abandonment="rate", **FIRST_READING)
    shares = []
    for sim, is_near in ((near, True), (far, False)):
        w = sim.world
        supporters = agents_of(w, 0, 3000)
        place(w, supporters, S.F_I, target=_target_at(sim, 0, near=is_near), estimate=0.7)
        rate_transitions(w, sim.params, "M1")
        shares.append(np.mean(w.state[supporters] == S.U_I))
    p = per_step(0.05 / 0.7, near.params)
    assert all(abs(s - p) < 4 * math.sqrt(p * (1 - p) / 3000) for s in shares)
    per_visit = make_sim("M1", n_agents=4000, **FIRST_READING)
    supporters = agents_of(per_visit.world, 0, 3000)
    place(per_visit.world, supporters, S.F_I, target=_target_at(per_visit, 0, near=False))
    rate_transitions(per_visit.world, per_visit.params, "M1")
    assert not np.any(per_visit.world.state[supporters] == S.U_I)


def test_rate_abandonment_spares_the_delay_states_and_the_visit():
    """F_D and F_R waits differ by distance by design: a rate there would penalise near sites."""
    sim = make_sim("M2", abandonment="rate", abandon_scale=50.0, **FIRST_READING)
    w = sim.world
    t = _target_at(sim, 0, near=True)
    waiting = agents_of(w, 0, 100)
    place(w, waiting, S.F_D, target=t, estimate=0.1)
    rate_transitions(w, sim.params, "M2")
    assert not np.any(w.state[waiting] == S.U_I)
    # On a visit nothing is abandoned, however far and poor the site (P_α would be 1).
    visitors = agents_of(w, 0, 50, start=100)
    place(w, visitors, S.F_L, target=_target_at(sim, 0, near=False), leg=S.TO_TARGET)
    w.target_value[:] = 0.05
    reach_target(w, visitors, sim.params, "M2")
    assert np.all(w.arrival_state[visitors] == S.F_R)


def test_value_inside_g_makes_the_discovery_delay_v_hat_squared_over_the_gap():
    sim = make_sim("M2", n_agents=4000, m2_g_reading="value_inside", **FIRST_READING)
    w = sim.world
    t = _target_at(sim, 0, near=True)
    waiting = agents_of(w, 0, 3000)
    place(w, waiting, S.F_D, target=t, estimate=0.5)
    d = w.hub_distance[0, t]
    p = per_step(0.5 * 0.5 / (1 / g(350) - 1 / g(d)), sim.params)
    rate_transitions(w, sim.params, "M2")
    share = np.mean(w.state[waiting] == S.F_I)
    assert abs(share - p) < 4 * math.sqrt(p * (1 - p) / waiting.size)
