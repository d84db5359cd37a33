"""Movement (spec §1): correlated random walks in discs and straight flights.

Agents in the hub area and explorers turn by a wrapped-normal angle each step
and are reflected at the edge of their disc. Agents travelling between hub and
target fly straight at constant speed.
"""

from __future__ import annotations

import numpy as np

from hcss.simulation import states as S
from hcss.simulation.params import Params
from hcss.simulation.world import World


def move(world: World, params: Params, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Advance every agent one step.

    Returns the indices of agents that reached their target this step and of
    agents that reached their hub area; the rules decide what they do there.
    """
    step = params.speed_mps * params.dt_s
    hx, hy = world.home_xy()
    leg = world.leg
    x, y = world.pos[:, 0].copy(), world.pos[:, 1].copy()

    # Correlated random walk for agents in the hub area and explorers.
    walking = np.flatnonzero(leg <= S.EXPLORING)  # AT_HUB or EXPLORING
    heading = world.heading[walking] + rng.normal(0.0, params.turn_sd_rad, walking.size)
    x[walking] += step * np.cos(heading)
    y[walking] += step * np.sin(heading)
    _reflect(x, y, heading, walking, leg, hx, hy, params)
    world.heading[walking] = heading

    # Straight flights: towards the target, or towards the hub.
    flying = np.flatnonzero(leg >= S.TO_TARGET)
    to_target = leg[flying] == S.TO_TARGET
    goal_x, goal_y = hx[flying], hy[flying]
    aim = world.target[flying[to_target]]
    goal_x[to_target] = world.target_pos[aim, 0]
    goal_y[to_target] = world.target_pos[aim, 1]
    gx, gy = goal_x - x[flying], goal_y - y[flying]
    distance = np.sqrt(gx * gx + gy * gy)
    advance = np.minimum(step, distance)
    scale = np.divide(advance, distance, out=np.zeros_like(distance), where=distance > 0)
    x[flying] += gx * scale
    y[flying] += gy * scale
    world.pos = np.stack((x, y), axis=1)

    remaining = distance - advance
    arrived = np.where(to_target, remaining <= 1e-9, remaining <= params.hub_radius_m)
    landed = flying[arrived]
    # Arriving agents keep their flight direction as the heading of their next walk.
    world.heading[landed] = np.arctan2(gy[arrived], gx[arrived])
    return landed[to_target[arrived]], landed[~to_target[arrived]]


def _reflect(
    x: np.ndarray,
    y: np.ndarray,
    heading: np.ndarray,
    walking: np.ndarray,
    leg: np.ndarray,
    hx: np.ndarray,
    hy: np.ndarray,
    params: Params,
) -> None:
    """Reflect walkers that left their disc: mirror the overshoot and the radial heading.

    `heading` is indexed like `walking`; `x`, `y`, `leg`, `hx`, `hy` over all agents.
    """
    radius = np.where(leg[walking] == S.AT_HUB, params.hub_radius_m, params.exploration_range_m)
    ox = x[walking] - hx[walking]
    oy = y[walking] - hy[walking]
    distance2 = ox * ox + oy * oy
    out = np.flatnonzero(distance2 > radius * radius)
    if out.size == 0:
        return
    agents = walking[out]
    distance = np.sqrt(distance2[out])
    nx, ny = ox[out] / distance, oy[out] / distance
    dx, dy = np.cos(heading[out]), np.sin(heading[out])
    dot = dx * nx + dy * ny
    r = radius[out]
    back = np.minimum(np.maximum(2.0 * r - distance, 0.0), r)
    x[agents] = hx[agents] + nx * back
    y[agents] = hy[agents] + ny * back
    heading[out] = np.arctan2(dy - 2.0 * dot * ny, dx - 2.0 * dot * nx)


def scatter_in_hub(
    world: World, agents: np.ndarray, params: Params, rng: np.random.Generator
) -> None:
    """Place agents uniformly in their hub disc with random headings."""
    n = agents.size
    radius = params.hub_radius_m * np.sqrt(rng.random(n))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    hx, hy = world.home_xy()
    world.pos[agents, 0] = hx[agents] + radius * np.cos(angle)
    world.pos[agents, 1] = hy[agents] + radius * np.sin(angle)
    world.heading[agents] = rng.uniform(0.0, 2.0 * np.pi, n)
