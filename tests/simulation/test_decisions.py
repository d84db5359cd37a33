"""Difficulty, correctness, reservation, relocation and sections (spec §2, §7)."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.simulation import Scenario, Simulation
from hcss.simulation import states as S
from hcss.simulation.decisions import best_available, difficulty
from tests.support.worlds import agents_of, make_sim, place, visible_target


def _layout(sim, collective, targets):
    """Replace the active targets by hand: [(distance from the hub, value)] along the x axis."""
    w = sim.world
    w.active[:] = False
    hub = w.hub[collective]
    for i, (distance, value) in enumerate(targets):
        w.active[i] = True
        w.target_pos[i] = hub + [distance, 0.0]
        w.target_value[i] = value
    w.refresh_hub_distance()


@pytest.mark.parametrize(
    ("targets", "expected"),
    [
        ([(150, 1.0), (250, 0.9), (350, 0.8)], "easy"),
        ([(350, 1.0), (150, 0.9), (250, 0.8)], "difficult"),
        ([(250, 1.0), (250, 0.9)], "easy"),  # equally near is not strictly nearer
        ([(250, 1.0), (600, 0.9), (150, 1.0)], "easy"),  # a tie on value goes to the nearer
        ([(350, 1.0), (600, 0.7)], "easy"),  # out of range does not count
    ],
)
def test_difficulty_compares_the_best_target_with_nearer_lower_valued_ones(targets, expected):
    sim = make_sim("M1")
    _layout(sim, 0, targets)
    assert difficulty(sim.world, 0, sim.params) == expected


def test_best_available_ignores_targets_reserved_by_another_collective():
    sim = make_sim("M1")
    _layout(sim, 0, [(150, 0.8), (300, 1.0)])
    assert best_available(sim.world, 0, sim.params) == 1
    sim.world.reserved_by[1] = 2
    assert best_available(sim.world, 0, sim.params) == 0
    assert sim.best_target(0) == 1  # ids are 1-based


def test_first_decisions_of_a_section_follow_the_scenario_kind():
    for kind in ("easy", "difficult"):
        sim = Simulation(Scenario.generate(5, first_section=kind), "M1")
        # Each collective's own four targets make its first decision of this kind,
        # unless a neighbour's targets reach into its range and change the picture.
        assert {d.difficulty for d in sim.open} <= {"easy", "difficult"}
        own_only = [difficulty_of_own(sim, c) for c in range(4)]
        assert own_only == [kind] * 4


def difficulty_of_own(sim, c):
    w = sim.world
    keep = w.active.copy()
    own = np.array([t.around == c for t in sim.scenario.sections[0].targets] + [False] * 16)
    w.active[:] = keep & own
    result = difficulty(w, c, sim.params)
    w.active[:] = keep
    return result


def test_moving_reserves_the_target_and_other_collectives_drop_it():
    sim = make_sim("M1")
    w = sim.world
    t = visible_target(sim, 0)
    rival_fans = agents_of(w, 1, 30)
    place(w, rival_fans[:20], S.F_I, target=t)
    place(w, rival_fans[20:], S.C, target=t)
    place(w, agents_of(w, 0, 5), S.X, target=t, leg=S.TO_TARGET)
    sim.step()
    assert w.reserved_by[t] == 0 and w.executing[0] == t
    # In the hub, favouring and committed agents return to deliberation at once ...
    in_hub = rival_fans[w.leg[rival_fans] == S.AT_HUB]
    assert in_hub.size > 0 and np.all(w.state[in_hub] == S.U_I)
    assert not np.any(np.isin(w.state[rival_fans], (S.C, S.I)))
    refused = sim.investigate(1, t + 1)
    assert not refused.accepted and "taken by collective I" in refused.reason
    assert "move" in [e["kind"] for e in sim.drain_events()]
    # ... and those away reassessing it drop it when they come back.
    sim.step(90)
    rivals = w.collective == 1
    assert not np.any(rivals & (w.target == t))


def test_a_decision_ends_with_relocation_and_a_correct_record():
    sim = make_sim("M1")
    w = sim.world
    best = best_available(w, 0, sim.params)
    movers = agents_of(w, 0, 200)
    place(w, movers, S.X, target=best, leg=S.TO_TARGET)
    for _ in range(200):
        sim.step()
        if sim.decisions:
            break
    record = sim.decisions[0]
    assert record.chosen_target == best + 1 and record.correct and not record.timed_out
    assert record.chosen_value == record.best_value == w.target_value[best]
    assert np.allclose(w.hub[0], w.target_pos[best]) and not w.active[best]
    assert sim.open[0].index == 2 and sim.open[0].start_s == record.end_s
    row = record.as_row(trial_id="t")
    assert row["collective"] == "I" and row["decision_time_s"] == record.end_s - record.start_s


def test_choosing_a_worse_target_is_recorded_as_incorrect():
    sim = make_sim("M1")
    w = sim.world
    best = best_available(w, 0, sim.params)
    in_range = np.flatnonzero(
        w.active & (w.hub_distance[0] <= 500) & (w.target_value < w.target_value[best])
    )
    worse = int(in_range[0])
    place(w, agents_of(w, 0, 200), S.X, target=worse, leg=S.TO_TARGET)
    sim.run_until_finished(max_steps=200)
    record = sim.decisions[0]
    assert record.chosen_target == worse + 1 and not record.correct
    assert record.best_value == pytest.approx(w.target_value[best])


def test_a_full_trial_has_two_sections_of_six_decisions():
    sim = Simulation(Scenario.generate(8, first_section="difficult"), "M1")
    sim.run_until_finished(max_steps=4 * 3600)
    assert sim.finished
    sections = [d.section for d in sim.decisions]
    assert sections.count(1) == 6 and sections.count(2) == 6
    kinds = [e["kind"] for e in sim.drain_events()]
    assert kinds.count("section_end") == 2 and kinds[-1] == "finished"
    for d in sim.decisions:
        assert d.correct == (d.chosen_value is not None and d.chosen_value >= d.best_value)
        assert d.section_kind == ("difficult" if d.section == 1 else "easy")
    # The second section starts from the start hubs with its own targets.
    first_of_second = min(d.start_s for d in sim.decisions if d.section == 2)
    assert first_of_second == max(d.end_s for d in sim.decisions if d.section == 1)


def test_a_decision_that_runs_past_the_cap_times_out_and_counts():
    sim = make_sim("M3", decision_timeout_s=120.0)  # M3 never decides without an operator
    sim.step(121)
    assert len(sim.decisions) == 4
    assert all(d.timed_out and not d.correct and d.chosen_target is None for d in sim.decisions)
    assert sim.world.decisions_in_section == 4


def test_arrivals_in_the_step_that_ends_a_section_are_discarded():
    """Two collectives reach their arrival quorum in the same step as the section's 6th decision."""
    sim = make_sim("M1", decisions_per_section=1)
    w = sim.world
    for c in (0, 1):
        t = best_available(w, c, sim.params)
        place(w, agents_of(w, c, 200), S.D, target=t)
        w.executing[c] = t
        w.reserved_by[t] = c
        w.streak[agents_of(w, c, 200)] = sim.params.quorum_k
    sim.step()
    assert len(sim.decisions) == 1 and sim.decisions[0].chosen_target is not None
    assert w.section == 1 and np.allclose(w.hub, w.start_hub)
    assert all(d.start_s == sim.time for d in sim.open)
