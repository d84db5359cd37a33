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
    what they do there. Headings are unit vectors, so a reflection or an
    arrival sets one without trigonometry.
    """
    # The arrays in locals: the loop then reads them without going through `w`.
    state, leg, target, collective = w.state, w.leg, w.target, w.collective
    pos, heading, hub, target_pos = w.pos, w.heading, w.hub, w.target_pos
    step = k.speed_mps * k.dt_s
    n_target = 0
    n_hub = 0
    n_walkers = 0
    for i in range(state.size):
        n_walkers += leg[i] <= S.EXPLORING
    turns = np.empty(n_walkers)  # every walker's turning deviate, drawn in one tight loop
    stream.fill_normals(w.stream, turns)
    n_walkers = 0
    for i in range(state.size):
        if state[i] >= S.X:  # home: the collective's hub, or the new site for X and D
            hx, hy = target_pos[target[i], 0], target_pos[target[i], 1]
        else:
            hx, hy = hub[collective[i], 0], hub[collective[i], 1]
        px, py = pos[i, 0], pos[i, 1]
        if leg[i] <= S.EXPLORING:  # correlated random walk in the hub area or exploration disc
            turn = k.turn_sd_rad * turns[n_walkers]
            n_walkers += 1
            cos_turn, sin_turn = math.cos(turn), math.sin(turn)
            ux, uy = heading[i, 0], heading[i, 1]
            dx, dy = ux * cos_turn - uy * sin_turn, ux * sin_turn + uy * cos_turn
            x, y = px + step * dx, py + step * dy
            radius = k.hub_radius_m if leg[i] == S.AT_HUB else k.exploration_range_m
            ox, oy = x - hx, y - hy
            distance2 = ox * ox + oy * oy
            if distance2 > radius * radius:  # mirror the overshoot and the radial heading
                distance = math.sqrt(distance2)
                nx, ny = ox / distance, oy / distance
                dot = dx * nx + dy * ny
                back = min(max(2.0 * radius - distance, 0.0), radius)
                x, y = hx + nx * back, hy + ny * back
                dx, dy = dx - 2.0 * dot * nx, dy - 2.0 * dot * ny
            pos[i, 0], pos[i, 1] = x, y
            heading[i, 0], heading[i, 1] = dx, dy
            continue
        # straight flight towards the target or the hub
        to_target = leg[i] == S.TO_TARGET
        if to_target:
            gx, gy = target_pos[target[i], 0] - px, target_pos[target[i], 1] - py
        else:
            gx, gy = hx - px, hy - py
        distance = math.sqrt(gx * gx + gy * gy)
        advance = min(step, distance)
        if distance > 0.0:
            pos[i, 0] = px + gx * advance / distance
            pos[i, 1] = py + gy * advance / distance
        remaining = distance - advance
        if to_target and remaining <= 1e-9:
            at_target[n_target] = i
            n_target += 1
        elif not to_target and remaining <= k.hub_radius_m:
            at_hub[n_hub] = i
            n_hub += 1
        else:
            continue
        if distance > 0.0:  # arriving agents keep their flight direction for their next walk
            heading[i, 0], heading[i, 1] = gx / distance, gy / distance
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
        heading = 2.0 * math.pi * stream.uniform(w.stream)
        w.heading[i, 0], w.heading[i, 1] = math.cos(heading), math.sin(heading)


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
