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


@dataclass(frozen=True)
class Inbox:
    """The messages of one step, already addressed: parallel arrays over messages."""

    sender: np.ndarray
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
    first = np.flatnonzero(np.concatenate(([True], sorted_receivers[1:] != sorted_receivers[:-1])))
    counts = np.diff(np.append(first, sorted_receivers.size))
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
    senders = np.flatnonzero(in_hub & S.SENDING[world.state])
    rate = np.full(senders.size, params.message_rate)
    if params.m2_uses(model, "modulation"):
        favouring = world.state[senders] == S.F_I
        t = world.target[senders[favouring]]
        rate[favouring] *= frequency_modulation(
            world.hub_distance[world.collective[senders[favouring]], t], params
        )
    n_messages = rng.poisson(rate * params.dt_s)
    senders = np.repeat(senders, n_messages)
    receivers = find_neighbours(world, senders, in_hub, params, rng)
    # A message between two uncommitted agents changes nothing: an uncommitted
    # agent's streak is never used (any change of decision state clears it)
    # and only initiating agents count silence. Dropping them is exact.
    ok = receivers >= 0
    ok[ok] = ~((world.state[senders[ok]] == S.U_I) & (world.state[receivers[ok]] == S.U_I))
    senders, receivers = senders[ok], receivers[ok]
    return Inbox(
        sender=senders,
        receiver=receivers,
        sender_state=world.state[senders].copy(),
        sender_target=world.target[senders].copy(),
        sender_key=S.decision_key(world.state[senders], world.target[senders]),
        sender_estimate=world.estimate[senders].copy(),
    )


def frequency_modulation(distance_m: np.ndarray, params: Params) -> np.ndarray:
    """M2's M_i = d_i / d_min: farther targets recruit and inhibit more often.

    d_min and the treatment of sites beyond d_max follow the chosen reading.
    """
    return params.m2_distance(distance_m) / params.m2_d_min_m


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
    size = np.bincount(area[members], minlength=2 * world.n_collectives)
    start = np.cumsum(size) - size
    sender_area = area[senders]
    # Draw every candidate at once: (messages, draws); keep the first within range.
    draws = rng.random((senders.size, params.neighbour_draws))
    pick = members[start[sender_area, None] + (draws * size[sender_area, None]).astype(np.int64)]
    dx = world.pos[pick, 0] - world.pos[senders, 0, None]
    dy = world.pos[pick, 1] - world.pos[senders, 1, None]
    good = (pick != senders[:, None]) & (dx * dx + dy * dy <= params.comm_range_m**2)
    found = good.any(axis=1)
    first = np.argmax(good, axis=1)
    receivers[found] = pick[found, first[found]]
    return receivers


def deliver(
    world: World, params: Params, model: str, inbox: Inbox, messages: np.ndarray, draw: np.ndarray
) -> np.ndarray:
    """Apply one message to each receiver (receivers in `messages` are distinct).

    Every rule reads the receiver's state before this message, so at most one
    rule fires per message; the new states are written back at once.
    """
    r = inbox.receiver[messages]
    s_state = inbox.sender_state[messages]
    s_target = inbox.sender_target[messages]
    state = world.state[r]
    target = world.target[r]
    world.silence[r] = 0.0

    key = S.decision_key(state, target)
    streak = np.where(key == inbox.sender_key[messages], world.streak[r] + 1, 0)
    quorum = streak >= params.quorum_k
    new_state, new_target, new_leg = state.copy(), target.copy(), world.leg[r]

    def become(
        mask: np.ndarray, code: int, to_target: np.ndarray | None = None, leg: int | None = None
    ) -> None:
        new_state[mask] = code
        if to_target is not None:
            new_target[mask] = to_target[mask]
        if leg is not None:
            new_leg[mask] = leg

    senders_by_state = np.bincount(s_state, minlength=len(S.NAMES))
    changed = np.zeros(r.size, dtype=bool)
    if senders_by_state[S.C]:  # commitment spreads to deliberating agents
        changed = (s_state == S.C) & S.DELIBERATING[state]
        become(changed, S.C, s_target)
    if senders_by_state[S.I]:  # initiation spreads
        initiate = (s_state == S.I) & (
            (state == S.U_I) | (state == S.F_I) | ((state == S.C) & (target == s_target))
        )
        become(initiate, S.I, s_target)
        changed |= initiate

    if model != "M3" and senders_by_state[S.F_I]:
        from_favouring = s_state == S.F_I
        persuaded = from_favouring & (draw < inbox.sender_estimate[messages]) & ~changed
        recruit = persuaded & (state == S.U_I)
        if world.abandon_order.any():
            recruit &= ~world.abandon_order[world.collective[r], np.maximum(s_target, 0)]
        inhibit = persuaded & S.FAVOURING_IN_HUB[state] & (target != s_target)
        become(recruit, S.F_L, s_target, S.TO_TARGET)
        become(inhibit, S.U_L, None, S.EXPLORING)
        changed |= recruit | inhibit
    finished = np.zeros(world.n_collectives, dtype=bool)
    if quorum.any():
        quorum &= ~changed
        if model != "M3":
            become(quorum & (state == S.F_I), S.C)  # F_I(i) → C(i)
        become(quorum & (state == S.C), S.I)  # C(i) → I(i)
        become(quorum & (state == S.I), S.X, None, S.TO_TARGET)  # I(i) → X(i)
        done = quorum & (state == S.D)  # D(i) quorum ends the decision
        finished[world.collective[r[done]]] = True
        changed |= quorum & (state != S.D)

    if changed.any():
        new_target[S.PHASE_OF_STATE[new_state] == 0] = -1
        streak[S.decision_key(new_state, new_target) != key] = 0
        world.state[r], world.target[r], world.leg[r] = new_state, new_target, new_leg
    world.streak[r] = streak
    return finished


def execute(world: World, agents: np.ndarray) -> None:
    """I(i) → X(i): the agent leaves to fly to the new site."""
    world.set_state(agents, S.X)
    world.leg[agents] = S.TO_TARGET


def initiating_silence(world: World, params: Params) -> None:
    """I(i) → X(i) after k/r_msg seconds without receiving any message."""
    quiet = np.flatnonzero((world.state == S.I) & (world.silence >= params.silence_limit_s))
    execute(world, quiet)
