"""Messages in the hub area: recruitment, cross-inhibition and quorum (spec §4, §7).

Every agent in an interactive hub state sends messages as a Poisson process
(rate r_msg, times M_i in M2 for agents favouring i). Each message goes to one
random neighbour of its collective within the communication range in the same
hub area. Receivers then apply the rules one message at a time, in a random
order, exactly as if the messages had arrived one after another.

Neighbours are found by rejection sampling within each hub area: a sender
draws a random agent of its hub area and keeps it if it is within range. This
is exact (uniform over the sender's neighbours) and O(messages); a sender that
finds nobody in `params.neighbour_draws` draws sends nothing this step
[choice]. A pairwise distance matrix or a k-d tree per collective would cost
more than the rest of the step at our sizes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hcss.simulation import states as S
from hcss.simulation.params import Params
from hcss.simulation.world import World

SENDING_STATES = np.array([S.U_I, S.F_I, S.C, S.I, S.D], dtype=np.int8)


@dataclass(frozen=True)
class Inbox:
    """The messages of one step, already addressed: parallel arrays over messages."""

    receiver: np.ndarray
    sender_state: np.ndarray
    sender_target: np.ndarray
    sender_key: np.ndarray
    sender_estimate: np.ndarray


def exchange(world: World, params: Params, rng: np.random.Generator, model: str) -> np.ndarray:
    """Send, deliver and apply one step of messages.

    Returns the collectives in which a D(i) quorum was reached this step (the
    first such transition ends their decision).
    """
    world.silence += params.dt_s
    inbox = compose(world, params, rng, model)
    finished = np.zeros(world.n_collectives, dtype=bool)
    if inbox.receiver.size == 0:
        return finished
    order = rng.permutation(inbox.receiver.size)
    receivers = inbox.receiver[order]
    # Rank each message among those to the same receiver; round r delivers the r-th.
    by_receiver = np.argsort(receivers, kind="stable")
    sorted_receivers = receivers[by_receiver]
    first = np.r_[0, np.flatnonzero(np.diff(sorted_receivers)) + 1]
    counts = np.diff(np.r_[first, sorted_receivers.size])
    rank = np.empty(receivers.size, dtype=np.int64)
    rank[by_receiver] = np.arange(receivers.size) - np.repeat(first, counts)
    draws = rng.random(receivers.size)
    for r in range(int(rank.max()) + 1):
        this_round = order[rank == r]
        finished |= deliver(world, params, model, inbox, this_round, draws[rank == r])
    return finished


def compose(world: World, params: Params, rng: np.random.Generator, model: str) -> Inbox:
    """Who sends how many messages to whom this step."""
    in_hub = world.leg == S.AT_HUB
    senders = np.flatnonzero(in_hub & np.isin(world.state, SENDING_STATES))
    rate = np.full(senders.size, params.message_rate)
    if model == "M2":
        favouring = world.state[senders] == S.F_I
        t = world.target[senders[favouring]]
        rate[favouring] *= frequency_modulation(
            world.hub_distance[world.collective[senders[favouring]], t], params
        )
    n_messages = rng.poisson(rate * params.dt_s)
    senders = np.repeat(senders, n_messages)
    receivers = find_neighbours(world, senders, in_hub, params, rng)
    ok = receivers >= 0
    senders, receivers = senders[ok], receivers[ok]
    return Inbox(
        receiver=receivers,
        sender_state=world.state[senders].copy(),
        sender_target=world.target[senders].copy(),
        sender_key=S.decision_key(world.state[senders], world.target[senders]),
        sender_estimate=world.estimate[senders].copy(),
    )


def frequency_modulation(distance_m: np.ndarray, params: Params) -> np.ndarray:
    """M2's M_i = d_i / d_min: farther targets recruit and inhibit more often."""
    return distance_m / params.site_d_min_m


def hub_area(world: World) -> np.ndarray:
    """Which hub area an agent is in: its collective's hub, or (D agents) the new site."""
    return world.collective.astype(np.int64) + world.n_collectives * (world.state == S.D)


