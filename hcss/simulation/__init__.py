"""The model: collectives of simulated UAVs choosing sites (SPEC-simulation.md).

numpy and numba (compiled rules, cached: see jit.py); no Flask, no database. The public API is documented in
docs/simulation-api.md.

The names below are imported when first asked for (PEP 562), not with the package: a
reader of the light modules (`params`, `requests`, `messages`: the platform's models, the
export) would otherwise import numba and load every compiled kernel, over a second of a
cold `hcss export` that runs no simulation. Each kernel module imports `jit` (directly or
through `stream`) before it defines a kernel, so the cache directory is always set first.
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hcss.simulation.decisions import DECISION_COLUMNS, DecisionRecord
    from hcss.simulation.engine import Simulation
    from hcss.simulation.errors import SimulationError
    from hcss.simulation.params import MODELS, ROMAN, Params
    from hcss.simulation.requests import (
        OperatorCommand,
        RequestOutcome,
        RequestState,
        StatusChange,
    )
    from hcss.simulation.scenario import Scenario, ScenarioError
    from hcss.simulation.snapshots import NewerSnapshotFormat
    from hcss.simulation.view import Display, Truth

__all__ = [
    "DECISION_COLUMNS",
    "MODELS",
    "NewerSnapshotFormat",
    "ROMAN",
    "DecisionRecord",
    "Display",
    "OperatorCommand",
    "Params",
    "RequestOutcome",
    "RequestState",
    "Scenario",
    "ScenarioError",
    "Simulation",
    "SimulationError",
    "StatusChange",
    "Truth",
]


def _module_of(name: str) -> ModuleType:
    """The module that defines the public `name`, imported (statically, for import-linter)."""
    if name in ("DECISION_COLUMNS", "DecisionRecord"):
        from hcss.simulation import decisions

        return decisions
    if name == "Simulation":
        from hcss.simulation import engine

        return engine
    if name == "SimulationError":
        from hcss.simulation import errors

        return errors
    if name in ("MODELS", "ROMAN", "Params"):
        from hcss.simulation import params

        return params
    if name in ("OperatorCommand", "RequestOutcome", "RequestState", "StatusChange"):
        from hcss.simulation import requests

        return requests
    if name in ("Scenario", "ScenarioError"):
        from hcss.simulation import scenario

        return scenario
    if name == "NewerSnapshotFormat":
        from hcss.simulation import snapshots

        return snapshots
    if name in ("Display", "Truth"):
        from hcss.simulation import view

        return view
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __getattr__(name: str) -> Any:
    """The public name from its module, imported on first use."""
    value = getattr(_module_of(name), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
