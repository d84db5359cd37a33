"""M_i's uses (issue 39): which of an F_I(i) agent's messages' uses carry M_i, d_min's reading,
and M1's queue messages, in the agent model. The rates are checked statistically (seeded);
the default reading keeps the engine's random stream bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.simulation import Params, Scenario, Simulation
from hcss.simulation import states as S
from hcss.simulation.messaging import ALL_USES, INHIBITION, QUEUE, RECRUITMENT, Inbox, compose
from hcss.simulation.presets import DEFAULT_PRESET, STUDY_UNITS, preset_params
from hcss.simulation.rules import refresh_geometry
from tests.support.worlds import agents_of, lay_out, make_sim, place, send

# State digests of trials under study-units, the default preset before issue 39
# (Scenario.generate(11, first_section="easy"), run 2, 900 steps), computed on the engine
# before M_i's uses were split (main at 6af1375): the default readings of M_i must
# reproduce them.
DIGESTS_BEFORE_SPLIT = {
    "M1": (665, "e3e7eb8e39babd859e9ad09084d961ddd0f7421ebf50d6c8f8499b7c19402cbb"),
    "M2": (900, "4c898326f232b88ef9e4554f53cb61b9a732676d1a45c55bbe758bd667570a64"),
    "M3": (900, "b5106ebdaee72229d4d94461f04d89556133c3199071b7a12ca2b2fe01b0fc8d"),
}
BIT = {"queue": QUEUE, "recruitment": RECRUITMENT, "inhibition": INHIBITION}


@pytest.mark.parametrize("model", sorted(DIGESTS_BEFORE_SPLIT))
def test_the_default_readings_run_bit_for_bit_as_before_the_split(model: str) -> None:
    """study-units (the default before issue 39) keeps its stream: the new readings at their
    defaults draw nothing; the new default differs from it only in foreign_targets."""
    assert preset_params(DEFAULT_PRESET).m2_modulation_uses == (
        "queue",
        "recruitment",
        "inhibition",
    )
    params = preset_params(STUDY_UNITS)
    sim = Simulation(
        Scenario.generate(11, first_section="easy", params=params), model, params, run=2
    )
    sim.step(900)
    assert (sim.step_count, sim.state_digest()) == DIGESTS_BEFORE_SPLIT[model]


def _use_rates(
    model: str, rounds: int = 300, **changes: object
) -> tuple[dict[str, float], float, float]:
    """Per sender and step: how often an F_I sender's messages carry each use; and M_i, r·dt."""
    sim = make_sim(model, n_agents=400, m2_beyond_dmax="guard", **changes)
    w = sim.world
    lay_out(sim, 0, [(150.0, 0.9), (330.0, 1.0)])
    refresh_geometry(w, sim.params)
    senders = agents_of(w, 0, 100)
    place(w, senders, S.F_I, target=1)
    counts = dict.fromkeys(BIT, 0)
    for _ in range(rounds):
        inbox = compose(w, sim.params, model)
        assert inbox.uses is not None
        mine = np.isin(inbox.sender, senders)
        for use, bit in BIT.items():
            counts[use] += int(np.count_nonzero(inbox.uses[mine] & bit))
    per_sender = {use: n / (rounds * senders.size) for use, n in counts.items()}
    return per_sender, float(w.send_factor[0, 1]), sim.params.message_rate * sim.params.dt_s


@pytest.mark.parametrize(
    "uses",
    [
        ("recruitment",),
        ("recruitment", "inhibition"),
        ("queue",),
        ("queue", "inhibition"),
        ("queue", "recruitment", "inhibition"),
    ],
)
def test_each_use_is_sent_at_r_times_m_i_when_modulated_and_at_r_otherwise(uses):
    rates, m_i, r = _use_rates("M2", m2_modulation_uses=uses)
    assert m_i == pytest.approx(330.0 / 150.0)
    for use, rate in rates.items():
        expected = r * (m_i if use in uses else 1.0)
        # 30,000 sender-steps: Poisson counts, SE about 0.6 % of the mean; the neighbour
        # search fails rarely (400 agents in a 50 m hub, 30 m range).
        assert rate == pytest.approx(expected, rel=0.05), use


def test_m1_queue_messages_carry_m_i_only_under_the_modulated_reading():
    rates, m_i, r = _use_rates("M1", m1_queue_modulation="modulated")
    assert rates["queue"] == pytest.approx(r * m_i, rel=0.05)
    assert rates["recruitment"] == pytest.approx(r, rel=0.05)
    assert rates["inhibition"] == pytest.approx(r, rel=0.05)
    plain, _, _ = _use_rates("M1")
    for use in BIT:
        assert plain[use] == pytest.approx(r, rel=0.05)
    # M2's own uses are not M1's: M2 with recruitment only leaves its queue at r.
    m2, _, _ = _use_rates(
        "M2", m2_modulation_uses=("recruitment",), m1_queue_modulation="modulated"
    )
    assert m2["queue"] == pytest.approx(r, rel=0.05)


