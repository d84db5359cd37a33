"""The model: collectives of simulated UAVs choosing sites (SPEC-simulation.md).

numpy and numba (compiled rules, cached: see jit.py); no Flask, no database. The public API is documented in
docs/simulation-api.md.
"""

from hcss.simulation import jit  # noqa: F401 - sets the kernels' cache before they are defined
from hcss.simulation.decisions import DECISION_COLUMNS, DecisionRecord
from hcss.simulation.engine import Simulation
from hcss.simulation.errors import SimulationError
from hcss.simulation.params import MODELS, ROMAN, Params
from hcss.simulation.requests import OperatorCommand, RequestOutcome, RequestState, StatusChange
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
