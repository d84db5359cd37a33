"""The per-agent rules of spec §4–5 that do not involve messages.

Each rule is one compiled (numba) function over the agents, named as in the
spec; the engine runs them fused in `step.advance_agents`, and the thin
Python entry points below let a test or a request call one rule on its own. Rates
become per-step probabilities 1 - exp(-rate·dt).

Quantities that depend only on hub-to-target distances (M2's delay
denominators and message-rate factor) are computed with numpy in
`refresh_geometry` whenever a hub moves, so their formulas live in one place.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hcss.simulation import states as S
from hcss.simulation import stream
from hcss.simulation.constants import Constants, constants_for
from hcss.simulation.jit import internal
from hcss.simulation.params import Params
from hcss.simulation.world import Arrays, World, set_state_one


# ----------------------------------------------------------------- formulas
@njit(cache=True)
def per_step_probability(rate: float, dt: float) -> float:
    """Probability that a Poisson event of the given rate happens within one step."""
    return -math.expm1(-rate * dt)


@njit(cache=True, inline="always")
def within_step(u: float, rate: float, dt: float) -> bool:
    """Whether a uniform draw u falls below `per_step_probability(rate, dt)`.

    Exact, and cheap for the common draw: 1 - e^(-x) lies between x·(1 - x)
    and x, so the exponential is computed only for a draw between the two.
    """
    x = rate * dt
    if u >= x:
        return False
    if u < x * (1.0 - x):
        return True
    return u < per_step_probability(rate, dt)


@njit(cache=True)
def leave_rate_one(estimate: float, gap: float) -> float:
    """v̂ / gap, with the guard of spec §5: infinite (leave at once) where gap ≤ 0."""
    return estimate / gap if gap > 0.0 else math.inf


@njit(cache=True, inline="always")
def assess(w: Arrays, k: Constants, t: int) -> float:
    """A fresh estimate v̂ = v·(1+e) of target t, e ~ U[-0.1, 0.1], clipped to (0, 1]."""
    error = k.value_error * (2.0 * stream.uniform(w.stream) - 1.0)
    return float(min(max(w.target_value[t] * (1.0 + error), 1e-9), 1.0))


@njit(cache=True, inline="always")
def abandon_probability_one(w: Arrays, k: Constants, i: int) -> float:
    """P_α = min(1, α·(d_i/100 m)/v̂): farther and poorer targets are abandoned more."""
    d = w.hub_distance[w.collective[i], w.target[i]]
    return float(min(1.0, k.abandon_alpha * (d / k.abandon_unit_m) / w.estimate[i]))


def discovery_gap(distance_m: np.ndarray, params: Params) -> np.ndarray:
    """scale·(1/g(d_max) − 1/g(d_i)): the extra wait that equalises discovery times.

    d_max and the treatment of sites beyond it follow the chosen reading
    (`params.m2_distance_bounds`, `params.m2_beyond_dmax`).
    """
    return _discovery_gap(params.m2_distance(distance_m), params)


def _discovery_gap(d: np.ndarray, params: Params) -> np.ndarray:
    return params.discovery_wait_gap_s(d)


def round_trip_gap(distance_m: np.ndarray, params: Params) -> np.ndarray:
    """τ_max − τ_i: the extra wait that equalises round-trip times."""
    return _round_trip_gap(params.m2_distance(distance_m), params)


def _round_trip_gap(d: np.ndarray, params: Params) -> np.ndarray:
    return np.asarray(params.round_trip_s(params.m2_d_max_m) - params.round_trip_s(d))


def frequency_modulation(
    distance_m: np.ndarray, params: Params, nearest_site_m: float | None = None
) -> np.ndarray:
    """M2's M_i = d_i / d_min: farther targets' messages count more often.

    d_min (`params.m2_d_min`: the search space's, or `nearest_site_m`, the nearest
    eligible site's) and the treatment of sites beyond d_max follow the chosen
    reading; which uses of a message M_i multiplies is `params.m2_modulation_uses`.
    """
    return params.m2_distance(distance_m) / params.modulation_d_min_m(nearest_site_m)


def nearest_eligible_site_m(world: World, params: Params) -> list[float | None]:
    """Per collective: the distance of the nearest site of its current layout (active, in
    range, its own under foreign_targets="own_only"), or None when it has none."""
    nearest: list[float | None] = []
    for c in range(world.n_collectives):
        ok = world.active & (world.hub_distance[c] <= params.exploration_range_m)
        if params.foreign_targets == "own_only":
            ok &= world.target_around == c
        nearest.append(float(world.hub_distance[c, ok].min()) if ok.any() else None)
    return nearest


def site_rate(distance_m: np.ndarray, params: Params) -> np.ndarray:
    """Per-agent discovery rate g(d) (discovery "per_agent").

    Distances are floored at the hub radius: a site can be no nearer than the
    edge of the hub area, and g(d) diverges at d = 0.
    """
    return np.asarray(params.discovery_rate(np.maximum(distance_m, params.hub_radius_m)))


def refresh_geometry(world: World, params: Params) -> None:
    """Hub-to-target distances and what derives from them; called when a hub moves.

    Written in place (the kernels' argument tuple holds these arrays), with
    M2's distance reading computed once for its three quantities.
    """
    world.refresh_hub_distance()
    d = params.m2_distance(world.hub_distance)
    with np.errstate(divide="ignore", invalid="ignore"):
        world.discovery_gap[:] = _discovery_gap(d, params)
    world.round_trip_gap[:] = _round_trip_gap(d, params)
    if params.m2_d_min == "nearest_site":
        for c, nearest in enumerate(nearest_eligible_site_m(world, params)):
            world.send_factor[c] = d[c] / params.modulation_d_min_m(nearest)
    else:
        world.send_factor[:] = d / params.m2_d_min_m
    world.site_rate[:] = site_rate(world.hub_distance, params)


# -------------------------------------------------------------------- rules
@internal
def discoverable_sites(w: Arrays, k: Constants, ok: np.ndarray) -> None:
    """(C, T) into `ok`: whether collective c's explorers can adopt target t.

    Active, in range of the hub, not reserved by another collective, not under
    a standing abandon order, and (reading `foreign_targets="own_only"`)
    placed around the collective's own start hub.
    """
    active, reserved_by, around = w.active, w.reserved_by, w.target_around
    hub_distance, abandon_order = w.hub_distance, w.abandon_order
    for c in range(ok.shape[0]):
        for t in range(ok.shape[1]):
            owner = reserved_by[t]
            ok[c, t] = (
                active[t]
                and hub_distance[c, t] <= k.exploration_range_m
                and (owner < 0 or owner == c)
                and not abandon_order[c, t]
                and (not k.own_targets_only or around[t] == c)
            )


@njit(cache=True, inline="always")
def adopt_on_discovery(w: Arrays, k: Constants, i: int, t: int) -> None:
    """An explorer that found target t assesses it, adopts it with probability v̂ and flies home."""
    estimate = assess(w, k, t)
    if stream.uniform(w.stream) < estimate:
        set_state_one(w.state, w.target, w.streak, i, S.F_L, t)
        w.estimate[i] = estimate
        w.report_target[i] = t
        w.leg[i] = S.TO_HUB
        w.arrival_state[i] = S.F_D if k.discovery_delay else S.F_I


@internal
def discovery_plan(
    w: Arrays, k: Constants
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What an explorer can find this step: it depends on its collective only, and a
    discovery changes none of it, so it is worked out once per step.

    Per collective: how many sites are discoverable, which (`discoverable_sites`),
    and for reading "per_agent" their summed rate g and the per-step probability
    of finding one.
    """
    n_c, n_t = w.hub_distance.shape
    ok = np.empty((n_c, n_t), dtype=np.bool_)
    discoverable_sites(w, k, ok)
    count = np.zeros(n_c, dtype=np.int64)
    sites = np.empty((n_c, n_t), dtype=np.int64)
    total = np.zeros(n_c)
    probability = np.zeros(n_c)
    for c in range(n_c):
        for t in range(n_t):
            if ok[c, t]:
                sites[c, count[c]] = t
                count[c] += 1
                total[c] += w.site_rate[c, t]
        if total[c] > 0.0:
            probability[c] = per_step_probability(total[c], k.dt_s)
    return count, sites, total, probability


@internal
def reach_target_kernel(w: Arrays, k: Constants, agents: np.ndarray, n: int) -> None:
    """Agents arriving at a target: executing agents enter D; assessing agents re-estimate it.

    An assessing agent (F_L, sent to reassess, recruited or asked to
    investigate) takes a fresh estimate and, under the "per_visit" reading of
    abandonment, abandons with probability P_α, returning uncommitted; otherwise it returns favouring the target (through
    F_R in M2). A target taken or reserved by another collective meanwhile is
    dropped without a report.
    """
    for j in range(n):
        i = agents[j]
        if w.state[i] == S.X:
            set_state_one(w.state, w.target, w.streak, i, S.D, w.target[i])
            w.leg[i] = S.AT_HUB
        elif w.state[i] == S.F_L:
            t = w.target[i]
            owner = w.reserved_by[t]
            w.leg[i] = S.TO_HUB
            if not w.active[t] or (owner >= 0 and owner != w.collective[i]):
                w.arrival_state[i] = S.U_I
                continue
            w.estimate[i] = assess(w, k, t)
            w.report_target[i] = t
            if not k.abandon_rate and stream.uniform(w.stream) < abandon_probability_one(w, k, i):
                w.arrival_state[i] = S.U_I
            else:
                w.arrival_state[i] = S.F_R if k.reassessment_delay else S.F_I


@internal
def reach_hub_kernel(w: Arrays, agents: np.ndarray, n: int, newly_visible: np.ndarray) -> int:
    """Agents arriving home enter their arrival state and report their estimate.

    Writes the targets that became visible to the operator with these reports
    into `newly_visible` and returns how many.
    """
    n_visible = 0
    for j in range(n):
        i = agents[j]
        w.leg[i] = S.AT_HUB
        set_state_one(w.state, w.target, w.streak, i, w.arrival_state[i], w.target[i])
        t = w.report_target[i]
        if t >= 0:
            if w.report_count[t] == 0:
                newly_visible[n_visible] = t
                n_visible += 1
            w.report_sum[t] += w.estimate[i]
            w.report_count[t] += 1
            w.report_target[i] = -1
    return n_visible


@internal
def agent_rules_kernel(
    w: Arrays, k: Constants, orders: bool, discovery: bool, transitions: bool
) -> None:
    """Standing orders, discovery and the rate transitions, agent by agent in one pass.

    Each rule reads only its agent and target-level state that none of them
    changes, so applying them agent by agent, in this order, is applying them
    rule by rule; one pass over the agents costs less than three. The flags
    select rules, for a caller (a test, a request, the calibration) that needs
    only some.

    Standing orders (spec §8): an abandon order makes c's agents favouring t
    uncommitted when in the hub. A target reserved by another collective (or
    taken) is dropped the same way, and committed or initiating agents for it
    return to deliberation.

    Discovery, U_L → F_L(i): an explorer discovers a target and adopts it with
    probability v̂. Reading "spatial": it encounters target i within the
    sensing radius (of two sensed at once, the nearer). Reading "per_agent"
    (the paper's P_γ = v·g(d) per agent): it finds each discoverable site at
    rate g(d_i), some site within a step with probability 1 − exp(−Σ g(d_i)·dt),
    which one in proportion to the rates; its flights stay spatial.

    Rate transitions: under the "rate" reading of abandonment, favouring agents
    in the hub abandon at α/v̂ (→ U_I); stop exploring (U_L → home), resume
    exploring (U_I → U_L), reassess (F_I → F_L), and M2's delays: F_D → F_I at P_D(i) =
    v̂/(1/g(d_max) − 1/g(d_i)) and F_R → F_I at P_R(i) = v̂/(τ_max − τ_i), so
    that every target's discovery-plus-delay and round-trip-plus-delay times
    match those of a target at d_max. Where d_i ≥ d_max the state is left at once.
    """
    state, leg, target, streak, collective = w.state, w.leg, w.target, w.streak, w.collective
    reserved_by, active, abandon_order = w.reserved_by, w.active, w.abandon_order
    arrival_state, estimate, pos, target_pos = w.arrival_state, w.estimate, w.pos, w.target_pos
    site_rate = w.site_rate
    count, sites, total, probability = discovery_plan(w, k)
    radius2 = k.sensing_radius_m * k.sensing_radius_m
    r = stream.load(w.stream)
    for i in range(state.size):
        # -- standing orders and reservations, for agents in their hub
        t = target[i]
        if orders and t >= 0:
            c = collective[i]
            favouring_here = leg[i] == S.AT_HUB and S.FAVOURING_IN_HUB[state[i]]
            owner = reserved_by[t]
            taken = (owner >= 0 and owner != c) or not active[t]
            if (favouring_here and abandon_order[c, t]) or (
                taken and (favouring_here or state[i] == S.C or state[i] == S.I)
            ):
                set_state_one(state, target, streak, i, S.U_I, -1)
        # -- discovery by an explorer
        if discovery and leg[i] == S.EXPLORING and state[i] == S.U_L:
            c = collective[i]
            best = -1
            if k.discovery_per_agent:
                if total[c] > 0.0:
                    u, r = stream.unit(r)
                    if u < probability[c]:
                        u, r = stream.unit(r)
                        pick = u * total[c]
                        for j in range(count[c]):
                            best = sites[c, j]
                            pick -= site_rate[c, best]
                            if pick < 0.0:
                                break
            else:
                best_d2 = radius2
                for j in range(count[c]):
                    t = sites[c, j]
                    dx = pos[i, 0] - target_pos[t, 0]
                    dy = pos[i, 1] - target_pos[t, 1]
                    d2 = dx * dx + dy * dy
                    if d2 < best_d2 or (best < 0 and d2 == best_d2):
                        best, best_d2 = t, d2
            if best >= 0:
                stream.store(w.stream, r)
                adopt_on_discovery(w, k, i, best)
                r = stream.load(w.stream)
        if not transitions:
            continue
        # -- rate transitions
        if leg[i] == S.EXPLORING:
            if state[i] == S.U_L:
                u, r = stream.unit(r)
                if u < k.stop_probability:
                    leg[i] = S.TO_HUB
                    arrival_state[i] = S.U_I
        elif leg[i] == S.AT_HUB:
            if k.abandon_rate and state[i] == S.F_I:
                u, r = stream.unit(r)
                if within_step(u, k.abandon_alpha / estimate[i], k.dt_s):
                    set_state_one(state, target, streak, i, S.U_I, -1)
                    continue
            if state[i] == S.U_I:
                u, r = stream.unit(r)
                if u < k.leave_probability:
                    set_state_one(state, target, streak, i, S.U_L, -1)
                    leg[i] = S.EXPLORING
            elif state[i] == S.F_I:
                u, r = stream.unit(r)
                if u < k.leave_probability:
                    set_state_one(state, target, streak, i, S.F_L, target[i])
                    leg[i] = S.TO_TARGET
            elif state[i] == S.F_D or state[i] == S.F_R:  # only M2 (with its delays) has them
                c, t = collective[i], target[i]
                if state[i] == S.F_D:
                    gap = w.discovery_gap[c, t]
                    if k.g_value_inside:  # g carries v̂ at both distances: the gap is over v̂
                        gap = gap / estimate[i]
                else:
                    gap = w.round_trip_gap[c, t]
                rate = leave_rate_one(estimate[i], gap)
                leave = rate == math.inf
                if not leave:
                    u, r = stream.unit(r)
                    leave = within_step(u, rate, k.dt_s)
                if leave:
                    set_state_one(state, target, streak, i, S.F_I, t)
    stream.store(w.stream, r)


# ------------------------------------------------------- Python entry points
def per_step(rate: float, params: Params) -> float:
    return float(per_step_probability(float(rate), float(params.dt_s)))


def leave_rate(estimate: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """Elementwise `leave_rate_one` (for tests and analysis)."""
    estimate, gap = np.broadcast_arrays(np.asarray(estimate, float), np.asarray(gap, float))
    return np.array([leave_rate_one(e, g) for e, g in zip(estimate.flat, gap.flat, strict=True)])


def abandon_probability(world: World, agents: np.ndarray, params: Params) -> np.ndarray:
    k = constants_for(params, "M1")
    w = world.kernel_arrays()
    return np.array([abandon_probability_one(w, k, int(i)) for i in agents])


def reach_hub(world: World, agents: np.ndarray) -> np.ndarray:
    """Agents arriving home enter their arrival state and report; the newly visible targets."""
    agents = np.asarray(agents, dtype=np.int64)
    visible = np.empty(world.active.size, dtype=np.int64)
    n = _reach_hub(world.kernel_arrays(), agents, agents.size, visible)
    return visible[:n]


def reach_target(world: World, agents: np.ndarray, params: Params, model: str) -> None:
    """Agents arriving at their target (`reach_target_kernel`)."""
    agents = np.asarray(agents, dtype=np.int64)
    _reach_target(world.kernel_arrays(), constants_for(params, model), agents, agents.size)


def discoverable(world: World, params: Params) -> np.ndarray:
    """(C, T): targets each collective's explorers can adopt (`discoverable_sites`)."""
    ok = np.zeros(world.abandon_order.shape, dtype=np.bool_)
    _discoverable_sites(world.kernel_arrays(), constants_for(params, "M1"), ok)
    return ok


def discovery(world: World, params: Params, model: str) -> None:
    _agent_rules(world.kernel_arrays(), constants_for(params, model), False, True, False)


def rate_transitions(world: World, params: Params, model: str) -> None:
    _agent_rules(world.kernel_arrays(), constants_for(params, model), False, False, True)


def enforce_orders(world: World, params: Params) -> None:
    _agent_rules(world.kernel_arrays(), constants_for(params, "M1"), True, False, False)


# The kernels' entries from Python (the kernels themselves have none: jit.internal).
@njit(cache=True)
def _reach_hub(w: Arrays, agents: np.ndarray, n: int, newly_visible: np.ndarray) -> int:
    return reach_hub_kernel(w, agents, n, newly_visible)


@njit(cache=True)
def _reach_target(w: Arrays, k: Constants, agents: np.ndarray, n: int) -> None:
    reach_target_kernel(w, k, agents, n)


@njit(cache=True)
def _discoverable_sites(w: Arrays, k: Constants, ok: np.ndarray) -> None:
    discoverable_sites(w, k, ok)


@njit(cache=True)
def _agent_rules(w: Arrays, k: Constants, orders: bool, discovery: bool, transitions: bool) -> None:
    agent_rules_kernel(w, k, orders, discovery, transitions)
