"""Movement (spec §1): correlated random walks in discs and straight flights.

Agents in the hub area and explorers turn by a wrapped-normal angle each step
and are reflected at the edge of their disc. Agents travelling between hub and
target fly straight at constant speed. Compiled (numba): one pass over the
agents, no temporary arrays.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from hcss.simulation import states as S
from hcss.simulation import stream
from hcss.simulation.constants import Constants, constants_for
from hcss.simulation.params import Params
from hcss.simulation.world import Arrays, World


@njit(cache=True, inline="always")
def home(w, i):
    """Centre of agent i's hub area: its collective's hub, or the new site for X and D."""
    if w.state[i] >= S.X:
        t = w.target[i]
        return w.target_pos[t, 0], w.target_pos[t, 1]
    c = w.collective[i]
    return w.hub[c, 0], w.hub[c, 1]


@njit(cache=True)
def move_kernel(w: Arrays, k: Constants, at_target, at_hub):
    """Advance every agent one step.

    Fills `at_target` and `at_hub` with the agents that reached their target or
    their hub area this step and returns how many of each; the rules decide
    what they do there.
    """
    step = k.speed_mps * k.dt_s
    n_target = 0
    n_hub = 0
    n_walkers = 0
    for i in range(w.state.size):
        n_walkers += w.leg[i] <= S.EXPLORING
    turns = np.empty(n_walkers)  # every walker's turning deviate, drawn in one tight loop
    stream.fill_normals(w.stream, turns)
    n_walkers = 0
    for i in range(w.state.size):
        hx, hy = home(w, i)
        leg = w.leg[i]
        if leg <= S.EXPLORING:  # correlated random walk in the hub area or the exploration disc
            heading = w.heading[i] + k.turn_sd_rad * turns[n_walkers]
            n_walkers += 1
            dx, dy = math.cos(heading), math.sin(heading)
            x = w.pos[i, 0] + step * dx
            y = w.pos[i, 1] + step * dy
            radius = k.hub_radius_m if leg == S.AT_HUB else k.exploration_range_m
            ox, oy = x - hx, y - hy
            distance2 = ox * ox + oy * oy
            if distance2 > radius * radius:  # mirror the overshoot and the radial heading
                distance = math.sqrt(distance2)
                nx, ny = ox / distance, oy / distance
                dot = dx * nx + dy * ny
                back = min(max(2.0 * radius - distance, 0.0), radius)
                x, y = hx + nx * back, hy + ny * back
                heading = math.atan2(dy - 2.0 * dot * ny, dx - 2.0 * dot * nx)
            w.pos[i, 0], w.pos[i, 1], w.heading[i] = x, y, heading
        else:  # straight flight towards the target or the hub
            to_target = leg == S.TO_TARGET
            if to_target:
                gx = w.target_pos[w.target[i], 0] - w.pos[i, 0]
                gy = w.target_pos[w.target[i], 1] - w.pos[i, 1]
            else:
                gx, gy = hx - w.pos[i, 0], hy - w.pos[i, 1]
            distance = math.sqrt(gx * gx + gy * gy)
            advance = min(step, distance)
            if distance > 0.0:
                w.pos[i, 0] += gx * advance / distance
                w.pos[i, 1] += gy * advance / distance
            remaining = distance - advance
            if to_target and remaining <= 1e-9:
                at_target[n_target] = i
                n_target += 1
            elif not to_target and remaining <= k.hub_radius_m:
                at_hub[n_hub] = i
                n_hub += 1
            else:
                continue
            # Arriving agents keep their flight direction as the heading of their next walk.
            w.heading[i] = math.atan2(gy, gx)
    return n_target, n_hub


@njit(cache=True)
def scatter_kernel(w: Arrays, k: Constants, agents):
    """Place agents uniformly in their hub disc with random headings."""
    for i in agents:
        radius = k.hub_radius_m * math.sqrt(stream.uniform(w.stream))
        angle = 2.0 * math.pi * stream.uniform(w.stream)
        hx, hy = home(w, i)
        w.pos[i, 0] = hx + radius * math.cos(angle)
        w.pos[i, 1] = hy + radius * math.sin(angle)
        w.heading[i] = 2.0 * math.pi * stream.uniform(w.stream)


def scatter_in_hub(world: World, agents: np.ndarray, k: Constants) -> None:
    scatter_kernel(world.kernel_arrays(), k, np.asarray(agents, dtype=np.int64))


def move(world: World, params: Params) -> tuple[np.ndarray, np.ndarray]:
    """Advance every agent one step; the agents that reached their target and their hub."""
    at_target = np.empty(world.state.size, dtype=np.int64)
    at_hub = np.empty(world.state.size, dtype=np.int64)
    n_target, n_hub = move_kernel(
        world.kernel_arrays(), constants_for(params, "M1"), at_target, at_hub
    )
    return at_target[:n_target], at_hub[:n_hub]
