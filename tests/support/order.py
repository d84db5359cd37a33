"""The order in which `make test` hands modules to its workers: the heavy ones apart.

`--dist loadfile` gives a worker the next module when it is nearly done with
its own. xdist reorders modules by their number of tests unless told not to
(`--no-loadscope-reorder`, in pyproject's addopts): under that order the soak
(one test, 3 min) was among the last modules handed out and ran on while the
other workers had nothing left.

Longest first alone is no better on this machine's two cores: the three
longest modules (the soak, the hour-long snapshot trial, the failover
processes) each run servers of their own, and started together they slowed
one another by a third (3,939 test-seconds against 2,970, 22.5 min against
18.4) and a failover test timed out. So the heavy modules go one at a time,
longest first, each followed by enough light modules (longest first too) to
keep the other workers busy while it runs; the light modules left go last.

A module's length is its tests' seconds in the recorded full run
(tests/durations.csv). A module not recorded there (a new one) is guessed from
its marks, so a new slow module is not left to the end.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

#: Guessed seconds a test takes when its module is not recorded: slow, browser, other.
GUESSED_SECONDS = {"slow": 60.0, "browser": 10.0, "other": 0.5}
#: A module this long (recorded or guessed) is heavy: it runs while no other heavy one does.
HEAVY_S = 100.0


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


def heavy_apart(
    tests: Iterable[tuple[str, str]], recorded: Mapping[str, float], workers: int
) -> list[str]:
    """The modules in the order to hand them out to `workers` workers.

    Each heavy module (longest first) is followed by light modules (longest
    first) adding up to what the other workers do while it runs, its seconds
    times workers - 1; the light ones left follow the last heavy one. Ties keep
    the order the modules were collected in.
    """
    tests = list(tests)
    seconds = module_seconds(tests, recorded)
    collected = list(dict.fromkeys(module_of(nodeid) for nodeid, _ in tests))
    by_length = sorted(collected, key=lambda module: -seconds[module])
    heavy = [module for module in by_length if seconds[module] >= HEAVY_S]
    light = [module for module in by_length if seconds[module] < HEAVY_S]
    order: list[str] = []
    for module in heavy:
        order.append(module)
        room = seconds[module] * max(workers - 1, 0)
        while light and room > 0:
            room -= seconds[light[0]]
            order.append(light.pop(0))
    return order + light


def workers_of(config: Any) -> int:
    """How many workers run the suite: in an xdist worker, the count xdist tells it (xdist
    clears `-n` in its workers, and each worker collects and orders the suite itself); in
    the controller, `-n N`; one without xdist."""
    told = getattr(config, "workerinput", {}).get("workercount")
    if told is not None:
        return int(told)
    workers = getattr(config.option, "numprocesses", None)
    return workers if isinstance(workers, int) and workers > 0 else 1
