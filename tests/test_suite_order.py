"""The suite hands its longest modules to the workers first (tests/support/order.py)."""

from __future__ import annotations

import os

import pytest

from tests.support import order


def test_xdist_keeps_the_suite_s_order(request: pytest.FixtureRequest) -> None:
    """xdist's default reorders modules by their number of tests, which put the 3-minute soak
    (one test) among the last modules handed out; the suite's addopts turn that off."""
    assert request.config.getoption("loadscopereorder") is False


def test_heavy_modules_go_one_at_a_time_with_light_ones_between() -> None:
    """Two heavy modules (100 s or more) and light ones: with 3 workers, the first heavy module
    is followed by light modules adding up to twice its time (what the other two workers do
    while it runs), then the next heavy one; a module not recorded is guessed from its marks."""
    tests = [
        ("tests/light_a.py::one", "other"),
        ("tests/light_a.py::two", "other"),
        ("tests/soak.py::long", "slow"),
        ("tests/new_slow.py::fresh", "slow"),
        ("tests/new_slow.py::fresher", "slow"),
        ("tests/new_fast.py::fresh", "other"),
        ("tests/light_b.py::one", "other"),
        ("tests/light_c.py::one", "browser"),
        ("tests/light_d.py::one", "other"),
    ]
    recorded = {
        "tests/light_a.py::one": 30.0,
        "tests/light_a.py::two": 40.0,
        "tests/soak.py::long": 200.0,
        "tests/light_b.py::one": 60.0,
        "tests/light_c.py::one": 60.0,
        "tests/light_d.py::one": 50.0,
    }
    assert order.heavy_apart(tests, recorded, workers=3) == [
        "tests/soak.py",  # 200 s recorded: the other two workers have 400 s to fill
        "tests/light_a.py",  # 70 s
        "tests/light_b.py",  # 60 s, collected before light_c.py
        "tests/light_c.py",  # 60 s recorded, not the browser guess
        "tests/light_d.py",  # 50 s: 240 s so far, short of 400
        "tests/new_fast.py",  # guessed 0.5 s: the light modules are used up
        "tests/new_slow.py",  # not recorded: two slow tests guessed 120 s, heavy
    ]
    assert order.heavy_apart(tests, recorded, workers=1)[:2] == [
        "tests/soak.py",
        "tests/new_slow.py",  # one worker: no room between heavy modules
    ]


def test_a_module_s_new_test_does_not_hide_its_recorded_ones() -> None:
    tests = [("tests/a.py::old", "other"), ("tests/a.py::added", "slow")]
    assert order.module_seconds(tests, {"tests/a.py::old": 30.0}) == {"tests/a.py": 30.0}


def test_the_order_is_made_for_the_workers_that_run(request: pytest.FixtureRequest) -> None:
    """Each xdist worker collects and orders the suite itself, and xdist clears `-n` in its
    workers: the order must read their count where a worker is told it."""
    running = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    assert order.workers_of(request.config) == running
