"""The per-agent rules of spec §4–5 that do not involve messages.

Each function is one rule, named as in the spec, and acts on all agents at
once. Rates become per-step probabilities 1 - exp(-rate·dt).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from hcss.simulation import states as S
from hcss.simulation.params import Params
from hcss.simulation.world import World


def per_step(rate: np.ndarray | float, params: Params) -> np.ndarray | float:
    """Probability that a Poisson event of the given rate happens within one step."""
    return -np.expm1(-np.asarray(rate) * params.dt_s)


def assess(
    world: World, agents: np.ndarray, params: Params, rng: np.random.Generator
) -> np.ndarray:
    """A fresh estimate v̂ = v·(1+e) of each agent's target, e ~ U[-0.1, 0.1], clipped to (0, 1]."""
    value = world.target_value[world.target[agents]]
    error = rng.uniform(-params.value_error, params.value_error, agents.size)
    return np.clip(value * (1.0 + error), 1e-9, 1.0)


def discovery(world: World, params: Params, rng: np.random.Generator, model: str) -> None:
    """U_L → F_L(i): an explorer within the sensing radius of target i adopts it with probability v̂.

    Only targets eligible for the agent's collective count (`discoverable`).
    Under the per-agent reading (`params.discovery == "per_agent"`) explorers
    find sites at the paper's rate g(d) instead of by encounter.
    """
    if params.discovery == "per_agent":
        from hcss.simulation.discovery import discover_per_agent

        discover_per_agent(world, params, rng, model)
        return
    explorers = np.flatnonzero((world.leg == S.EXPLORING) & (world.state == S.U_L))
    candidates = np.flatnonzero(world.active)
    if explorers.size == 0 or candidates.size == 0:
        return
    # Only explorers in a grid cell near some target need exact distances.
    grid = sensing_grid(
        world.target_pos[candidates].tobytes(), params.arena_side_m, params.sensing_radius_m
    )
    explorers = explorers[grid.covers(world.pos[explorers])]
    if explorers.size == 0:
        return
    dx = world.pos[explorers, 0, None] - world.target_pos[None, candidates, 0]
    dy = world.pos[explorers, 1, None] - world.target_pos[None, candidates, 1]
    distance2 = dx * dx + dy * dy
    near = distance2 <= params.sensing_radius_m**2
    if not near.any():
        return
    col = world.collective[explorers]
    near &= discoverable(world, params)[col[:, None], candidates[None, :]]
    found = near.any(axis=1)
    if not found.any():
        return
    agents = explorers[found]
    # The nearest encountered target, if an explorer senses two at once.
    distance = np.where(near[found], distance2[found], np.inf)
    adopt_on_discovery(world, agents, candidates[np.argmin(distance, axis=1)], params, rng, model)


def discoverable(world: World, params: Params) -> np.ndarray:
    """(C, T): targets a collective's explorers can adopt.

    Active, in range of the hub, not reserved by another collective, not under
    a standing abandon order, and (reading `foreign_targets="own_only"`)
    placed around the collective's own start hub.
    """
    n_c = world.n_collectives
    reserved = world.reserved_by[None, :]
    mine = np.arange(n_c)[:, None]
    ok = (
        world.active[None, :]
        & (world.hub_distance <= params.exploration_range_m)
        & ((reserved < 0) | (reserved == mine))
        & ~world.abandon_order
    )
    if params.foreign_targets == "own_only":
        ok &= world.target_around[None, :] == mine
    return ok


def adopt_on_discovery(
    world: World,
    agents: np.ndarray,
    targets: np.ndarray,
    params: Params,
    rng: np.random.Generator,
    model: str,
) -> None:
    """Explorers that found a target assess it, adopt it with probability v̂ and fly home."""
    world.target[agents] = targets  # provisional, to read the value; reset below if not adopted
    estimate = assess(world, agents, params, rng)
    adopt = rng.random(agents.size) < estimate
    world.target[agents[~adopt]] = -1
    adopters = agents[adopt]
    world.set_state(adopters, S.F_L, targets[adopt])
    world.estimate[adopters] = estimate[adopt]
    world.report_target[adopters] = targets[adopt]
    world.leg[adopters] = S.TO_HUB
    world.arrival_state[adopters] = S.F_D if params.m2_uses(model, "discovery_delay") else S.F_I


