"""Snapshots stamped with formats this version does not write, planted by the tests of
what a rebuild does with them (a newer version's, during a rolling upgrade; a retired one)."""

from __future__ import annotations

import pickle

from hcss.simulation.snapshots import PICKLE_PROTOCOL, SNAPSHOT_FORMAT

#: Where `Later` claims to live in the bytes: a module this version does not have.
ABSENT_MODULE = "hcss.simulation.later"


class Later:
    """A value of a class only a newer version has (its module is renamed in the bytes)."""


def restamped(blob: bytes, found: int, *, unknown_class: bool = False) -> bytes:
    """Today's snapshot stamped `found`, the stamp first as this version writes it.

    `unknown_class`: the state also holds an instance of a class from a module
    this version does not have, so the bytes cannot be unpickled here at all.
    """
    state = pickle.loads(blob)
    del state["version"]
    if unknown_class:
        state["later"] = Later()
    restamped = pickle.dumps({"version": found, **state}, protocol=PICKLE_PROTOCOL)
    if not unknown_class:
        return restamped
    ours = Later.__module__.encode()
    absent = ABSENT_MODULE.encode().ljust(len(ours), b"x")  # same length: the pickle stays valid
    assert restamped.count(ours) == 1
    return restamped.replace(ours, absent)


def newer(blob: bytes) -> bytes:
    """The snapshot as the next format would stamp it, with a class this version lacks."""
    return restamped(blob, SNAPSHOT_FORMAT + 1, unknown_class=True)
