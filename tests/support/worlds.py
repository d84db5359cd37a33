"""Controlled situations for the simulation's rule tests: a fresh trial whose agents we place
by hand."""

from __future__ import annotations

import numpy as np

from hcss.simulation import Params, Scenario, Simulation
from hcss.simulation import states as S
from hcss.simulation.messaging import Inbox, deliver
from hcss.simulation.world import World


def make_sim(model: str = "M1", seed: int = 3, **changes: object) -> Simulation:
    params = Params().with_changes(**changes) if changes else Params()
    return Simulation(Scenario.generate(seed, first_section="easy", params=params), model, params)


def agents_of(world: World, collective: int, n: int, start: int = 0) -> np.ndarray:
    """n agent indices of one collective."""
    first = int(np.flatnonzero(world.collective == collective)[0])
    return np.arange(first + start, first + start + n)


def place(
    world: World,
    agents: np.ndarray,
    state: int,
    target: int = -1,
    leg: int = S.AT_HUB,
    estimate: float = 0.8,
) -> None:
    """Put agents in a state at their hub (or on a leg), bypassing the rules."""
    world.state[agents] = state
    world.target[agents] = target if S.PHASE_OF_STATE[state] > 0 else -1
    world.leg[agents] = leg
    world.estimate[agents] = estimate
    world.streak[agents] = 0
    if leg == S.AT_HUB:
        world.pos[agents] = world.home()[agents]


def send(
    sim: Simulation, senders: np.ndarray, receivers: np.ndarray, draw: float | np.ndarray = 0.0
) -> np.ndarray:
    """Deliver one message from each sender to each receiver (receivers distinct), as the engine would."""
    w = sim.world
    inbox = Inbox(
        sender=np.asarray(senders),
        receiver=np.asarray(receivers),
        sender_state=w.state[senders].copy(),
        sender_target=w.target[senders].copy(),
        sender_estimate=w.estimate[senders].copy(),
    )
    messages = np.arange(len(receivers))
    draws = np.broadcast_to(np.asarray(draw, dtype=float), messages.shape).copy()
    return deliver(w, sim.params, sim.model, inbox, messages, draws)


def visible_target(sim: Simulation, collective: int = 0) -> int:
    """Index of an active target in range of the collective, made visible to the operator."""
    w = sim.world
    in_range = np.flatnonzero(
        w.active & (w.hub_distance[collective] <= sim.params.exploration_range_m)
    )
    t = int(in_range[np.argmin(w.hub_distance[collective, in_range])])
    w.report_count[t] = max(2, int(w.report_count[t]))
    w.report_sum[t] = w.report_count[t] * w.target_value[t]
    return t


def lay_out(sim: Simulation, collective: int, targets: list[tuple[float, float]]) -> None:
    """Replace the active targets by hand: [(distance from the hub, value)] along the x axis.

    Uses the first targets of the trial, which were placed around collective 0.
    """
    w = sim.world
    w.active[:] = False
    hub = w.hub[collective]
    for i, (distance, value) in enumerate(targets):
        w.active[i] = True
        w.target_pos[i] = hub + [distance, 0.0]
        w.target_value[i] = value
    w.refresh_hub_distance()
