"""Target ids: 0-based indices inside the arrays, 1-based ids in every public output.

Events, the view, request records, refusal texts, decision records and the
platform's exports all name a target by its id (what the participant sees on
the map); the engine's arrays are indexed from 0. These functions are the
only place the one becomes the other.
"""

from __future__ import annotations

import numpy as np


def target_id(index: int) -> int:
    """The public id of the target at array index `index`."""
    return int(index) + 1


def target_index(target: int) -> int:
    """The array index of the target with public id `target`."""
    return int(target) - 1


def target_ids(indices: np.ndarray) -> np.ndarray:
    """The public ids of the targets at these array indices (int64)."""
    return np.asarray(indices, dtype=np.int64) + 1
