"""Names shown for stored numbers, and the error for a stored row that names nothing.

A collective is stored as its 0-based index and shown as a Roman numeral. A
row written before the command checks existed, or by hand, can hold an index
no trial has; readers (the export, a rebuild's System Messages) report such a
row and skip it instead of failing for everyone.
"""

from __future__ import annotations

from hcss.simulation.params import ROMAN


class Uninterpretable(ValueError):
    """A stored value that cannot be turned into what the reader shows."""


def collective_name(index: int | None) -> str | None:
    """``I`` for collective 0; None for no collective; Uninterpretable for an impossible one."""
    if index is None:
        return None
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(ROMAN):
        raise Uninterpretable(f"collective {index!r} is not a collective any trial has")
    return ROMAN[index]
