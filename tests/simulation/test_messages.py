"""System Messages: the engine emits typed events; `hcss.simulation.messages` words them."""

from __future__ import annotations

import pytest

from hcss.simulation import Scenario, Simulation
from hcss.simulation.messages import (
    accepted_text,
    collective_names,
    event_text,
    refusal_text,
    request_subject,
)


def _run_events(steps: int = 1200) -> list[dict]:
    sim = Simulation(Scenario.generate(2, first_section="easy"), "M1")
    events: list[dict] = []
    for _ in range(steps):
        sim.step(1)
        events += sim.drain_events()
        if sim.finished:
            break
    return events


def test_the_engine_emits_typed_events_and_every_one_has_its_words() -> None:
    events = _run_events()
    kinds = {e["kind"] for e in events}
    assert {"discovery", "commitment", "move", "arrival"} <= kinds, kinds
    for event in events:
        assert "text" not in event, event  # the model does not word its events
        assert event_text(event)


@pytest.mark.parametrize(
    ("event", "text"),
    [
        ({"kind": "discovery", "collective": None, "target": 9}, "Target 9 discovered."),
        (
            {"kind": "commitment", "collective": 1, "target": 3},
            "Collective II committed to target 3.",
        ),
        ({"kind": "move", "collective": 3, "target": 12}, "Collective IV is moving to target 12."),
        ({"kind": "arrival", "collective": 0, "target": 5}, "Collective I arrived at target 5."),
        ({"kind": "timeout", "collective": 2, "target": None}, "Collective III timed out."),
        (
            {"kind": "section_end", "collective": None, "target": None, "section": 1},
            "Section 1 complete.",
        ),
        ({"kind": "finished", "collective": None, "target": None}, "All decisions complete."),
    ],
)
def test_each_event_kind_is_worded_as_the_spec_shows_it(event: dict, text: str) -> None:
    assert event_text(event) == text


def test_an_event_kind_with_no_words_is_refused() -> None:
    with pytest.raises(ValueError, match="no System Message"):
        event_text({"kind": "landslide", "collective": None, "target": None})


def test_a_command_is_worded_with_its_subject() -> None:
    subject = request_subject("investigate", "II", 4, None)
    assert accepted_text(subject, "investigate", 7) == (
        "Request 7 accepted (investigate by collective II on target 4)"
    )
    cancel = request_subject("cancel", None, None, 7)
    assert accepted_text(cancel, "cancel", None) == "Request accepted (cancel of assignment 7)"
    assert refusal_text(subject, "The trial is over.") == (
        "Request refused (investigate by collective II on target 4): The trial is over."
    )


def test_the_names_a_page_receives_are_the_messages_names() -> None:
    assert collective_names(4) == ["I", "II", "III", "IV"]
    assert len(collective_names()) == 64
