"""The order in which `make test` hands modules to its workers: longest first.

`--dist loadfile` gives a worker the next module when it is nearly done with
its own. Handed out longest first (the longest-processing-time rule), what is
left at the end is short and the workers finish together. xdist reorders
modules by their number of tests unless told not to (`--no-loadscope-reorder`,
in pyproject's addopts): under that order the soak (one test, 3 min) was among
the last modules handed out and ran alone at the end.

A module's length is its tests' seconds in the recorded full run
(tests/durations.csv). A module not recorded there (a new one) is guessed from
its marks, so a new slow module still starts early.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

#: Guessed seconds a test takes when its module is not recorded: slow, browser, other.
GUESSED_SECONDS = {"slow": 60.0, "browser": 10.0, "other": 0.5}


def module_of(nodeid: str) -> str:
    """The module part of a test id: what `--dist loadfile` hands out as one unit."""
    return nodeid.split("::")[0]


def module_seconds(
    tests: Iterable[tuple[str, str]], recorded: Mapping[str, float]
) -> dict[str, float]:
    """Each module's expected seconds, from (test id, kind) pairs (kind a GUESSED_SECONDS key).

    A module with any test in the record counts its recorded tests only (a test
    added since is short beside them, or the next refresh of the record says so);
    a module with none is guessed from its tests' kinds.
    """
    recorded_sum: dict[str, float] = {}
    guessed_sum: dict[str, float] = {}
    for nodeid, kind in tests:
        module = module_of(nodeid)
        if nodeid in recorded:
            recorded_sum[module] = recorded_sum.get(module, 0.0) + recorded[nodeid]
        guessed_sum[module] = guessed_sum.get(module, 0.0) + GUESSED_SECONDS[kind]
    return {module: recorded_sum.get(module, guessed) for module, guessed in guessed_sum.items()}


def longest_first(tests: Iterable[tuple[str, str]], recorded: Mapping[str, float]) -> list[str]:
    """The modules, longest expected first; ties keep the order they were collected in."""
    tests = list(tests)
    seconds = module_seconds(tests, recorded)
    collected = list(dict.fromkeys(module_of(nodeid) for nodeid, _ in tests))
    return sorted(collected, key=lambda module: -seconds[module])
