"""The model's one error type, apart so that the engine and its snapshot format share it."""

from __future__ import annotations


class SimulationError(ValueError):
    """The simulation cannot be built or restored as asked."""