def test_d_min_from_the_nearest_eligible_site_gives_the_nearest_site_m_i_of_one():
    sim = make_sim("M2", m2_d_min="nearest_site", m2_beyond_dmax="guard")
    w = sim.world
    lay_out(sim, 0, [(210.0, 0.9), (315.0, 1.0)])
    refresh_geometry(w, sim.params)
    assert w.send_factor[0, 0] == pytest.approx(1.0)
    assert w.send_factor[0, 1] == pytest.approx(315.0 / 210.0)
    rates, m_i, r = _use_rates("M2", m2_d_min="nearest_site")
    assert m_i == pytest.approx(330.0 / 150.0)  # _use_rates' layout: nearest at 150 m
    assert rates["queue"] == pytest.approx(r * m_i, rel=0.05)
    search_space = make_sim("M2", m2_beyond_dmax="guard")
    lay_out(search_space, 0, [(210.0, 0.9), (315.0, 1.0)])
    refresh_geometry(search_space.world, search_space.params)
    assert search_space.world.send_factor[0, 0] == pytest.approx(210.0 / 150.0)


def _one_message(sim: Simulation, sender: int, receiver: int, uses: int, draw: float) -> None:
    w = sim.world
    inbox = Inbox(
        sender=np.array([sender]),
        receiver=np.array([receiver]),
        sender_state=w.state[[sender]].copy(),
        sender_target=w.target[[sender]].copy(),
        sender_estimate=w.estimate[[sender]].copy(),
        uses=np.array([uses], dtype=np.int8),
    )
    from hcss.simulation.messaging import deliver

    deliver(w, sim.params, sim.model, inbox, np.array([0]), np.array([draw]))


def test_a_message_without_a_use_does_not_do_what_that_use_does():
    sim = make_sim("M2")
    w = sim.world
    sender, uncommitted, rival, ally = agents_of(w, 0, 4)
    place(w, np.array([sender, ally]), S.F_I, target=2, estimate=0.9)
    place(w, np.array([uncommitted]), S.U_I)
    place(w, np.array([rival]), S.F_I, target=3)
    _one_message(sim, sender, uncommitted, ALL_USES ^ RECRUITMENT, draw=0.0)
    assert w.state[uncommitted] == S.U_I
    _one_message(sim, sender, rival, ALL_USES ^ INHIBITION, draw=0.0)
    assert (w.state[rival], w.target[rival]) == (S.F_I, 3)
    w.streak[ally] = 4
    _one_message(sim, sender, ally, ALL_USES ^ QUEUE, draw=0.99)
    assert w.streak[ally] == 4  # the window neither grows nor breaks
    _one_message(sim, sender, ally, QUEUE, draw=0.99)
    assert w.streak[ally] == 5
    w.streak[rival] = 6
    _one_message(
        sim, sender, rival, QUEUE, draw=0.0
    )  # counts, breaks the rival's run, no inhibition
    assert (w.state[rival], w.streak[rival]) == (S.F_I, 0)
    send(sim, np.array([sender]), np.array([uncommitted]), draw=0.0)  # all uses: recruits
    assert w.state[uncommitted] == S.F_L


@pytest.mark.parametrize("bad", [(), ("queue", "bogus"), ("queue", "queue")])
def test_an_empty_or_unknown_set_of_uses_is_refused(bad):
    with pytest.raises(ValueError, match="m2_modulation_uses"):
        Params().with_changes(m2_modulation_uses=bad)


def test_the_uses_are_one_set_whatever_their_order_and_survive_the_round_trip():
    params = Params().with_changes(
        m2_modulation_uses=("inhibition", "recruitment"),
        m1_queue_modulation="modulated",
        m2_d_min="nearest_site",
    )
    assert params.m2_modulation_uses == ("recruitment", "inhibition")
    assert Params.from_dict(params.to_dict()) == params
    assert "m2_d_min" in params.stored_dict()
    assert "m2_d_min" not in Params().stored_dict()  # default: the digest as before


def test_a_full_trial_runs_under_the_split_readings():
    params = preset_params(DEFAULT_PRESET).with_changes(
        m2_modulation_uses=("recruitment",),
        m1_queue_modulation="modulated",
        m2_d_min="nearest_site",
    )
    for model in ("M1", "M2"):
        sim = Simulation(Scenario.generate(5, params=params), model, params)
        sim.step(1200)
        assert sim.decisions, model
