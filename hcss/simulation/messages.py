"""System Messages: the words for what the simulation emits and for each command's outcome.

The engine emits typed events (kind, collective, target, section) and typed
request outcomes; this module is the one place that words them, for every
reader that shows them: the participant's live page and its rebuild after a
restart, the console's replay and `hcss simulate`. Collectives are named by
`collective_name`, the one naming the page receives as well.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hcss.simulation.params import ROMAN


def collective_name(index: int) -> str:
    """``I`` for collective 0: how every page, message and record names a collective."""
    return ROMAN[index]


def collective_names(n_collectives: int | None = None) -> list[str]:
    """The names of collectives 0 .. n-1 (every name there is, by default), for a page to use."""
    return list(ROMAN if n_collectives is None else ROMAN[:n_collectives])


#: The words of each kind of event the engine emits, filled by `event_text`.
EVENT_WORDS = {
    "discovery": "Target {target} discovered.",
    "commitment": "Collective {collective} committed to target {target}.",
    "move": "Collective {collective} is moving to target {target}.",
    "arrival": "Collective {collective} arrived at target {target}.",
    "timeout": "Collective {collective} timed out.",
    "section_end": "Section {section} complete.",
    "finished": "All decisions complete.",
}


def event_text(event: Mapping[str, Any]) -> str:
    """The System Message of one of the engine's events (`Simulation.drain_events`)."""
    words = EVENT_WORDS.get(event["kind"])
    if words is None:
        raise ValueError(f"no System Message for an event of kind {event['kind']!r}")
    collective = event.get("collective")
    return words.format(
        target=event.get("target"),
        collective=None if collective is None else collective_name(int(collective)),
        section=event.get("section"),
    )


def request_subject(
    kind: str, collective: str | None, target: int | None, cancel_request_id: int | None
) -> str:
    """What a command was about, with its collective already named (None: unknown)."""
    if kind == "cancel":
        return f"cancel of assignment {cancel_request_id}"
    return f"{kind} by collective {collective or '?'} on target {target}"


def accepted_text(subject: str, kind: str, request_id: int | None) -> str:
    """The System Message of an accepted command (accepted requests are shown as well as refusals)."""
    if kind == "cancel":
        return f"Request accepted ({subject})"
    return f"Request {request_id} accepted ({subject})"


def refusal_text(subject: str, reason: str) -> str:
    """The System Message of a refused command: its subject and the simulation's reason."""
    return f"Request refused ({subject}): {reason}"
