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
    Every agent draws a turning angle each step, whether it walks or flies, so
    the generator advances by the same amount whatever the agents are doing.
    """
    step = params.speed_mps * params.dt_s
    home = world.home()
    leg = world.leg
    walking = leg <= S.EXPLORING  # AT_HUB or EXPLORING
    to_target = leg == S.TO_TARGET

    # Straight flights: towards the target, or towards the hub.
    goal = home.copy()
    goal[to_target] = world.target_pos[world.target[to_target]]
    gx = goal[:, 0] - world.pos[:, 0]
    gy = goal[:, 1] - world.pos[:, 1]
    distance = np.sqrt(gx * gx + gy * gy)
    advance = np.minimum(step, distance)

    # Correlated random walk for agents in the hub area and explorers.
    turned = world.heading + rng.normal(0.0, params.turn_sd_rad, leg.size)
    heading = np.where(walking, turned, np.arctan2(gy, gx))
    length = np.where(walking, step, advance)
    x = world.pos[:, 0] + length * np.cos(heading)
    y = world.pos[:, 1] + length * np.sin(heading)
    _reflect(x, y, heading, leg, home, params)
    world.pos = np.stack((x, y), axis=1)
    world.heading = heading

    remaining = distance - advance
    at_target = np.flatnonzero(to_target & (remaining <= 1e-9))
    at_hub = np.flatnonzero((leg == S.TO_HUB) & (remaining <= params.hub_radius_m))
    return at_target, at_hub


def _reflect(x: np.ndarray, y: np.ndarray, heading: np.ndarray, leg: np.ndarray, home: np.ndarray, params: Params) -> None:
    """Reflect walkers that left their disc: mirror the overshoot and the radial heading."""
    radius = np.array([params.hub_radius_m, params.exploration_range_m, np.inf, np.inf])[leg]
    ox = x - home[:, 0]
    oy = y - home[:, 1]
    distance2 = ox * ox + oy * oy
    outside = np.flatnonzero(distance2 > radius * radius)
    if outside.size == 0:
        return
    distance = np.sqrt(distance2[outside])
    nx, ny = ox[outside] / distance, oy[outside] / distance
    dx, dy = np.cos(heading[outside]), np.sin(heading[outside])
    dot = dx * nx + dy * ny
    r = radius[outside]
    back = np.clip(2.0 * r - distance, 0.0, r)
    x[outside] = home[outside, 0] + nx * back
    y[outside] = home[outside, 1] + ny * back
    heading[outside] = np.arctan2(dy - 2.0 * dot * ny, dx - 2.0 * dot * nx)


def scatter_in_hub(world: World, agents: np.ndarray, params: Params, rng: np.random.Generator) -> None:
    """Place agents uniformly in their hub disc with random headings."""
    n = agents.size
    radius = params.hub_radius_m * np.sqrt(rng.random(n))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    world.pos[agents] = world.home()[agents] + np.column_stack((radius * np.cos(angle), radius * np.sin(angle)))
    world.heading[agents] = rng.uniform(0.0, 2.0 * np.pi, n)


