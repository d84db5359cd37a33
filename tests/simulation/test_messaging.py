"""Recruitment, cross-inhibition, quorum streaks and message rates (spec §4, §5, §7)."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.simulation import states as S
from hcss.simulation.messaging import compose, frequency_modulation
from tests.support.worlds import agents_of, make_sim, place, send


def test_recruitment_turns_uncommitted_into_assessing_agents_with_probability_of_senders_estimate():
    sim = make_sim("M1")
    w = sim.world
    sender, low, high = agents_of(w, 0, 3)
    place(w, np.array([sender]), S.F_I, target=5, estimate=0.7)
    place(w, np.array([low, high]), S.U_I)
    send(sim, np.array([sender, sender]), np.array([low, high]), draw=np.array([0.69, 0.71]))
    assert (w.state[low], w.target[low], w.leg[low]) == (S.F_L, 5, S.TO_TARGET)
    assert (w.state[high], w.target[high], w.leg[high]) == (S.U_I, -1, S.AT_HUB)


def test_recruitment_rate_matches_estimate_statistically():
    sim = make_sim("M1", n_agents=2000)
    w = sim.world
    sender = agents_of(w, 0, 1)
    receivers = agents_of(w, 0, 1500, start=1)
    place(w, sender, S.F_I, target=2, estimate=0.8)
    place(w, receivers, S.U_I)
    draws = np.random.default_rng(1).random(receivers.size)
    send(sim, np.repeat(sender, receivers.size), receivers, draw=draws)
    share = np.mean(w.state[receivers] == S.F_L)
    assert abs(share - 0.8) < 4 * np.sqrt(0.8 * 0.2 / receivers.size)


@pytest.mark.parametrize("sender_state", [S.U_I, S.D])
def test_only_favouring_interactive_senders_recruit(sender_state):
    sim = make_sim("M1")
    w = sim.world
    sender, receiver = agents_of(w, 0, 2)
    place(w, np.array([sender]), sender_state, target=4)
    place(w, np.array([receiver]), S.U_I)
    send(sim, np.array([sender]), np.array([receiver]), draw=0.0)
    assert w.state[receiver] == S.U_I


def test_semi_interactive_and_latent_agents_do_not_send():
    sim = make_sim("M2")
    w = sim.world
    mine = agents_of(w, 0, 200)
    for i, state in enumerate([S.F_D, S.F_R, S.F_L, S.U_L]):
        place(w, mine[i * 50 : (i + 1) * 50], state, target=3)
    place(w, agents_of(w, 1, 50), S.F_I, target=3)  # collective II still talks
    inbox = compose(w, sim.params, "M2")
    assert inbox.sender.size > 0
    assert not np.any(w.collective[inbox.sender] == 0)


@pytest.mark.parametrize("receiver_state", [S.F_I, S.F_D, S.F_R])
def test_cross_inhibition_sends_favouring_agents_of_another_target_to_explore(receiver_state):
    sim = make_sim("M2")
    w = sim.world
    sender, receiver = agents_of(w, 0, 2)
    place(w, np.array([sender]), S.F_I, target=1, estimate=0.9)
    place(w, np.array([receiver]), receiver_state, target=2)
    send(sim, np.array([sender]), np.array([receiver]), draw=0.5)
    assert (w.state[receiver], w.target[receiver], w.leg[receiver]) == (S.U_L, -1, S.EXPLORING)


def test_no_cross_inhibition_between_agents_of_the_same_target_or_above_the_estimate():
    sim = make_sim("M1")
    w = sim.world
    sender, same, lucky = agents_of(w, 0, 3)
    place(w, np.array([sender]), S.F_I, target=1, estimate=0.6)
    place(w, np.array([same]), S.F_I, target=1)
    place(w, np.array([lucky]), S.F_I, target=2)
    send(sim, np.array([sender, sender]), np.array([same, lucky]), draw=np.array([0.0, 0.61]))
    assert w.state[same] == S.F_I and w.state[lucky] == S.F_I and w.target[lucky] == 2


def test_a_streak_of_k_messages_from_the_same_decision_state_makes_a_quorum():
    sim = make_sim("M1")
    w = sim.world
    senders, receiver = agents_of(w, 0, 20), agents_of(w, 0, 1, start=30)
    place(w, senders, S.F_I, target=6)
    place(w, receiver, S.F_I, target=6)
    for i in range(sim.params.quorum_k - 1):
        send(sim, senders[[i]], receiver, draw=1.0)
    assert w.state[receiver[0]] == S.F_I and w.streak[receiver[0]] == sim.params.quorum_k - 1
    send(sim, senders[[0]], receiver, draw=1.0)
    assert (w.state[receiver[0]], w.target[receiver[0]]) == (S.C, 6)
    assert w.streak[receiver[0]] == 0  # the window is cleared by the change of decision state


def test_a_message_from_another_decision_state_breaks_the_streak():
    sim = make_sim("M1")
    w = sim.world
    senders, other, receiver = (
        agents_of(w, 0, 20),
        agents_of(w, 0, 1, start=25),
        agents_of(w, 0, 1, start=30),
    )
    place(w, senders, S.F_I, target=6)
    place(w, other, S.U_I)
    place(w, receiver, S.F_I, target=6)
    for i in range(10):
        send(sim, senders[[i]], receiver, draw=1.0)
    send(sim, other, receiver)
    assert w.streak[receiver[0]] == 0
    for i in range(sim.params.quorum_k - 1):
        send(sim, senders[[i]], receiver, draw=1.0)
    assert w.state[receiver[0]] == S.F_I


def test_moving_between_latent_and_interactive_keeps_the_streak_but_a_new_opinion_clears_it():
    sim = make_sim("M1")
    w = sim.world
    agent = agents_of(w, 0, 1)
    place(w, agent, S.F_I, target=3)
    w.streak[agent] = 9
    w.set_state(agent, S.F_L)  # leaves to reassess the same target
    w.set_state(agent, S.F_I)
    assert w.streak[agent[0]] == 9
    w.set_state(agent, S.F_I, 4)  # now favours another target
    assert w.streak[agent[0]] == 0


def test_commitment_chain_committed_recruits_deliberating_and_initiating_spreads():
    sim = make_sim("M1")
    w = sim.world
    c_sender, i_sender, u, f, c_same, c_other = agents_of(w, 0, 6)
    place(w, np.array([c_sender]), S.C, target=2)
    place(w, np.array([i_sender]), S.I, target=2)
    place(w, np.array([u]), S.U_I)
    place(w, np.array([f]), S.F_D, target=5)
    send(sim, np.array([c_sender, c_sender]), np.array([u, f]))
    assert w.state[u] == S.C and w.state[f] == S.C and w.target[f] == 2
    place(w, np.array([c_same]), S.C, target=2)
    place(w, np.array([c_other]), S.C, target=7)
    send(sim, np.array([i_sender, i_sender]), np.array([c_same, c_other]))
    assert w.state[c_same] == S.I and w.state[c_other] == S.C


def test_m3_never_recruits_inhibits_or_commits_on_its_own():
    sim = make_sim("M3")
    w = sim.world
    senders, u, other, receiver = (
        agents_of(w, 0, 40),
        agents_of(w, 0, 1, 50),
        agents_of(w, 0, 1, 51),
        agents_of(w, 0, 1, 52),
    )
    place(w, senders, S.F_I, target=6, estimate=1.0)
    place(w, u, S.U_I)
    place(w, other, S.F_I, target=9)
    place(w, receiver, S.F_I, target=6)
    for i in range(3 * sim.params.quorum_k):
        send(sim, senders[[i % 40, i % 40, i % 40]], np.r_[u, other, receiver], draw=0.0)
    assert w.state[u[0]] == S.U_I and w.state[other[0]] == S.F_I and w.state[receiver[0]] == S.F_I


def test_m3_without_an_operator_makes_no_commitment_in_ten_minutes():
    sim = make_sim("M3")
    sim.step(600)
    assert not np.any(np.isin(sim.world.state, (S.C, S.I, S.X, S.D)))
    assert sim.decisions == []
    assert sim.view()["targets"], "agents still explore and report targets"


def test_m2_frequency_modulation_scales_the_send_rate_with_distance():
    # M_i = d/d_min as spec §5 writes it (the guard reading: no cap at d_max;
    # the clamp is checked in test_readings.py).
    sim = make_sim("M2", n_agents=400, m2_beyond_dmax="guard")
    w = sim.world
    far = int(np.argmax(np.where(w.active, w.hub_distance[0], 0)))
    senders = agents_of(w, 0, 100)
    place(w, senders, S.F_I, target=far)
    # Everyone else stays in the hub as U_I receivers, close enough to hear.
    expected = frequency_modulation(w.hub_distance[0, far], sim.params)
    assert expected == pytest.approx(w.hub_distance[0, far] / 150.0)
    counts = []
    for _ in range(200):
        inbox = compose(w, sim.params, "M2")
        counts.append(np.isin(inbox.sender, senders).sum())
    per_sender = np.mean(counts) / senders.size
    # Neighbour search can fail rarely; the Poisson mean is M_i · r_msg · dt.
    rate = sim.params.message_rate * sim.params.dt_s
    assert per_sender == pytest.approx(expected * rate, rel=0.08)
    m1 = make_sim("M1", n_agents=400)
    place(m1.world, agents_of(m1.world, 0, 100), S.F_I, target=far)  # same layout: same seed
    m1_senders = agents_of(m1.world, 0, 100)
    m1_counts = [
        np.isin(compose(m1.world, m1.params, "M1").sender, m1_senders).sum() for _ in range(200)
    ]
    assert np.mean(m1_counts) / 100 == pytest.approx(rate, rel=0.08)
