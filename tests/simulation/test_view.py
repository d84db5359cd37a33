"""What the interface is shown (spec §9)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hcss.simulation import Display, Scenario, Simulation
from hcss.simulation.messages import event_text


@pytest.fixture(scope="module")
def running() -> Simulation:
    sim = Simulation(Scenario.generate(31), "M1")
    sim.step(240)
    return sim


def test_view_is_json_and_fractions_are_hub_estimates(running):
    view = json.loads(json.dumps(running.view()))
    assert [c["name"] for c in view["collectives"]] == ["I", "II", "III", "IV"]
    for c in view["collectives"]:
        assert sum(c["fractions"].values()) == pytest.approx(1.0)
        assert sum(c["counts"].values()) == 200


def test_only_reported_targets_are_visible_with_mean_reported_value(running):
    w = running.world
    view = running.view()
    ids = {t["id"] for t in view["targets"]}
    assert ids == {int(t) + 1 for t in np.flatnonzero(w.active & (w.report_count >= 1))}
    for t in view["targets"]:
        i = t["id"] - 1
        assert t["value"] == pytest.approx(w.report_sum[i] / w.report_count[i])
        assert t["drawn"] == (t["reports"] >= 2)
        assert t["max_support"] == max(t["support"])
        assert t["outline_support"] == (t["max_support"] > 0.30)


def test_events_are_drained_once(running):
    first = running.drain_events()
    assert running.drain_events() == []
    assert all({"time", "kind", "collective", "target"} <= set(e) for e in first)
    assert all(event_text(e) for e in first)  # typed events; the wording is the messages module's


def test_a_move_under_way_reports_target_and_progress():
    sim = Simulation(Scenario.generate(2, first_section="easy"), "M1")
    while not sim.finished and all(c["move"] is None for c in sim.view()["collectives"]):
        sim.step()
    moving = next(c for c in sim.view()["collectives"] if c["move"])
    assert 0.0 <= moving["move"]["progress"] <= 1.0 and moving["executing"]
    target = next(t for t in sim.view()["targets"] if t["id"] == moving["move"]["target"])
    assert target["outline_executing"]


def test_the_view_carries_no_truth_and_the_truth_has_its_own_accessor(running):
    """The interface never gets a true value; `truth()` is the one place it is read."""
    view = running.view()
    text = json.dumps(view)
    assert "true_value" not in text and "best" not in text
    assert not any(set(t) - SHOWN_TARGET_KEYS for t in view["targets"])
    truth = running.truth()
    assert np.array_equal(truth.values, running.world.target_value)
    assert truth.value_of(1) == running.world.target_value[0]  # ids are 1-based
    assert [truth.best_for(c) for c in range(4)] == [running.best_target(c) for c in range(4)]


SHOWN_TARGET_KEYS = {
    "id",
    "position",
    "value",
    "reports",
    "drawn",
    "support",
    "max_support",
    "outline_support",
    "outline_executing",
    "in_range_of",
}


def test_the_display_is_read_only_arrays_and_the_view_is_its_json(running):
    display = running.display()
    assert display.to_json() == running.view()
    assert Display.from_json(running.view()).to_json() == running.view()
    assert display.n_agents == 200 and display.support.shape == (4, display.target_ids.size)
    with pytest.raises(ValueError):
        display.support[0, 0] = 1.0  # a display is a reading, not a handle on the state
    for v, target in enumerate(running.view()["targets"]):
        assert display.target_ids[v] == target["id"]
        assert display.support[:, v].tolist() == target["support"]
        assert np.flatnonzero(display.in_range[:, v]).tolist() == target["in_range_of"]
