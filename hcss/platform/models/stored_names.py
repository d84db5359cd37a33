"""Names shown for stored numbers, and the error for a stored row that names nothing.

A collective is stored as its 0-based index and shown as a Roman numeral. A
row written before the command checks existed, or by hand, can hold an index
no trial has; readers (the export, a rebuild's System Messages) report such a
row and skip it instead of failing for everyone. The name itself is the
model's (`hcss.simulation.messages.collective_name`); `stored_collective_name`
checks a stored index before asking it.
"""

from __future__ import annotations

from hcss.simulation.messages import collective_name, collective_names


class Uninterpretable(ValueError):
    """A stored value that cannot be turned into what the reader shows."""


def stored_collective_name(index: int | None, n_collectives: int | None = None) -> str | None:
    """``I`` for collective 0; None for no collective; Uninterpretable for an impossible one.

    `n_collectives` is the trial's own count (the simulation names up to 64, a
    study trial has 4): a row naming collective 16 of a four-collective trial is
    as uninterpretable as one naming collective 100.
    """
    if index is None:
        return None
    named = len(collective_names())
    limit = named if n_collectives is None else min(n_collectives, named)
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < limit:
        raise Uninterpretable(f"collective {index!r} is not a collective any trial has")
    return collective_name(index)
