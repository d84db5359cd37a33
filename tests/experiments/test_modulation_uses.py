"""M_i's uses, d_min's reading and M1's queue messages (issue 39) in the mean-field equations
and the stochastic chain: the same rates as the agent model (tests/simulation/test_modulation_uses.py)."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.experiments.crosscheck import LAYOUTS
from hcss.experiments.meanfield import Rates, Site, solve_meanfield
from hcss.experiments.meanfield_chain import FI, UI, Chain, run_chain
from hcss.simulation import Params

USES = ("queue", "recruitment", "inhibition")
BASE = Params().with_changes(m2_distance_bounds="fitted", fitted_d_max_m=430.0)
SITES = [Site(150.0, 0.9), Site(330.0, 1.0)]


def _factors(rates: Rates) -> dict[str, np.ndarray]:
    return {
        "queue": rates.queue_modulation,
        "recruitment": rates.recruit_modulation,
        "inhibition": rates.inhibit_modulation,
    }


@pytest.mark.parametrize("uses", [("recruitment",), ("queue", "inhibition"), USES])
def test_the_equations_put_m_i_on_the_uses_named_and_1_on_the_others(uses):
    rates = Rates.of(SITES, "M2", BASE.with_changes(m2_modulation_uses=uses))
    m_i = np.array([1.0, 330.0 / 150.0])
    for use, factor in _factors(rates).items():
        assert factor == pytest.approx(m_i if use in uses else np.ones(2)), use
    assert rates.send_modulation == pytest.approx(m_i)


def test_m1_carries_m_i_only_on_its_queue_and_only_under_the_modulated_reading():
    plain = Rates.of(SITES, "M1", BASE)
    assert all(np.array_equal(f, np.ones(2)) for f in _factors(plain).values())
    queued = Rates.of(SITES, "M1", BASE.with_changes(m1_queue_modulation="modulated"))
    assert queued.queue_modulation == pytest.approx([1.0, 330.0 / 150.0])
    assert np.array_equal(queued.recruit_modulation, np.ones(2))
    assert np.array_equal(queued.inhibit_modulation, np.ones(2))


def test_d_min_from_the_nearest_site_of_the_layout():
    sites = [Site(250.0, 0.9), Site(350.0, 1.0)]
    nearest = Rates.of(sites, "M2", BASE.with_changes(m2_d_min="nearest_site"))
    assert nearest.queue_modulation == pytest.approx([1.0, 350.0 / 250.0])
    search_space = Rates.of(sites, "M2", BASE)
    assert search_space.queue_modulation == pytest.approx([250.0 / 150.0, 350.0 / 150.0])


@pytest.mark.parametrize(
    ("model", "changes"),
    [
        ("M2", {"m2_modulation_uses": ("recruitment",)}),
        ("M2", {"m2_modulation_uses": ("queue", "inhibition")}),
        ("M2", {}),
        ("M1", {"m1_queue_modulation": "modulated"}),
    ],
)
def test_the_chain_sends_each_use_at_r_times_its_factor(model, changes):
    params = BASE.with_changes(n_agents=400, **changes)
    chain = Chain(SITES, model, params, np.random.default_rng(5))
    favouring = np.arange(100)
    chain.state[favouring], chain.target[favouring] = FI, 1
    chain.state[100:], chain.target[100:] = UI, -1
    counts, rounds = np.zeros(3), 300
    for _ in range(rounds):
        senders, _receivers, uses = chain.compose()
        counts += uses[:, senders < 100].sum(axis=1)
    r = params.message_rate * params.dt_s
    factors = _factors(chain.rates)
    for row, use in enumerate(USES):
        expected = r * factors[use][1]
        assert counts[row] / (rounds * favouring.size) == pytest.approx(expected, rel=0.05), use


def test_the_equations_and_the_chain_agree_under_eq_4_as_printed():
    """M_i on recruitment and inhibition only (Eq. 4), queue unmodulated: both readings of
    the equations pick the same site on the study's difficult layout."""
    params = BASE.with_changes(m2_modulation_uses=("recruitment", "inhibition"))
    sites = LAYOUTS["difficult"]
    ode = solve_meanfield(sites, "M2", params)
    rng = np.random.default_rng(3)
    chosen = [run_chain(sites, "M2", params, rng).chosen for _ in range(4)]
    assert max(set(chosen), key=chosen.count) == ode.winner, chosen
    # The queue unmodulated changes the equations' prediction from the all-uses reading's.
    everything = solve_meanfield(sites, "M2", BASE)
    assert ode.quorum_s != pytest.approx(everything.quorum_s, rel=0.01)