@dataclass(frozen=True)
class SensingGrid:
    """Cells of the arena within sensing range of some target: a cheap first filter."""

    covered: np.ndarray  # bool (cells, cells)
    origin: float
    cell: float

    def covers(self, pos: np.ndarray) -> np.ndarray:
        index = ((pos - self.origin) / self.cell).astype(np.int64)
        np.clip(index, 0, self.covered.shape[0] - 1, out=index)
        return self.covered[index[:, 0], index[:, 1]]


@functools.lru_cache(maxsize=64)
def sensing_grid(target_pos: bytes, arena_side_m: float, sensing_radius_m: float) -> SensingGrid:
    """Mark every cell that has a point within the sensing radius of a target.

    Cached on the targets' positions, which change only at section starts and
    relocations. Explorers reflect inside discs that may reach a little past
    the arena, so the grid has a margin of one exploration step.
    """
    cell = sensing_radius_m / 2.0
    origin = -arena_side_m / 2.0 - 4.0 * sensing_radius_m
    n = int(np.ceil((arena_side_m + 8.0 * sensing_radius_m) / cell)) + 1
    centres = origin + (np.arange(n) + 0.5) * cell
    targets = np.frombuffer(target_pos).reshape(-1, 2)
    reach = sensing_radius_m + cell  # cell half-diagonal < cell
    covered = np.zeros((n, n), dtype=bool)
    for x, y in targets:
        near_x = np.abs(centres - x) <= reach
        near_y = np.abs(centres - y) <= reach
        covered |= near_x[:, None] & near_y[None, :]
    return SensingGrid(covered, origin, cell)


def abandon_probability(world: World, agents: np.ndarray, params: Params) -> np.ndarray:
    """P_α = min(1, α·(d_i/100 m)/v̂): farther and poorer targets are abandoned more."""
    d = world.hub_distance[world.collective[agents], world.target[agents]]
    return np.minimum(
        1.0, params.abandon_alpha * (d / params.abandon_unit_m) / world.estimate[agents]
    )


def reach_target(
    world: World, agents: np.ndarray, params: Params, rng: np.random.Generator, model: str
) -> None:
    """Agents arriving at a target: executing agents enter D; assessing agents re-estimate it.

    An assessing agent (F_L, sent to reassess, recruited or asked to
    investigate) takes a fresh estimate and abandons with probability P_α,
    returning uncommitted; otherwise it returns favouring the target (through
    F_R in M2). A target taken or reserved by another collective meanwhile is
    dropped without a report.
    """
    if agents.size == 0:
        return
    executing = agents[world.state[agents] == S.X]
    world.set_state(executing, S.D)
    world.leg[executing] = S.AT_HUB
    assessing = agents[world.state[agents] == S.F_L]
    if assessing.size == 0:
        return
    t = world.target[assessing]
    owner = world.reserved_by[t]
    gone = ~world.active[t] | ((owner >= 0) & (owner != world.collective[assessing]))
    world.leg[assessing] = S.TO_HUB
    world.arrival_state[assessing[gone]] = S.U_I
    fresh = assessing[~gone]
    world.estimate[fresh] = assess(world, fresh, params, rng)
    world.report_target[fresh] = world.target[fresh]
    abandon = rng.random(fresh.size) < abandon_probability(world, fresh, params)
    world.arrival_state[fresh[abandon]] = S.U_I
    world.arrival_state[fresh[~abandon]] = (
        S.F_R if params.m2_uses(model, "reassessment_delay") else S.F_I
    )


def reach_hub(world: World, agents: np.ndarray) -> np.ndarray:
    """Agents arriving home enter their arrival state and report their estimate.

    Returns the targets that became visible to the operator with this report.
    """
    if agents.size == 0:
        return agents
    world.leg[agents] = S.AT_HUB
    world.set_states(agents, world.arrival_state[agents])
    carrying = agents[world.report_target[agents] >= 0]
    if carrying.size == 0:
        return carrying
    reported = world.report_target[carrying]
    before = world.report_count.copy()
    np.add.at(world.report_sum, reported, world.estimate[carrying])
    np.add.at(world.report_count, reported, 1)
    world.report_target[carrying] = -1
    return np.flatnonzero((before == 0) & (world.report_count > 0))


