"""The snapshot format: the bytes `Simulation.snapshot()` writes, and which of them this version reads.

A snapshot is a pickled dict of the simulation's state stamped with its
format number under ``"version"``, the first key, so that the number can be
read from the pickle's first opcodes without unpickling anything
(`snapshot_format`): a snapshot written by a newer version may name classes
this one does not have, yet it is still recognised as newer. Live trials are
rebuilt from snapshots by whichever version of the server takes them over, so
during a rolling upgrade adjacent versions read each other's (docs/operations.md,
"Rolling upgrade"):

- a format from `OLDEST_FORMAT` to `SNAPSHOT_FORMAT` is restored, each older
  one converted step by step by `CONVERTERS`;
- a newer format raises `NewerSnapshotFormat`: the platform rebuilds that
  trial from its start with the whole command log instead, which
  deterministic replay makes exact while the two versions step alike (what
  the committed fixtures of tests/simulation/snapshot_fixtures prove);
- an older one, or bytes that are no snapshot, raise `SimulationError`.

Any change to the bytes written (a field, a class's name or module, the
pickle protocol, numpy's pickled form) is a new format: raise
`SNAPSHOT_FORMAT` and, if the previous format can still be read, add its
converter.
"""

from __future__ import annotations

import pickle
import pickletools
from collections.abc import Callable
from itertools import islice
from typing import Any

from hcss.simulation.errors import SimulationError

#: The format written: 2 the compiled engine (World.stream, M2 geometry); 3 headings as unit
#: vectors. Formats 1 and 2 are not read: the steps that wrote them are gone, so neither a
#: conversion nor a replay would continue those trials as they ran.
SNAPSHOT_FORMAT = 3
#: The oldest format restored (through `CONVERTERS`).
OLDEST_FORMAT = 3
#: Format n's state (the dict without its stamp) to format n + 1's, for OLDEST_FORMAT <= n <
#: SNAPSHOT_FORMAT. None yet: format 3 is the first one read across versions.
CONVERTERS: dict[int, Callable[[dict[str, Any]], dict[str, Any]]] = {}
#: Fixed, not pickle.HIGHEST_PROTOCOL: a newer Python's highest is unreadable to an older one.
PICKLE_PROTOCOL = 5

_STAMP = "version"
_BOOKKEEPING = frozenset({"PROTO", "FRAME", "MEMOIZE", "PUT", "BINPUT", "LONG_BINPUT", "MARK"})
_INTEGERS = frozenset({"BININT", "BININT1", "BININT2", "INT", "LONG1"})


class NewerSnapshotFormat(SimulationError):
    """A snapshot written by a newer version, in a format this one does not know."""

    def __init__(self, found: int) -> None:
        super().__init__(
            f"snapshot format {found} is newer than this version reads"
            f" ({OLDEST_FORMAT} to {SNAPSHOT_FORMAT})"
        )
        self.found = found


def stamped(state: dict[str, Any]) -> bytes:
    """A state's snapshot bytes in today's format, the stamp first."""
    return pickle.dumps({_STAMP: SNAPSHOT_FORMAT, **state}, protocol=PICKLE_PROTOCOL)


def snapshot_format(blob: bytes) -> int | None:
    """The format number of a snapshot, read from its first opcodes without unpickling it.

    None when the stamp is not the first key (snapshots written before the stamp
    came first, all of format 3, and bytes that are no pickle).
    """
    try:
        significant = (op for op in pickletools.genops(blob) if op[0].name not in _BOOKKEEPING)
        first = [(op.name, arg) for op, arg, _ in islice(significant, 3)]
    except ValueError:  # not a pickle, or a truncated one
        return None
    if len(first) == 3 and first[0][0] == "EMPTY_DICT" and first[1][1] == _STAMP:
        name, number = first[2]
        if name in _INTEGERS and isinstance(number, int):
            return number
    return None


def unstamped(blob: bytes) -> dict[str, Any]:
    """The state in a snapshot, converted to today's format.

    Raises NewerSnapshotFormat for a newer format (before unpickling anything,
    when the stamp comes first), SimulationError for an older one or for bytes
    that are no snapshot. Snapshots are pickles written by this package into
    our own database; never read one from an untrusted source.
    """
    found = snapshot_format(blob)
    if found is not None and found > SNAPSHOT_FORMAT:
        raise NewerSnapshotFormat(found)
    try:
        state: dict[str, Any] = pickle.loads(blob)
    except Exception as error:  # any unpickling failure means "not a snapshot"
        raise SimulationError(f"not a simulation snapshot: {error}") from error
    found = state.pop(_STAMP, None) if isinstance(state, dict) else None
    if not isinstance(found, int) or isinstance(found, bool):
        raise SimulationError("not a simulation snapshot: it carries no format number")
    if found > SNAPSHOT_FORMAT:
        raise NewerSnapshotFormat(found)
    if found < OLDEST_FORMAT:
        raise SimulationError(
            f"snapshot format {found} is older than this version reads"
            f" ({OLDEST_FORMAT} to {SNAPSHOT_FORMAT}): the steps that wrote it are gone"
        )
    for number in range(found, SNAPSHOT_FORMAT):
        state = CONVERTERS[number](state)
    return state
