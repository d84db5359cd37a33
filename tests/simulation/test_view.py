"""What the interface is shown (spec §9)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from hcss.simulation import Scenario, Simulation


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
    assert all({"time", "kind", "collective", "target", "text"} <= set(e) for e in first)


def test_a_move_under_way_reports_target_and_progress():
    sim = Simulation(Scenario.generate(2, first_section="easy"), "M1")
    while not sim.finished and all(c["move"] is None for c in sim.view()["collectives"]):
        sim.step()
    moving = next(c for c in sim.view()["collectives"] if c["move"])
    assert 0.0 <= moving["move"]["progress"] <= 1.0 and moving["executing"]
    target = next(t for t in sim.view()["targets"] if t["id"] == moving["move"]["target"])
    assert target["outline_executing"]
