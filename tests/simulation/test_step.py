"""The compiled step and the engine name the same leading target.

`step.leading` (compiled, inside the quiet steps) decides whether a step
needs the engine; `engine._leading_targets` (Python) then announces the
commitment or begins the move. If they disagreed on a tie or an empty row,
the quiet steps would either stop for nothing at every step or run past a
commitment the engine should have announced.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from hcss.simulation.engine import _leading_targets
from hcss.simulation.step import leading


@njit
def _compiled_leading(counts):
    return leading(counts)  # `leading` is callable only from compiled code


@settings(deadline=None)  # not a timing test: a loaded machine passed the 200 ms default
@given(st.lists(st.lists(st.integers(0, 5), min_size=1, max_size=8), min_size=1, max_size=6))
def test_compiled_and_python_leading_targets_agree(rows: list[list[int]]) -> None:
    width = max(len(row) for row in rows)
    counts = np.array([row + [0] * (width - len(row)) for row in rows], dtype=np.int64)
    compiled = [(c, _compiled_leading(counts[c])) for c in range(counts.shape[0])]
    expected = [(c, t) for c, t in compiled if t >= 0]

    assert _leading_targets(counts) == expected
