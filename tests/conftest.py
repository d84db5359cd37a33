"""The suite's order: the heavy modules apart, so the workers finish together.

`make test` hands whole modules to its workers (`--dist loadfile`), each worker
taking the next module when it is nearly done with its own; tests/support/order.py
says why and how a module's length is known. The order inside a
module, and so its module-scoped fixtures, stay as they are.
"""

from __future__ import annotations

import csv
import gc
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support import order

#: Every run writes each test's time here (setup, call and teardown summed, and each apart:
#: a slow setup is a fixture's server or schema, a slow call the test's own work), longest
#: first, so the suite's slow tests are known from a file, not from commit messages.
DURATIONS_FILE = Path(__file__).resolve().parents[1] / "test-artifacts" / "durations.csv"
#: The fast tier's own times, apart: a `make test-fast` after a full run must not overwrite
#: the full run's record, the one that refreshes the tier.
FAST_DURATIONS_FILE = DURATIONS_FILE.with_name("durations-fast.csv")
#: A full run's durations, kept in the repository: the fast tier (`make test-fast`, `--fast`)
#: leaves out every test that took longer than FAST_LIMIT_S there. A test not in the file
#: (a new one) is in the fast tier until the file is refreshed from a full run
#: (`cp test-artifacts/durations.csv tests/durations.csv`).
RECORDED_DURATIONS = Path(__file__).resolve().parent / "durations.csv"
FAST_LIMIT_S = 2.0
PHASES = ("setup", "call", "teardown")
_seconds: dict[str, float] = {}
_phases: dict[str, dict[str, float]] = {}

#: The shared fixtures, in tests/support (a test module names a fixture, never imports one,
#: and no test module imports another: tests/test_architecture.py checks it).
pytest_plugins = [
    "tests.support.browser",
    "tests.support.console",
    "tests.support.pages",
    "tests.support.study",
]
_outcome: dict[str, str] = {}


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--fast",
        action="store_true",
        help=f"the fast tier: no slow or browser test, none over {FAST_LIMIT_S:g} s in "
        "tests/durations.csv",
    )


def _recorded_seconds() -> dict[str, float]:
    if not RECORDED_DURATIONS.exists():
        return {}
    with RECORDED_DURATIONS.open(newline="") as recorded:
        return {row["test"]: float(row["seconds"]) for row in csv.DictReader(recorded)}


def _in_fast_tier(item: pytest.Item, recorded: dict[str, float]) -> bool:
    if item.get_closest_marker("slow") or item.get_closest_marker("browser"):
        return False
    return recorded.get(item.nodeid, 0.0) <= FAST_LIMIT_S


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("fast"):
        recorded = _recorded_seconds()
        deselected = [item for item in items if not _in_fast_tier(item, recorded)]
        if deselected:
            config.hook.pytest_deselected(items=deselected)
            items[:] = [item for item in items if _in_fast_tier(item, recorded)]
    position = {
        module: place
        for place, module in enumerate(
            order.heavy_apart(
                ((item.nodeid, _kind(item)) for item in items),
                _recorded_seconds(),
                order.workers_of(config),
            )
        )
    }
    items.sort(key=lambda item: position[order.module_of(item.nodeid)])  # stable: file order within


def _kind(item: pytest.Item) -> str:
    """The kind tests/support/order.py guesses a test's time by, when it is not recorded."""
    if item.get_closest_marker("slow"):
        return "slow"
    if item.get_closest_marker("browser"):
        return "browser"
    return "other"


def pytest_collection_finish(session: pytest.Session) -> None:
    """Freeze what importing and collecting made (modules, fixtures, libraries), so the
    per-module collection below scans only what the tests made: a full collection in a
    worker late in the suite took 3-4 s, over 200 modules 6 minutes of teardown."""
    gc.collect()
    gc.freeze()


@pytest.fixture(scope="module", autouse=True)
def _collect_the_module_s_garbage() -> Iterator[None]:
    """Collect garbage when a module is done, after its other fixtures are torn down.

    An object a module leaves unclosed (a psycopg connection, say) is otherwise
    collected whenever the garbage collector next runs, perhaps in another
    module's test, and pytest reports the "unraisable" warning there: a module
    whose warnings are errors (tests/analysis/test_report.py) then failed for a
    connection some PostgreSQL test on the same worker had dropped (CI, once).
    Collected here, in the module's last teardown, it is reported by the module
    that leaked it (a warning, in the summary).
    """
    yield
    gc.collect()


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Sum a test's phases; under xdist the controller receives every worker's reports."""
    _seconds[report.nodeid] = _seconds.get(report.nodeid, 0.0) + report.duration
    _phases.setdefault(report.nodeid, {})[report.when] = report.duration
    if report.when == "call" or report.outcome != "passed":
        _outcome[report.nodeid] = report.outcome


def pytest_sessionfinish(session: pytest.Session) -> None:
    if hasattr(session.config, "workerinput") or not _seconds:
        return  # an xdist worker: the controller writes the file
    written = FAST_DURATIONS_FILE if session.config.getoption("fast") else DURATIONS_FILE
    written.parent.mkdir(exist_ok=True)
    with written.open("w", newline="") as out:
        table = csv.writer(out)
        table.writerow(["seconds", "outcome", "test", *PHASES])
        for nodeid, seconds in sorted(_seconds.items(), key=lambda kv: -kv[1]):
            phases = [f"{_phases[nodeid].get(phase, 0.0):.3f}" for phase in PHASES]
            table.writerow([f"{seconds:.3f}", _outcome.get(nodeid, "passed"), nodeid, *phases])
