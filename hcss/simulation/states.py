"""Agent state codes (spec §3) and the groupings the rules refer to.

States are small integers so that a whole collective's states fit in one
int8 array and every rule is a masked vector operation.
"""

from __future__ import annotations

import numpy as np

U_L, U_I, F_L, F_I, F_D, F_R, C, I, X, D = range(10)  # noqa: E741 - the spec names the state I
NAMES = ("U_L", "U_I", "F_L", "F_I", "F_D", "F_R", "C", "I", "X", "D")

# Where an agent physically is.  Independent of its decision state: an F_L
# agent flies to its target and back, an X agent flies to the new site.
AT_HUB, EXPLORING, TO_TARGET, TO_HUB = range(4)


def _table(*members: int) -> np.ndarray:
    """A boolean lookup table over state codes: ``TABLE[state]`` replaces ``np.isin``."""
    table = np.zeros(len(NAMES), dtype=bool)
    table[list(members)] = True
    return table


FAVOURING = _table(F_L, F_I, F_D, F_R)
FAVOURING_IN_HUB = _table(F_I, F_D, F_R)  # favouring states an agent has while in its hub
DELIBERATING = _table(U_I, F_I, F_D, F_R)
SENDING = _table(U_I, F_I, C, I, D)  # interactive hub states (F_D, F_R only receive)
COMMITTED_OR_LATER = _table(C, I, X, D)

# Decision phase of each state: the quorum window is cleared when it (or the
# target) changes, and not when an agent only moves between latent and
# interactive (spec §7).
PHASE_OF_STATE = np.array([0, 0, 1, 1, 1, 1, 2, 3, 4, 5], dtype=np.int32)

# Quadrant of the interface (U, F, C, X) for each state; X includes I and D.
QUADRANT_OF_STATE = np.array([0, 0, 1, 1, 1, 1, 2, 3, 3, 3], dtype=np.int8)
QUADRANTS = ("U", "F", "C", "X")


_KEY_BASE = PHASE_OF_STATE * 4096


def decision_key(state: np.ndarray, target: np.ndarray) -> np.ndarray:
    """One integer per agent for its decision state: phase and target.

    Relies on the invariant that uncommitted agents have target -1, which
    `World.set_state` keeps, so their key is 0 whatever they did before.
    """
    return np.asarray(_KEY_BASE[state] + target + 1)
