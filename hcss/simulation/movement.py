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
from hcss.simulation.jit import internal
from hcss.simulation.params import Params
from hcss.simulation.world import Arrays, World


@njit(cache=True, inline="always")
def home(w: Arrays, i: int) -> tuple[float, float]:
    """Centre of agent i's hub area: its collective's hub, or the new site for X and D."""
    if w.state[i] >= S.X:
        t = w.target[i]
        return w.target_pos[t, 0], w.target_pos[t, 1]
    c = w.collective[i]
    return w.hub[c, 0], w.hub[c, 1]


# fdlibm's kernels of sin and cos on [-π/4, π/4] (musl's __sin.c, __cos.c) and its
# two-part π/2 for the reduction: within an ulp of libm for the angles reduced here.
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_PIO2_HI, _PIO2_LO, _TWO_OVER_PI = (
    1.57079632673412561417,
    6.07710050650619224932e-11,
    0.63661977236758134,
)
_REDUCED_EXACTLY = 2.0**19 * 1.5707963267948966  # n·π/2 exact in two parts up to n = 2^19


@njit(cache=True)
def fill_cos_sin(angles: np.ndarray, cos_out: np.ndarray, sin_out: np.ndarray) -> None:
    """cos and sin of every angle, in a loop without calls that the compiler vectorises.

    Three to four times faster than a libm call per angle (every walker turns
    every step): reduce by π/2, evaluate fdlibm's polynomials, then pick and
    sign by quadrant. Angles too large to reduce this way go to libm.
    """
    for i in range(angles.size):
        a = angles[i]
        n = np.rint(a * _TWO_OVER_PI)
        x = (a - n * _PIO2_HI) - n * _PIO2_LO
        z = x * x
        w = z * z
        sine = x + z * x * (_S1 + z * (_S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)))
        r = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
        half = 0.5 * z
        one_less = 1.0 - half
        cosine = one_less + (((1.0 - one_less) - half) + z * r)
        quadrant = np.int64(n) & 3  # 0: (c, s), 1: (-s, c), 2: (-c, -s), 3: (s, -c)
        swap = (quadrant & 1) == 1
        cos_out[i] = (1.0 - 2.0 * (((quadrant + 1) >> 1) & 1)) * (sine if swap else cosine)
        sin_out[i] = (1.0 - 2.0 * ((quadrant >> 1) & 1)) * (cosine if swap else sine)
    for i in range(angles.size):
        if not abs(angles[i]) < _REDUCED_EXACTLY:
            cos_out[i], sin_out[i] = math.cos(angles[i]), math.sin(angles[i])


@internal
def move_kernel(
    w: Arrays, k: Constants, at_target: np.ndarray, at_hub: np.ndarray
) -> tuple[int, int]:
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
    # Every walker's turn, drawn and turned into a rotation in tight loops before the pass.
    turns = np.empty(n_walkers)
    stream.fill_normals(w.stream, turns)
    for j in range(n_walkers):
        turns[j] *= k.turn_sd_rad
    cos_turns, sin_turns = np.empty(n_walkers), np.empty(n_walkers)
    fill_cos_sin(turns, cos_turns, sin_turns)
    n_walkers = 0
    for i in range(state.size):
        if state[i] >= S.X:  # home: the collective's hub, or the new site for X and D
            hx, hy = target_pos[target[i], 0], target_pos[target[i], 1]
        else:
            hx, hy = hub[collective[i], 0], hub[collective[i], 1]
        px, py = pos[i, 0], pos[i, 1]
        if leg[i] <= S.EXPLORING:  # correlated random walk in the hub area or exploration disc
            cos_turn, sin_turn = cos_turns[n_walkers], sin_turns[n_walkers]
            n_walkers += 1
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
def scatter_kernel(
    pos: np.ndarray,
    heading: np.ndarray,
    s: np.ndarray,
    home_x: np.ndarray,
    home_y: np.ndarray,
    hub_radius_m: float,
    agents: np.ndarray,
) -> None:
    """Place agents uniformly in the disc around their home with random headings.

    Takes only the arrays it needs, not the world's `Arrays`: Python calls it,
    and unboxing 27 arrays is as much code to compile as the rule itself.
    """
    for i in agents:
        radius = hub_radius_m * math.sqrt(stream.uniform(s))
        angle = 2.0 * math.pi * stream.uniform(s)
        pos[i, 0] = home_x[i] + radius * math.cos(angle)
        pos[i, 1] = home_y[i] + radius * math.sin(angle)
        direction = 2.0 * math.pi * stream.uniform(s)
        heading[i, 0], heading[i, 1] = math.cos(direction), math.sin(direction)


def scatter_in_hub(world: World, agents: np.ndarray, k: Constants) -> None:
    home_x, home_y = world.home_xy()
    scatter_kernel(
        world.pos,
        world.heading,
        world.stream,
        home_x,
        home_y,
        k.hub_radius_m,
        np.asarray(agents, dtype=np.int64),
    )


def move(world: World, params: Params) -> tuple[np.ndarray, np.ndarray]:
    """Advance every agent one step; the agents that reached their target and their hub."""
    at_target = np.empty(world.state.size, dtype=np.int64)
    at_hub = np.empty(world.state.size, dtype=np.int64)
    n_target, n_hub = _move(world.kernel_arrays(), constants_for(params, "M1"), at_target, at_hub)
    return at_target[:n_target], at_hub[:n_hub]


# The kernel's entry from Python (the kernel itself has none: jit.internal).
@njit(cache=True)
def _move(w: Arrays, k: Constants, at_target: np.ndarray, at_hub: np.ndarray) -> tuple[int, int]:
    return move_kernel(w, k, at_target, at_hub)
