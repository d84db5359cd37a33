"""The suite's order: modules with slow tests first, so the two workers finish together.

`make test` hands whole modules to its workers (`--dist loadfile`), each worker
taking the next module when it is done with its own. Handed out in file
order, a slow module near the end (the installed wheel's, the simulation's
sweeps) ran on one worker while the other had nothing left to do; handed out
longest first, what is left at the end is short. The order inside a module,
and so its module-scoped fixtures, stay as they are.
"""

from __future__ import annotations

import pytest


def _rank(item: pytest.Item) -> int:
    """0 for a test marked slow, 1 for a browser test, 2 for the rest."""
    if item.get_closest_marker("slow"):
        return 0
    if item.get_closest_marker("browser"):
        return 1
    return 2


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank: dict[str, int] = {}
    for item in items:
        module = item.nodeid.split("::")[0]
        rank[module] = min(rank.get(module, 2), _rank(item))
    items.sort(key=lambda item: rank[item.nodeid.split("::")[0]])  # stable: file order within
