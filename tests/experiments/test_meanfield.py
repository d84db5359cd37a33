"""The paper's equations as a mean-field model, and its agreement with the agent model."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.experiments.crosscheck import LAYOUTS
from hcss.experiments.meanfield import Rates, Site, solve_meanfield
from hcss.experiments.meanfield_chain import run_chain
from hcss.simulation import Params

SEARCH_SPACE = Params().with_changes(m2_distance_bounds="search_space")
SITE_BOUNDS = Params().with_changes(m2_distance_bounds="site_distances")


def test_win_probabilities_and_undecided_share_add_up_to_one() -> None:
    prediction = solve_meanfield(LAYOUTS["easy"], "M2", SEARCH_SPACE)
    assert sum(prediction.win_probability) + prediction.undecided == pytest.approx(1.0, abs=1e-3)
    assert 0 < prediction.quorum_s < prediction.decision_s


def test_m1_picks_the_nearest_good_site_whatever_is_best() -> None:
    """The paper's bias: M1 is right when the best is near, wrong when it is the farthest."""
    easy = solve_meanfield(LAYOUTS["easy"], "M1", Params())
    difficult = solve_meanfield(LAYOUTS["difficult"], "M1", Params())
    assert easy.winner == 0 and easy.win_probability[0] > 0.9
    assert difficult.winner == 1  # the 0.9 site at 150 m, not the 1.0 site at 350 m


def test_m2_with_the_search_space_bounds_is_accurate_and_slower() -> None:
    for layout in ("easy", "difficult"):
        m1 = solve_meanfield(LAYOUTS[layout], "M1", SEARCH_SPACE)
        m2 = solve_meanfield(LAYOUTS[layout], "M2", SEARCH_SPACE)
        assert m2.winner == 0 and m2.win_probability[0] > 0.9
        assert m2.quorum_s > m1.quorum_s


def test_m2_with_the_site_distance_bounds_favours_the_farthest_site() -> None:
    """d_max = 350 m: the 350 m sites skip the delays and get the largest M_i."""
    easy = solve_meanfield(LAYOUTS["easy"], "M2", SITE_BOUNDS)
    assert LAYOUTS["easy"][easy.winner].distance_m == 350.0


def test_a_single_site_is_chosen_by_every_reading() -> None:
    site = [Site(250.0, 0.9)]
    for model in ("M1", "M2"):
        prediction = solve_meanfield(site, model, Params())
        assert prediction.win_probability[0] == pytest.approx(1.0, abs=1e-3)
        rng = np.random.default_rng(4)
        outcome = run_chain(site, model, Params(), rng)
        assert outcome.chosen == 0


def test_the_chain_agrees_with_the_odes_on_the_winner() -> None:
    """Each reading of the equations checks the other: the chain's modal site is the ODEs' winner."""
    rng = np.random.default_rng(11)
    for layout, model in (("easy", "M1"), ("difficult", "M1"), ("difficult", "M2")):
        params = SEARCH_SPACE
        ode = solve_meanfield(LAYOUTS[layout], model, params)
        chosen = [run_chain(LAYOUTS[layout], model, params, rng).chosen for _ in range(4)]
        assert max(set(chosen), key=chosen.count) == ode.winner, (layout, model, chosen)


@pytest.mark.slow
def test_the_agent_model_agrees_with_the_mean_field_chain_on_simple_layouts() -> None:
    """One collective, its own four sites, per-agent discovery (the mean-field model's).

    Stated tolerances (5 runs each): the agent model's modal site is the ODEs'
    winner, its best-site share is within 0.4 of the chain's, and its mean
    decision time within a factor of 4 of the chain's. The factor is wide
    because the chain has no hub space: on the difficult layout M1's two 150 m
    sites split the well-mixed chain's support for longer (measured with 20
    runs: chain 314 ± 39 s, agent 115 ± 8 s; docs/simulation-notes.md), so the
    expected ratio is about 0.37, and five-run means of the chain (sd ~110-175 s
    per run) move it by a third either way: a factor of 3 failed by chance
    (0.33) when the engine's random stream changed; 4 keeps the structural gap
    and still fails for a real change of the agent model's speed.
    """
    from hcss.experiments.crosscheck import agent_decision

    params = SEARCH_SPACE.with_changes(discovery="per_agent")
    rng = np.random.default_rng(21)
    for layout, model in (("easy", "M1"), ("difficult", "M1"), ("difficult", "M2")):
        sites = LAYOUTS[layout]
        ode = solve_meanfield(sites, model, params)
        chain = [run_chain(sites, model, params, rng) for _ in range(5)]
        agent = [agent_decision(sites, model, params, 300 + i) for i in range(5)]
        agent_sites = [c for c, _ in agent]
        assert max(set(agent_sites), key=agent_sites.count) == ode.winner, (layout, model)
        chain_best = np.mean([c.chosen == 0 for c in chain])
        agent_best = np.mean([c == 0 for c in agent_sites])
        assert abs(chain_best - agent_best) <= 0.4, (layout, model, chain_best, agent_best)
        chain_time = np.mean([c.time_s for c in chain])
        agent_time = np.mean([t for _, t in agent])
        assert 1 / 4 <= agent_time / chain_time <= 4, (layout, model, chain_time, agent_time)


