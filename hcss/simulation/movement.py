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
    home = world.home()
    _walk(world, params, rng, home, step)
    at_target = _fly(world, world.leg == S.TO_TARGET, _goal_targets(world), step, 0.0)
    at_hub = _fly(world, world.leg == S.TO_HUB, home, step, params.hub_radius_m)
    return at_target, at_hub


def scatter_in_hub(world: World, agents: np.ndarray, params: Params, rng: np.random.Generator) -> None:
    """Place agents uniformly in their hub disc with random headings."""
    n = agents.size
    radius = params.hub_radius_m * np.sqrt(rng.random(n))
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    world.pos[agents] = world.home()[agents] + np.column_stack((radius * np.cos(angle), radius * np.sin(angle)))
    world.heading[agents] = rng.uniform(0.0, 2.0 * np.pi, n)


def _goal_targets(world: World) -> np.ndarray:
    goal = np.zeros_like(world.pos)
    flying = (world.leg == S.TO_TARGET) & (world.target >= 0)
    goal[flying] = world.target_pos[world.target[flying]]
    return goal


def _walk(world: World, params: Params, rng: np.random.Generator, home: np.ndarray, step: float) -> None:
    walking = np.flatnonzero((world.leg == S.AT_HUB) | (world.leg == S.EXPLORING))
    if walking.size == 0:
        return
    heading = world.heading[walking] + rng.normal(0.0, params.turn_sd_rad, walking.size)
    direction = np.column_stack((np.cos(heading), np.sin(heading)))
    pos = world.pos[walking] + step * direction
    radius = np.where(world.leg[walking] == S.AT_HUB, params.hub_radius_m, params.exploration_range_m)
    centre = home[walking]
    offset = pos - centre
    distance = np.hypot(offset[:, 0], offset[:, 1])
    outside = distance > radius
    if outside.any():
        # Reflect the radial component of the heading and mirror the overshoot back inside.
        normal = offset[outside] / distance[outside, None]
        d = direction[outside]
        d = d - 2.0 * np.sum(d * normal, axis=1, keepdims=True) * normal
        back = np.clip(2.0 * radius[outside] - distance[outside], 0.0, radius[outside])
        pos[outside] = centre[outside] + normal * back[:, None]
        heading[outside] = np.arctan2(d[:, 1], d[:, 0])
    world.pos[walking] = pos
    world.heading[walking] = np.mod(heading, 2.0 * np.pi)


def _fly(world: World, flying: np.ndarray, goal: np.ndarray, step: float, arrive_within: float) -> np.ndarray:
    agents = np.flatnonzero(flying)
    if agents.size == 0:
        return agents
    offset = goal[agents] - world.pos[agents]
    distance = np.hypot(offset[:, 0], offset[:, 1])
    advance = np.minimum(step, distance)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(distance[:, None] > 0, offset / distance[:, None], 0.0)
    world.pos[agents] += unit * advance[:, None]
    world.heading[agents] = np.where(distance > 0, np.arctan2(unit[:, 1], unit[:, 0]), world.heading[agents])
    return agents[distance - advance <= arrive_within]
