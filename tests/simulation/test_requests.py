"""Operator requests: validity, refusals that change nothing, and their effects (spec §8)."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.simulation import OperatorCommand, StatusChange
from hcss.simulation import states as S
from tests.support.worlds import agents_of, make_sim, place, visible_target


def _uncommitted_in_hub(sim, c=0):
    w = sim.world
    return np.flatnonzero((w.collective == c) & (w.state == S.U_I) & (w.leg == S.AT_HUB))


def test_investigate_sends_exactly_ten_uncommitted_agents_and_completes():
    sim = make_sim("M1")
    t = visible_target(sim)
    before = _uncommitted_in_hub(sim)
    assert before.size >= 10  # at the section start everyone is in the hub
    outcome = sim.investigate(0, t + 1)
    assert outcome.accepted and outcome.request_id == 1 and outcome.reason == ""
    w = sim.world
    sent = before[(w.state[before] == S.F_L)]
    assert sent.size == 10 and np.all(w.target[sent] == t) and np.all(w.leg[sent] == S.TO_TARGET)
    assert sim.view()["requests"][0] == {
        "id": 1,
        "kind": "investigate",
        "collective": 0,
        "target": t + 1,
        "status": "completed",
        "acknowledged": 10,
    }


def test_investigate_stays_in_progress_until_ten_agents_have_acknowledged():
    sim = make_sim("M1")
    t = visible_target(sim)
    w = sim.world
    hub = _uncommitted_in_hub(sim)
    place(w, hub[4:], S.U_L, leg=S.EXPLORING)  # only 4 left in the hub
    sim.investigate(0, t + 1)
    assert sim.view()["requests"][0]["status"] == "in_progress"
    assert sim.view()["requests"][0]["acknowledged"] == 4
    for _ in range(120):
        sim.step()
        if sim.view()["requests"][0]["status"] == "completed":
            break
    assert sim.view()["requests"][0]["acknowledged"] == 10
    assert sim.view()["requests"][0]["status"] == "completed"


def test_out_of_range_investigate_is_refused_and_changes_nothing():
    sim = make_sim("M1")
    w = sim.world
    far = int(np.argmax(np.where(w.active, w.hub_distance[0], -1)))
    assert w.hub_distance[0, far] > sim.params.exploration_range_m
    w.report_count[far] = 2
    before = sim.state_digest()
    outcome = sim.investigate(0, far + 1)
    assert not outcome.accepted and "out of range" in outcome.reason and outcome.request_id is None
    assert sim.state_digest() == before and sim.requests == []


@pytest.mark.parametrize(
    ("command", "fragment"),
    [
        (OperatorCommand("investigate", 9, 1), "no collective"),
        (OperatorCommand("investigate", 0, 999), "no target"),
        (OperatorCommand("investigate", 0, "x"), "needs a collective and a target"),
        (OperatorCommand("investigate"), "needs a collective and a target"),
        (OperatorCommand("launch", 0, 1), "Unknown request type"),
        (OperatorCommand.cancel(42), "no active abandon"),
        ({"kind": "investigate", "collective": 0, "target": 1}, "must be an OperatorCommand"),
        (None, "must be an OperatorCommand"),
    ],
)
def test_malformed_requests_are_refused_with_a_reason(command, fragment):
    sim = make_sim("M1")
    before = sim.state_digest()
    outcome = sim.apply(command)
    assert not outcome.accepted and fragment in outcome.reason
    assert sim.state_digest() == before


def test_undiscovered_targets_cannot_be_requested():
    sim = make_sim("M1")
    outcome = sim.investigate(0, 1)
    assert not outcome.accepted and "not been discovered" in outcome.reason


def test_abandon_needs_two_supporters_then_drops_them_in_the_hub_until_cancelled():
    sim = make_sim("M1")
    w = sim.world
    t = visible_target(sim)
    fans = agents_of(w, 0, 5)
    place(w, fans[:1], S.F_I, target=t)
    refused = sim.abandon(0, t + 1)
    assert not refused.accepted and "abandon needs at least 2" in refused.reason
    # In the participant's words (the introduction's "robots"), singular for one.
    assert refused.reason.startswith(f"Only 1 robot of collective I favours target {t + 1};")
    place(w, fans, S.F_I, target=t)
    accepted = sim.abandon(0, t + 1)
    assert accepted.accepted
    assert np.all(w.state[fans] == S.U_I)
    assert sim.view()["requests"][0]["status"] == "in_progress"
    assert not sim.decide(0, t + 1).accepted
    cancelled = sim.cancel_abandon(accepted.request_id)
    assert cancelled.accepted and not w.abandon_order[0, t] and sim.view()["requests"] == []
    assert not sim.cancel_abandon(accepted.request_id).accepted


def test_only_an_abandon_can_be_cancelled():
    sim = make_sim("M1")
    t = visible_target(sim)
    outcome = sim.investigate(0, t + 1)
    assert not sim.apply(OperatorCommand.cancel(outcome.request_id)).accepted


def _favoured_by(n: int):
    """A simulation in which n agents of collective I favour a visible target: (sim, its index)."""
    sim = make_sim("M1")
    t = visible_target(sim)
    place(sim.world, agents_of(sim.world, 0, n), S.F_I, target=t)
    return sim, t


@pytest.mark.parametrize(("fans", "intervention"), [(20, True), (19, False)])
def test_an_abandon_with_ten_percent_support_counts_as_an_intervention(fans, intervention):
    sim, t = _favoured_by(fans)  # 20 of 200 is 10%
    outcome = sim.abandon(0, t + 1)
    assert outcome.accepted and outcome.intervention is intervention
    assert outcome.support == pytest.approx(fans / 200)
    assert sim.open[0].requests["interventions"] == int(intervention)


def test_the_outcome_carries_the_context_the_command_was_applied_in():
    sim, t = _favoured_by(30)
    w = sim.world
    shown = sim.view()["targets"]
    support = next(x["support"][0] for x in shown if x["id"] == t + 1)
    refused = sim.decide(0, t + 1)  # 15% < 30%: refused, still with its context
    assert not refused.accepted
    assert (refused.collective, refused.target) == (0, t + 1)
    assert refused.support == support == 0.15
    assert refused.decision_index == sim.open[0].index == 1
    assert not refused.intervention
    hidden = next(i for i in range(w.active.size) if w.active[i] and w.report_count[i] == 0)
    undiscovered = sim.investigate(1, hidden + 1)
    assert undiscovered.support is None and undiscovered.decision_index == 1
    nobody = sim.investigate(9, t + 1)
    assert nobody.support is None and nobody.decision_index is None


def test_the_decision_index_is_the_decision_under_way_after_a_discarded_one():
    """A section that completes discards the decisions still under way; their index is spent.

    So "1 + decisions recorded" (the platform's old count) is not the decision under way.
    """
    for seed in range(40):  # a scenario where collective I had a decision discarded
        sim = make_sim("M1", seed=seed)
        while sim.world.section == 0:
            sim.step()
        recorded = sum(1 for d in sim.decisions if d.collective == 0)
        if sim.open[0].index > recorded + 1:
            break
    else:
        pytest.fail("no seed in 0..39 discards a decision of collective I in the first section")
    outcome = sim.investigate(0, 1)
    assert (
        outcome.decision_index == sim.open[0].index != recorded + 1
    )  # the index its record will carry


def test_a_cancel_names_the_abandon_it_lifts():
    sim, t = _favoured_by(5)
    abandon = sim.abandon(0, t + 1)
    cancel = sim.cancel_abandon(abandon.request_id)
    assert cancel.accepted and cancel.request_id == abandon.request_id
    assert (cancel.collective, cancel.target) == (0, t + 1)
    assert cancel.decision_index == 1 and not cancel.intervention


def _statuses(sim):
    return [(c.request_id, c.status) for c in sim.drain_status_changes()]


def test_each_request_status_is_queued_once_with_its_step():
    sim = make_sim("M1")
    w = sim.world
    t = visible_target(sim)
    hub = _uncommitted_in_hub(sim)
    place(w, hub[4:], S.U_L, leg=S.EXPLORING)  # only 4 left in the hub: stays in progress
    first = sim.investigate(0, t + 1)
    assert sim.drain_status_changes() == [StatusChange(first.request_id, "in_progress", 0, 0.0)]
    assert sim.drain_status_changes() == []
    for _ in range(120):
        sim.step()
        changes = sim.drain_status_changes()
        if changes:
            break
    assert changes == [StatusChange(first.request_id, "completed", sim.step_count, sim.time)]
    assert sim.view()["requests"][0]["status"] == "completed"
    sim.step(5)
    assert sim.drain_status_changes() == []  # completed once, not at every step


def test_a_cancelled_abandon_and_a_finished_decision_remove_their_requests():
    sim, t = _favoured_by(5)
    abandon = sim.abandon(0, t + 1)
    sim.cancel_abandon(abandon.request_id)
    assert _statuses(sim) == [(abandon.request_id, "in_progress"), (abandon.request_id, "removed")]
    investigate = sim.investigate(0, t + 1)  # everyone is in the hub: completed at once
    assert _statuses(sim) == [
        (investigate.request_id, "in_progress"),
        (investigate.request_id, "completed"),
    ]
    sim._reset_collective(0)  # what the end of collective I's decision does
    assert _statuses(sim) == [(investigate.request_id, "removed")]
    assert sim.view()["requests"] == []


def test_decide_needs_thirty_percent_support_and_commits_two_supporters():
    sim = make_sim("M1")
    w = sim.world
    t = visible_target(sim)
    fans = agents_of(w, 0, 60)
    place(w, fans[:59], S.F_I, target=t)
    refused = sim.decide(0, t + 1)
    assert not refused.accepted and "decide needs at least 30%" in refused.reason
    # 59 of 200 is 29.5%: a refusal that says "Only 30%" contradicts its own rule
    assert refused.reason.startswith(
        f"Only 59 robots (29.5%) of collective I favour target {t + 1};"
    )
    place(w, fans, S.F_I, target=t)
    assert sim.decide(0, t + 1).accepted
    committed = np.flatnonzero((w.collective == 0) & (w.state == S.C))
    assert committed.size == 2 and set(committed) <= set(fans) and np.all(w.target[committed] == t)


def test_every_request_is_refused_while_the_collective_is_executing():
    sim = make_sim("M1")
    w = sim.world
    t = visible_target(sim)
    place(w, agents_of(w, 0, 80), S.F_I, target=t)
    place(w, agents_of(w, 0, 1, start=100), S.I, target=t)
    for kind in ("investigate", "abandon", "decide"):
        outcome = sim.apply(OperatorCommand(kind, 0, t + 1))
        assert not outcome.accepted and "executing" in outcome.reason