def rate_transitions(world: World, params: Params, rng: np.random.Generator, model: str) -> None:
    """Stop exploring (U_L → home), resume exploring (U_I → U_L), reassess (F_I → F_L), M2 delays."""
    draw = rng.random(world.state.shape[0])
    explorers = (world.leg == S.EXPLORING) & (world.state == S.U_L)
    in_hub = world.leg == S.AT_HUB

    stop = np.flatnonzero(explorers & (draw < per_step(params.stop_exploring_rate, params)))
    world.leg[stop] = S.TO_HUB
    world.arrival_state[stop] = S.U_I

    leave = per_step(params.resume_rate, params)
    resume = np.flatnonzero(in_hub & (world.state == S.U_I) & (draw < leave))
    world.set_state(resume, S.U_L)
    world.leg[resume] = S.EXPLORING

    reassess = np.flatnonzero(in_hub & (world.state == S.F_I) & (draw < leave))
    world.set_state(reassess, S.F_L)
    world.leg[reassess] = S.TO_TARGET

    if model == "M2":
        _interaction_delay(world, params, draw, in_hub)


def _interaction_delay(world: World, params: Params, draw: np.ndarray, in_hub: np.ndarray) -> None:
    """M2: F_D → F_I at P_D(i) = v̂/(1/g(d_max) − 1/g(d_i)); F_R → F_I at P_R(i) = v̂/(τ_max − τ_i).

    Near targets wait longer, so that every target's discovery-plus-delay and
    round-trip-plus-delay times match those of a target at d_max. Where
    d_i ≥ d_max the denominator is not positive and the state is left at once.
    """
    for state, gap in ((S.F_D, discovery_gap), (S.F_R, round_trip_gap)):
        waiting = np.flatnonzero(in_hub & (world.state == state))
        if waiting.size == 0:
            continue
        d = world.hub_distance[world.collective[waiting], world.target[waiting]]
        rate = leave_rate(world.estimate[waiting], gap(d, params))
        leave = waiting[
            (rate == np.inf) | (draw[waiting] < per_step(np.where(rate == np.inf, 0, rate), params))
        ]
        world.set_state(leave, S.F_I)


def discovery_gap(distance_m: np.ndarray, params: Params) -> np.ndarray:
    """1/g(d_max) − 1/g(d_i): the extra wait that equalises discovery times.

    d_max and the treatment of sites beyond it follow the chosen reading
    (`params.m2_distance_bounds`, `params.m2_beyond_dmax`).
    """
    d = params.m2_distance(distance_m)
    return 1.0 / params.discovery_rate(params.m2_d_max_m) - 1.0 / params.discovery_rate(d)


def round_trip_gap(distance_m: np.ndarray, params: Params) -> np.ndarray:
    """τ_max − τ_i: the extra wait that equalises round-trip times."""
    d = params.m2_distance(distance_m)
    return params.round_trip_s(params.m2_d_max_m) - params.round_trip_s(d)


def leave_rate(estimate: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """v̂ / gap, with the guard of spec §5: infinite (leave at once) where gap ≤ 0."""
    with np.errstate(divide="ignore"):
        return np.where(gap > 0, estimate / np.where(gap > 0, gap, 1.0), np.inf)


def favouring_in_hub(world: World) -> np.ndarray:
    """Agents favouring a target and physically in their hub (not flying)."""
    return (world.leg == S.AT_HUB) & S.FAVOURING_IN_HUB[world.state]


def enforce_orders(world: World) -> None:
    """Standing abandon orders and reservations, applied to agents in their hub.

    An abandon order makes c's agents favouring t uncommitted when in the hub.
    A target reserved by another collective is dropped the same way, and
    committed or initiating agents for it return to deliberation.
    """
    has_target = world.target >= 0
    if not (
        world.abandon_order.any()
        or (world.reserved_by >= 0).any()
        or (~world.active[world.target[has_target]]).any()
    ):
        return
    in_hub_favouring = favouring_in_hub(world)
    t = np.where(has_target, world.target, 0)
    ordered = in_hub_favouring & world.abandon_order[world.collective, t] & has_target
    owner = world.reserved_by[t]
    taken = has_target & (((owner >= 0) & (owner != world.collective)) | ~world.active[t])
    taken_here = taken & (in_hub_favouring | (world.state == S.C) | (world.state == S.I))
    drop = np.flatnonzero(ordered | taken_here)
    world.set_state(drop, S.U_I)
