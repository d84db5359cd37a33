"""Agent state codes (spec §3) and the groupings the rules refer to.

States are small integers so that a whole collective's states fit in one
int8 array and every rule is a masked vector operation.
"""

from __future__ import annotations

import numpy as np

U_L, U_I, F_L, F_I, F_D, F_R, C, I, X, D = range(10)
NAMES = ("U_L", "U_I", "F_L", "F_I", "F_D", "F_R", "C", "I", "X", "D")

# Where an agent physically is.  Independent of its decision state: an F_L
# agent flies to its target and back, an X agent flies to the new site.
AT_HUB, EXPLORING, TO_TARGET, TO_HUB = range(4)

FAVOURING = np.array([F_L, F_I, F_D, F_R], dtype=np.int8)
DELIBERATING = np.array([U_I, F_I, F_D, F_R], dtype=np.int8)
SEMI_INTERACTIVE = np.array([F_D, F_R], dtype=np.int8)

# Decision phase of each state: the quorum window is cleared when it (or the
# target) changes, and not when an agent only moves between latent and
# interactive (spec §7).
PHASE_OF_STATE = np.array([0, 0, 1, 1, 1, 1, 2, 3, 4, 5], dtype=np.int16)

# Quadrant of the interface (U, F, C, X) for each state; X includes I and D.
QUADRANT_OF_STATE = np.array([0, 0, 1, 1, 1, 1, 2, 3, 3, 3], dtype=np.int8)
QUADRANTS = ("U", "F", "C", "X")


def decision_key(state: np.ndarray, target: np.ndarray) -> np.ndarray:
    """One integer per agent for its decision state: phase and target.

    Uncommitted agents have no target, so their key ignores it.
    """
    phase = PHASE_OF_STATE[state].astype(np.int32)
    return np.where(phase == 0, 0, phase * 1024 + target.astype(np.int32) + 1)
