"""Every parameter of the model, in one place.

The study leaves many details open; SPEC-simulation.md makes a choice for each
and marks it [choice]. They all live here, named and documented, so that a
researcher can change one without touching the engine. M1, M2 and M3 share
every value: the models differ only in their rules, never in their parameters.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Params:
    """Parameters of the world, the agents, the requests and the trial.

    Units are metres and seconds. Quantities called *rates* are per second and
    become a per-step probability 1 - exp(-rate * dt); quantities called
    *probabilities* apply once per event.
    """

    # --- world (spec §1) -------------------------------------------------
    arena_side_m: float = 1414.0  # square of about 2 km², origin at its centre
    hub_offset_m: float = 300.0  # hubs on a 600 m square centred in the arena
    n_agents: int = 200  # simulated UAVs per collective
    speed_mps: float = 60.0 / 3.6  # 60 km/h for every moving agent
    exploration_range_m: float = 500.0  # R, around the collective's current hub
    comm_range_m: float = 30.0  # peer-to-peer range inside the hub area
    hub_radius_m: float = 50.0  # [choice] hub area disc
    sensing_radius_m: float = 20.0  # [choice] an explorer this close encounters a target
    value_error: float = 0.1  # [choice] "10% error": v·(1+e), e ~ U[-0.1, 0.1]
    dt_s: float = 1.0  # time step
    turn_sd_rad: float = 0.5  # [choice] correlated random walk turning sd

    # --- targets and scenarios (spec §2) ---------------------------------
    target_values: tuple[float, ...] = (0.7, 0.8, 0.9, 1.0)
    target_distances_m: tuple[float, ...] = (150.0, 250.0, 350.0)
    min_separation_m: float = 50.0  # [choice] from every other target and hub
    decisions_per_section: int = 6
    decision_timeout_s: float | None = 30 * 60.0  # [choice]; None in live trials

    # --- rates (spec §4) --------------------------------------------------
    resume_factor: float = 9.0  # P_L = 9 · P_U^I
    message_rate: float = 1.0  # [choice] r_msg, messages per second per sender
    abandon_alpha: float = 0.05  # [choice] "5% per metre", read per 100 m
    abandon_unit_m: float = 100.0
    neighbour_draws: int = 8  # [choice] rejection-sampling draws to find a neighbour

    # --- M2 (spec §5) -----------------------------------------------------
    discovery_mu: float = 0.058  # g(d) = mu · exp(xi · d) / d, d in 100 m
    discovery_xi: float = -0.29
    discovery_unit_m: float = 100.0  # [choice] the fit's distance unit
    site_d_min_m: float = 150.0  # [choice] minimum site distance of the problem
    site_d_max_m: float = 350.0  # [choice] maximum site distance of the problem

    # --- quorum (spec §7) -------------------------------------------------
    quorum_k: int = 15

    # --- operator requests (spec §8) --------------------------------------
    investigate_agents: int = 10  # 5% of N
    abandon_min_supporters: int = 2
    decide_min_support: float = 0.30
    decide_agents: int = 2
    intervention_support: float = 0.10  # an abandon at or above this is an intervention
    outline_support: float = 0.30  # blue outline on the map
    visible_reports: int = 1  # reports before a target appears to the operator
    drawn_reports: int = 2  # reports before it is drawn with its value colour

    # --- derived quantities ----------------------------------------------
    @property
    def mean_round_trip_s(self) -> float:
        """τ̄ = 2·(2R/3)/speed: mean round trip over the exploration disc [choice]."""
        return 2.0 * (2.0 * self.exploration_range_m / 3.0) / self.speed_mps

    @property
    def stop_exploring_rate(self) -> float:
        """P_U^I = 1/τ̄."""
        return 1.0 / self.mean_round_trip_s

    @property
    def resume_rate(self) -> float:
        """P_L = 9·P_U^I, for resuming exploration and for leaving to reassess."""
        return self.resume_factor * self.stop_exploring_rate

    @property
    def silence_limit_s(self) -> float:
        """An initiating agent executes after k/r_msg seconds without a message."""
        return self.quorum_k / self.message_rate

    def discovery_rate(self, distance_m: float | np.ndarray) -> float | np.ndarray:
        """g(d) = μ·e^(ξ·d)/d per second, d in 100 m units (works on arrays)."""
        d = np.asarray(distance_m, dtype=float) / self.discovery_unit_m
        return self.discovery_mu * np.exp(self.discovery_xi * d) / d

    def round_trip_s(self, distance_m: float | np.ndarray) -> float | np.ndarray:
        """τ_i = 2·d_i/speed."""
        return 2.0 * distance_m / self.speed_mps

    def with_changes(self, **changes: object) -> Params:
        """A copy with some values changed, e.g. ``params.with_changes(dt_s=0.5)``."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, object]:
        return {name: getattr(self, name) for name in self.__dataclass_fields__}

    @classmethod
    def from_dict(cls, values: dict[str, object]) -> Params:
        known = {k: v for k, v in values.items() if k in cls.__dataclass_fields__}
        for key in ("target_values", "target_distances_m"):
            if key in known:
                known[key] = tuple(known[key])  # JSON turns tuples into lists
        return cls(**known)


MODELS: tuple[str, ...] = ("M1", "M2", "M3")
ROMAN: tuple[str, ...] = (
    "I",
    "II",
    "III",
    "IV",
    "V",
    "VI",
    "VII",
    "VIII",
    "IX",
    "X",
    "XI",
    "XII",
    "XIII",
    "XIV",
    "XV",
    "XVI",
)
