"""The parameters as the compiled kernels take them: plain numbers in a named tuple.

Built once per (Params, model) from `Params`, which stays the one place where
values are defined and documented; this is only their compiled-code form.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

from hcss.simulation.params import Params

MODEL_CODES = {"M1": 1, "M2": 2, "M3": 3}


class Constants(NamedTuple):
    model: int  # 1, 2 or 3 (MODEL_CODES)
    dt_s: float
    speed_mps: float
    turn_sd_rad: float
    hub_radius_m: float
    exploration_range_m: float
    comm_range_m: float
    sensing_radius_m: float
    value_error: float
    stop_probability: float  # per step, 1 - exp(-P_U^I·dt)
    leave_probability: float  # per step, 1 - exp(-P_L·dt)
    message_rate: float
    abandon_alpha: float  # α times its scale (params.abandon_scale)
    abandon_unit_m: float
    neighbour_draws: int
    quorum_k: int
    silence_limit_s: float
    discovery_per_agent: bool  # params.discovery == "per_agent"
    own_targets_only: bool  # params.foreign_targets == "own_only"
    discovery_delay: bool  # M2's mechanisms in force for this model
    reassessment_delay: bool
    modulation: bool  # some use of an F_I agent's messages carries M_i in this model
    modulate_queue: bool  # params.modulated_uses(model): which ones
    modulate_recruitment: bool
    modulate_inhibition: bool
    abandon_rate: bool  # params.abandonment == "rate"
    g_value_inside: bool  # params.m2_g_reading == "value_inside"


@functools.lru_cache(maxsize=256)
def constants_for(params: Params, model: str) -> Constants:
    return Constants(
        model=MODEL_CODES[model],
        dt_s=float(params.dt_s),
        speed_mps=float(params.speed_mps),
        turn_sd_rad=float(params.turn_sd_rad),
        hub_radius_m=float(params.hub_radius_m),
        exploration_range_m=float(params.exploration_range_m),
        comm_range_m=float(params.comm_range_m),
        sensing_radius_m=float(params.sensing_radius_m),
        value_error=float(params.value_error),
        stop_probability=-math.expm1(-params.stop_exploring_rate * params.dt_s),
        leave_probability=-math.expm1(-params.resume_rate * params.dt_s),
        message_rate=float(params.message_rate),
        abandon_alpha=float(params.abandon_alpha * params.abandon_scale),
        abandon_unit_m=float(params.abandon_unit_m),
        neighbour_draws=int(params.neighbour_draws),
        quorum_k=int(params.quorum_k),
        silence_limit_s=float(params.silence_limit_s),
        discovery_per_agent=params.discovery == "per_agent",
        own_targets_only=params.foreign_targets == "own_only",
        discovery_delay=params.m2_uses(model, "discovery_delay"),
        reassessment_delay=params.m2_uses(model, "reassessment_delay"),
        modulation=bool(params.modulated_uses(model)),
        modulate_queue="queue" in params.modulated_uses(model),
        modulate_recruitment="recruitment" in params.modulated_uses(model),
        modulate_inhibition="inhibition" in params.modulated_uses(model),
        abandon_rate=params.abandonment == "rate",
        g_value_inside=params.m2_g_reading == "value_inside",
    )