def test_the_odes_read_rate_abandonment_as_value_only_and_per_visit_as_distance_and_value() -> None:
    from hcss.experiments.meanfield import Rates

    sites = [Site(150.0, 1.0), Site(350.0, 0.5)]
    rate = Rates.of(sites, "M2", Params().with_changes(abandonment="rate", abandon_scale=2.0))
    assert rate.abandon == pytest.approx([0.0, 0.0])
    assert rate.abandon_rate == pytest.approx([2 * 0.05 / 1.0, 2 * 0.05 / 0.5])
    visit = Rates.of(sites, "M2", Params().with_changes(abandon_scale=2.0))
    assert visit.abandon == pytest.approx([2 * 0.05 * 1.5 / 1.0, min(1.0, 2 * 0.05 * 3.5 / 0.5)])
    assert visit.abandon_rate == pytest.approx([0.0, 0.0])
    # Supporters who abandon within seconds never reach a quorum.
    drained = solve_meanfield(
        LAYOUTS["easy"],
        "M1",
        Params().with_changes(abandonment="rate", abandon_scale=100.0),
        horizon_s=600.0,
    )
    assert drained.undecided > 0.99
    with pytest.raises(ValueError, match="per visit"):
        run_chain(sites, "M1", Params().with_changes(abandonment="rate"), np.random.default_rng(1))


def test_value_inside_g_lengthens_the_discovery_delay_of_poorer_sites() -> None:
    from hcss.experiments.meanfield import Rates

    sites = [Site(150.0, 1.0), Site(150.0, 0.5)]
    plain = Rates.of(sites, "M2", SEARCH_SPACE)
    inside = Rates.of(sites, "M2", SEARCH_SPACE.with_changes(m2_g_reading="value_inside"))
    assert inside.leave_delay == pytest.approx(plain.leave_delay * np.array([1.0, 0.5]))


def test_the_odes_run_only_the_m2_mechanisms_the_params_keep() -> None:
    """An ablation (`m2_mechanisms`) removes a mechanism from the equations too, as from the
    agent model: M2 with none of its three is M1, and each one removed is gone alone."""
    sites = LAYOUTS["difficult"]
    params = Params().with_changes(m2_distance_bounds="fitted", fitted_d_max_m=430.0)
    m1 = solve_meanfield(sites, "M1", params)
    bare = solve_meanfield(sites, "M2", params.with_changes(m2_mechanisms=()))
    assert bare.win_probability == pytest.approx(m1.win_probability, abs=0.01)
    assert bare.quorum_s == pytest.approx(m1.quorum_s, rel=0.02)
    full = Rates.of(sites, "M2", params)
    assert np.all(np.isfinite(full.leave_delay[[1, 2, 3]])) and np.any(full.send_modulation > 1)
    for mechanism, field in (
        ("discovery_delay", "leave_delay"),
        ("reassessment_delay", "leave_reassess"),
        ("modulation", "send_modulation"),
    ):
        kept = tuple(m for m in params.m2_mechanisms if m != mechanism)
        rates = Rates.of(sites, "M2", params.with_changes(m2_mechanisms=kept))
        removed = np.ones(4) if field == "send_modulation" else np.full(4, np.inf)
        assert np.array_equal(getattr(rates, field), removed)
        for other in {"leave_delay", "leave_reassess", "send_modulation"} - {field}:
            assert np.array_equal(getattr(rates, other), getattr(full, other))