def find_neighbours(
    world: World, senders: np.ndarray, in_hub: np.ndarray, params: Params, rng: np.random.Generator
) -> np.ndarray:
    """One random neighbour within range in the sender's hub area, or -1."""
    receivers = np.full(senders.size, -1, dtype=np.int64)
    if senders.size == 0:
        return receivers
    members = np.flatnonzero(in_hub)
    area = hub_area(world)
    members = members[np.argsort(area[members], kind="stable")]
    n_areas = 2 * world.n_collectives
    size = np.bincount(area[members], minlength=n_areas)
    start = np.r_[0, np.cumsum(size)[:-1]]
    sender_area = area[senders]
    pending = np.arange(senders.size)
    range2 = params.comm_range_m**2
    for _ in range(params.neighbour_draws):
        if pending.size == 0:
            break
        a = sender_area[pending]
        pick = members[start[a] + (rng.random(pending.size) * size[a]).astype(np.int64)]
        offset = world.pos[pick] - world.pos[senders[pending]]
        good = (pick != senders[pending]) & (np.einsum("ij,ij->i", offset, offset) <= range2)
        receivers[pending[good]] = pick[good]
        pending = pending[~good]
    return receivers


def deliver(
    world: World, params: Params, model: str, inbox: Inbox, messages: np.ndarray, draw: np.ndarray
) -> np.ndarray:
    """Apply one message to each receiver (receivers in `messages` are distinct)."""
    r = inbox.receiver[messages]
    s_state = inbox.sender_state[messages]
    s_target = inbox.sender_target[messages]
    state = world.state[r]
    target = world.target[r]
    world.silence[r] = 0.0

    same = S.decision_key(state, target) == inbox.sender_key[messages]
    world.streak[r] = np.where(same, world.streak[r] + 1, 0)
    quorum = world.streak[r] >= params.quorum_k

    deliberating = np.isin(state, S.DELIBERATING)
    commit = (s_state == S.C) & deliberating
    initiate = (s_state == S.I) & (
        (state == S.U_I) | (state == S.F_I) | ((state == S.C) & (target == s_target))
    )
    changed = commit | initiate
    finished = np.zeros(world.n_collectives, dtype=bool)

    if model != "M3":
        allowed = ~world.abandon_order[world.collective[r], np.maximum(s_target, 0)]
        persuaded = draw < inbox.sender_estimate[messages]
        recruit = (s_state == S.F_I) & (state == S.U_I) & allowed & persuaded & ~changed
        inhibit = (
            (s_state == S.F_I)
            & np.isin(state, (S.F_I, S.F_D, S.F_R))
            & (target != s_target)
            & persuaded
            & ~changed
        )
        world.set_state(r[recruit], S.F_L, s_target[recruit])
        world.leg[r[recruit]] = S.TO_TARGET
        world.set_state(r[inhibit], S.U_L)
        world.leg[r[inhibit]] = S.EXPLORING
        changed |= recruit | inhibit
        to_commit = quorum & (state == S.F_I) & ~changed
        world.set_state(r[to_commit], S.C)
        changed |= to_commit

    world.set_state(r[commit], S.C, s_target[commit])
    world.set_state(r[initiate], S.I, s_target[initiate])
    to_initiate = quorum & (state == S.C) & ~changed
    world.set_state(r[to_initiate], S.I)
    to_execute = quorum & (state == S.I) & ~changed
    execute(world, r[to_execute])
    done = quorum & (state == S.D) & ~changed
    finished[np.unique(world.collective[r[done]])] = True
    return finished


def execute(world: World, agents: np.ndarray) -> None:
    """I(i) → X(i): the agent leaves to fly to the new site."""
    world.set_state(agents, S.X)
    world.leg[agents] = S.TO_TARGET


def initiating_silence(world: World, params: Params) -> None:
    """I(i) → X(i) after k/r_msg seconds without receiving any message."""
    quiet = np.flatnonzero((world.state == S.I) & (world.silence >= params.silence_limit_s))
    execute(world, quiet)
