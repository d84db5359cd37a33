"""The suite hands its longest modules to the workers first (tests/support/order.py)."""

from __future__ import annotations

import pytest

from tests.support import order


def test_xdist_keeps_the_suite_s_order(request: pytest.FixtureRequest) -> None:
    """xdist's default reorders modules by their number of tests, which put the 3-minute soak
    (one test) among the last modules handed out; the suite's addopts turn that off."""
    assert request.config.getoption("loadscopereorder") is False


def test_modules_go_longest_first_by_the_record_and_new_ones_by_their_marks() -> None:
    tests = [
        ("tests/a.py::one", "other"),
        ("tests/a.py::two", "other"),
        ("tests/soak.py::long", "slow"),
        ("tests/new_slow.py::fresh", "slow"),
        ("tests/new_fast.py::fresh", "other"),
        ("tests/b.py::one", "other"),
        ("tests/c.py::one", "browser"),
    ]
    recorded = {
        "tests/a.py::one": 3.0,
        "tests/a.py::two": 4.0,
        "tests/soak.py::long": 200.0,
        "tests/b.py::one": 3.0,
        "tests/c.py::one": 3.0,
    }
    assert order.longest_first(tests, recorded) == [
        "tests/soak.py",  # 200 s recorded
        "tests/new_slow.py",  # not recorded: guessed 60 s for a slow test
        "tests/a.py",  # 7 s recorded
        "tests/b.py",  # 3 s, collected before c.py
        "tests/c.py",  # 3 s recorded, not the browser guess
        "tests/new_fast.py",  # guessed 0.5 s
    ]


def test_a_module_s_new_test_does_not_hide_its_recorded_ones() -> None:
    tests = [("tests/a.py::old", "other"), ("tests/a.py::added", "slow")]
    assert order.module_seconds(tests, {"tests/a.py::old": 30.0}) == {"tests/a.py": 30.0}
