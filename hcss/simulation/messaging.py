"""Messages in the hub area: recruitment, cross-inhibition and quorum (spec §4, §7).

Every agent in an interactive hub state sends messages as a Poisson process
(rate r_msg, times M_i in M2 for agents favouring i). Each message goes to one
random neighbour of its collective within the communication range in the same
hub area. Receivers then apply the rules one message at a time, in a random
order, exactly as if the messages had arrived one after another: a plain
compiled loop over the messages, each applied to the state the previous one
left. Senders speak from the state they had when the step's messages were
composed.

Neighbours are found by rejection sampling within each hub area: a sender
draws a random agent of its hub area and keeps it if it is within range. This
is exact (uniform over the sender's neighbours) and O(messages); a sender that
finds nobody in `params.neighbour_draws` draws sends nothing this step
[choice].
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from hcss.simulation import states as S
from hcss.simulation import stream
from hcss.simulation.constants import Constants, constants_for
from hcss.simulation.params import Params
from hcss.simulation.rules import frequency_modulation  # noqa: F401 - part of this rule's API
from hcss.simulation.world import Arrays, World, set_state_one

M3 = 3


@dataclass(frozen=True)
class Inbox:
    """The messages of one step, already addressed: parallel arrays over messages."""

    sender: np.ndarray
    receiver: np.ndarray
    sender_state: np.ndarray
    sender_target: np.ndarray
    sender_estimate: np.ndarray


@njit(cache=True)
def decision_key(state, target):
    """One integer for a decision state: phase and target (uncommitted agents have target -1)."""
    return S.PHASE_OF_STATE[state] * 4096 + target + 1


@njit(cache=True)
def compose_kernel(w: Arrays, k: Constants):
    """Who sends how many messages to whom this step: (sender, receiver) arrays."""
    n_agents = w.state.size
    n_areas = 2 * w.hub.shape[0]
    # Members of each hub area (its collective's hub, or for D agents the new site).
    area = np.empty(n_agents, dtype=np.int64)
    size = np.zeros(n_areas + 1, dtype=np.int64)
    listeners = np.zeros(n_areas, dtype=np.int64)  # members a U_I sender can affect
    for i in range(n_agents):
        if w.leg[i] == S.AT_HUB:
            area[i] = w.collective[i] + (n_areas // 2) * (w.state[i] == S.D)
            size[area[i] + 1] += 1
            listeners[area[i]] += w.state[i] != S.U_I
        else:
            area[i] = -1
    start = np.cumsum(size)  # start[a] .. start[a + 1] are area a's members
    fill = start[:-1].copy()
    members = np.empty(start[-1], dtype=np.int64)
    for i in range(n_agents):
        if area[i] >= 0:
            members[fill[area[i]]] = i
            fill[area[i]] += 1

    capacity = 64 + 4 * start[-1]
    sender = np.empty(capacity, dtype=np.int64)
    receiver = np.empty(capacity, dtype=np.int64)
    n = 0
    range2 = k.comm_range_m * k.comm_range_m
    base_limit = math.exp(-k.message_rate * k.dt_s)  # most senders share the base rate
    for i in range(n_agents):
        if area[i] < 0 or not S.SENDING[w.state[i]]:
            continue
        if w.state[i] == S.U_I and listeners[area[i]] == 0:
            continue  # every message it could send would be dropped below
        if k.modulation and w.state[i] == S.F_I:
            rate = k.message_rate * w.send_factor[w.collective[i], w.target[i]]
            count = stream.poisson(w.stream, rate * k.dt_s)
        elif k.message_rate * k.dt_s <= 20.0:
            count = stream.poisson_below(w.stream, base_limit)
        else:
            count = stream.poisson(w.stream, k.message_rate * k.dt_s)
        first, n_members = start[area[i]], start[area[i] + 1] - start[area[i]]
        for _ in range(count):
            found = -1
            for _draw in range(k.neighbour_draws):
                j = members[first + stream.below(w.stream, n_members)]
                dx = w.pos[j, 0] - w.pos[i, 0]
                dy = w.pos[j, 1] - w.pos[i, 1]
                if j != i and dx * dx + dy * dy <= range2:
                    found = j
                    break
            # A message between two uncommitted agents changes nothing: an
            # uncommitted agent's streak is never used (any change of decision
            # state clears it) and only initiating agents count silence.
            if found < 0 or (w.state[i] == S.U_I and w.state[found] == S.U_I):
                continue
            if n == sender.size:
                sender = np.concatenate((sender, np.empty(n, dtype=np.int64)))
                receiver = np.concatenate((receiver, np.empty(n, dtype=np.int64)))
            sender[n] = i
            receiver[n] = found
            n += 1
    return sender[:n], receiver[:n]


@njit(cache=True)
def deliver_one(w: Arrays, k: Constants, r, s_state, s_target, s_estimate, draw, finished):
    """Apply one message to its receiver r.

    Every rule reads the receiver's state before this message, so at most one
    rule fires per message. A D(i) quorum marks the receiver's collective in
    `finished` (the first such transition ends its decision).
    """
    state, target = w.state[r], w.target[r]
    w.silence[r] = 0.0
    key = decision_key(state, target)
    streak = w.streak[r] + 1 if key == decision_key(s_state, s_target) else 0
    new_state, new_target, new_leg = state, target, w.leg[r]
    changed = False
    if s_state == S.C and S.DELIBERATING[state]:  # commitment spreads to deliberating agents
        new_state, new_target, changed = S.C, s_target, True
    elif s_state == S.I and (
        state == S.U_I or state == S.F_I or (state == S.C and target == s_target)
    ):  # initiation spreads
        new_state, new_target, changed = S.I, s_target, True
    elif k.model != M3 and s_state == S.F_I and draw < s_estimate:
        if state == S.U_I and not w.abandon_order[w.collective[r], s_target]:  # recruitment
            new_state, new_target, new_leg, changed = S.F_L, s_target, S.TO_TARGET, True
        elif S.FAVOURING_IN_HUB[state] and target != s_target:  # cross-inhibition
            new_state, new_target, new_leg, changed = S.U_L, -1, S.EXPLORING, True
    if streak >= k.quorum_k and not changed:
        if k.model != M3 and state == S.F_I:  # F_I(i) → C(i)
            new_state = S.C
        elif state == S.C:  # C(i) → I(i)
            new_state = S.I
        elif state == S.I:  # I(i) → X(i)
            new_state, new_leg = S.X, S.TO_TARGET
        elif state == S.D:  # a D(i) quorum ends the decision
            finished[w.collective[r]] = True
    set_state_one(w.state, w.target, w.streak, r, new_state, new_target)  # clears on a change
    if decision_key(w.state[r], w.target[r]) == key:
        w.streak[r] = streak
    w.leg[r] = new_leg


@njit(cache=True)
def exchange_kernel(w: Arrays, k: Constants, finished):
    """Send, deliver and apply one step of messages, in a random order.

    Marks in `finished` the collectives in which a D(i) quorum was reached.
    """
    for i in range(w.silence.size):
        w.silence[i] += k.dt_s
    sender, receiver = compose_kernel(w, k)
    n = sender.size
    s_state = np.empty(n, dtype=np.int8)
    s_target = np.empty(n, dtype=np.int32)
    s_estimate = np.empty(n, dtype=np.float64)
    for m in range(n):  # senders speak from their state at composition
        s_state[m] = w.state[sender[m]]
        s_target[m] = w.target[sender[m]]
        s_estimate[m] = w.estimate[sender[m]]
    order = np.arange(n)
    for m in range(n - 1, 0, -1):  # Fisher-Yates shuffle
        j = stream.below(w.stream, m + 1)
        order[m], order[j] = order[j], order[m]
    for m in order:
        draw = stream.uniform(w.stream) if s_state[m] == S.F_I else 1.0
        deliver_one(w, k, receiver[m], s_state[m], s_target[m], s_estimate[m], draw, finished)


@njit(cache=True)
def initiating_silence_kernel(w: Arrays, k: Constants):
    """I(i) → X(i) after k/r_msg seconds without receiving any message."""
    for i in range(w.state.size):
        if w.state[i] == S.I and w.silence[i] >= k.silence_limit_s:
            set_state_one(w.state, w.target, w.streak, i, S.X, w.target[i])
            w.leg[i] = S.TO_TARGET


# ------------------------------------------------------- Python entry points
def compose(world: World, params: Params, model: str) -> Inbox:
    """The messages one step would send (advances the world's stream)."""
    sender, receiver = compose_kernel(world.kernel_arrays(), constants_for(params, model))
    return Inbox(
        sender=sender,
        receiver=receiver,
        sender_state=world.state[sender].copy(),
        sender_target=world.target[sender].copy(),
        sender_estimate=world.estimate[sender].copy(),
    )


def deliver(
    world: World, params: Params, model: str, inbox: Inbox, messages: np.ndarray, draw: np.ndarray
) -> np.ndarray:
    """Apply the given messages of an inbox in order, with the given recruitment draws.

    Returns the collectives in which a D(i) quorum was reached.
    """
    finished = np.zeros(world.n_collectives, dtype=np.bool_)
    _deliver_kernel(
        world.kernel_arrays(),
        constants_for(params, model),
        inbox.receiver[messages].astype(np.int64),
        inbox.sender_state[messages].astype(np.int8),
        inbox.sender_target[messages].astype(np.int32),
        inbox.sender_estimate[messages].astype(np.float64),
        np.asarray(draw, dtype=np.float64),
        finished,
    )
    return finished


@njit(cache=True)
def _deliver_kernel(w, k, receiver, s_state, s_target, s_estimate, draw, finished):
    for m in range(receiver.size):
        deliver_one(w, k, receiver[m], s_state[m], s_target[m], s_estimate[m], draw[m], finished)
