"""Every public output names a target by its 1-based id (issue 10 §4).

Regression: discovery events carried the 0-based index ("target": 8 with the text
"Target 9 discovered."), and the platform stored that index in SimEvent.target.
"""

from __future__ import annotations

import re

from hcss.simulation import Scenario, Simulation
from hcss.simulation.ids import target_id, target_index
from hcss.simulation.messages import event_text


def _events_until_discoveries(seed: int = 31, steps: int = 400) -> tuple[Simulation, list[dict]]:
    sim = Simulation(Scenario.generate(seed), "M1")
    events: list[dict] = []
    for _ in range(steps):
        sim.step(1)
        events += sim.drain_events()
    return sim, events


def test_every_event_names_its_target_by_the_id_in_its_text():
    _, events = _events_until_discoveries()
    assert any(e["kind"] == "discovery" for e in events), "the run must discover a target"
    for event in events:
        if event["target"] is None:
            continue
        named = re.search(r"[Tt]arget (\d+)", event_text(event))
        assert named is not None, event
        assert event["target"] == int(named.group(1)), event


def test_a_discovered_target_is_shown_in_the_view_of_the_same_step():
    sim = Simulation(Scenario.generate(31), "M1")
    checked = 0
    for _ in range(200):
        sim.step(1)
        shown = {t["id"] for t in sim.view()["targets"]}
        for event in sim.drain_events():
            if event["kind"] == "discovery":
                assert event["target"] in shown, (event, shown)
                checked += 1
    assert checked > 0


def test_the_conversion_is_its_own_inverse_and_rejects_nothing_valid():
    for index in range(0, 50):
        assert target_index(target_id(index)) == index
    assert target_id(0) == 1
