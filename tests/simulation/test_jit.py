"""The compiled kernels' build options (jit.py)."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.simulation import Params, Scenario, Simulation
from hcss.simulation.constants import constants_for
from hcss.simulation.rules import discovery_plan


def test_a_kernel_for_compiled_callers_refuses_a_call_from_python():
    # Without its Python wrapper such a call would crash the interpreter.
    sim = Simulation(Scenario.generate(1), "M1")
    with pytest.raises(TypeError, match="called only from compiled code"):
        discovery_plan(sim.world.kernel_arrays(), constants_for(Params(), "M1"))
    sim.step(2)  # compiled callers still reach it
    assert sim.step_count == 2 and np.isfinite(sim.world.pos).all()
