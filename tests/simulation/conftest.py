"""The rule tests' scenario; the trial whose agents a test places by hand is in
tests/support/worlds.py."""

from __future__ import annotations

import pytest

from hcss.simulation import Scenario


@pytest.fixture
def scenario() -> Scenario:
    return Scenario.generate(3, first_section="easy")
