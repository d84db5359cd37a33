"""Operator requests: validity, refusals that change nothing, and their effects (spec §8)."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.simulation import states as S

from .conftest import agents_of, make_sim, place, visible_target


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
        ({"kind": "investigate", "collective": 9, "target": 1}, "no collective"),
        ({"kind": "investigate", "collective": 0, "target": 999}, "no target"),
        (
            {"kind": "investigate", "collective": 0, "target": "x"},
            "needs a collective and a target",
        ),
        ({"kind": "launch", "collective": 0, "target": 1}, "Unknown request type"),
        ({"kind": "cancel", "request_id": 42}, "no active abandon"),
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
    assert not sim.apply({"kind": "cancel", "request_id": outcome.request_id}).accepted


def test_abandon_with_ten_percent_support_counts_as_an_intervention():
    sim = make_sim("M1")
    w = sim.world
    t = visible_target(sim)
    place(w, agents_of(w, 0, 20), S.F_I, target=t)  # 10% of 200
    sim.abandon(0, t + 1)
    assert sim.open[0].requests["interventions"] == 1


def test_decide_needs_thirty_percent_support_and_commits_two_supporters():
    sim = make_sim("M1")
    w = sim.world
    t = visible_target(sim)
    fans = agents_of(w, 0, 60)
    place(w, fans[:59], S.F_I, target=t)
    refused = sim.decide(0, t + 1)
    assert not refused.accepted and "decide needs at least 30%" in refused.reason
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
        outcome = sim.apply({"kind": kind, "collective": 0, "target": t + 1})
        assert not outcome.accepted and "executing" in outcome.reason
