"""Messages in the hub area: recruitment, cross-inhibition and quorum (spec §4, §7).

Every agent in an interactive hub state sends messages as a Poisson process
(rate r_msg, times M_i in M2 for agents favouring i). A message of an F_I(i)
agent has three uses, each of which may carry M_i (`Params.m2_modulation_uses`):
it counts in the receiver's quorum window (QUEUE), it may recruit (RECRUITMENT)
and it may cross-inhibit (INHIBITION). With factors f = M_i for a modulated use
and 1 otherwise, the sender sends at r·max(f) and each message keeps each use
with probability f_use/max(f) (thinning, one Poisson stream: each use's rate is
exactly r·f_use); a message that keeps no use is not sent. When every use has
the same factor no thinning draw is made, so such runs keep their stream. Each message goes to one
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
from hcss.simulation.jit import internal
from hcss.simulation.params import Params
from hcss.simulation.rules import frequency_modulation  # noqa: F401 - part of this rule's API
from hcss.simulation.world import Arrays, World, decision_changed, set_state_one, target_in

M3 = 3
# A message's uses (bits of `uses`): quorum window, recruitment, cross-inhibition.
QUEUE, RECRUITMENT, INHIBITION = 1, 2, 4
ALL_USES = QUEUE | RECRUITMENT | INHIBITION


@dataclass(frozen=True)
class Inbox:
    """The messages of one step, already addressed: parallel arrays over messages."""

    sender: np.ndarray
    receiver: np.ndarray
    sender_state: np.ndarray
    sender_target: np.ndarray
    sender_estimate: np.ndarray
    uses: np.ndarray | None = None  # int8 bits per message (QUEUE, ...); None: all uses


@njit(cache=True, inline="always")
def decision_key(state: int, target: int) -> int:
    """One integer for a decision state: phase and target (uncommitted agents have target -1)."""
    key: int = S.PHASE_OF_STATE[state] * 4096 + target + 1
    return key


@internal
def compose_kernel(w: Arrays, k: Constants) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Who sends how many messages to whom this step, and with which uses:
    (sender, receiver, uses) arrays."""
    state, leg, collective, pos = w.state, w.leg, w.collective, w.pos
    n_agents = state.size
    n_collectives = w.hub.shape[0]
    n_areas = 2 * n_collectives
    # Members of each hub area (its collective's hub, or for D agents the new site), in
    # one pass: an area holds agents of one collective only, so it gets a slot per agent
    # of a collective and area a's members are members[a * per + 0 .. a * per + size[a]].
    per = n_agents // n_collectives
    members = np.empty(n_areas * per, dtype=np.int64)
    size = np.zeros(n_areas, dtype=np.int64)
    listeners = np.zeros(n_areas, dtype=np.int64)  # members a U_I sender can affect
    in_hubs = 0
    for i in range(n_agents):
        if leg[i] == S.AT_HUB:
            a = collective[i] + n_collectives * (state[i] == S.D)
            members[a * per + size[a]] = i
            size[a] += 1
            listeners[a] += state[i] != S.U_I
            in_hubs += 1

    capacity = 64 + 4 * in_hubs
    sender = np.empty(capacity, dtype=np.int64)
    receiver = np.empty(capacity, dtype=np.int64)
    uses = np.empty(capacity, dtype=np.int8)
    n = 0
    range2 = k.comm_range_m * k.comm_range_m
    base_mean = k.message_rate * k.dt_s
    base_limit = math.exp(-base_mean)  # most senders share the base rate
    r = stream.load(w.stream)
    for a in range(n_areas):  # senders, area by area
        first, n_members = a * per, size[a]
        for i in members[first : first + n_members]:
            if not S.SENDING[state[i]]:
                continue
            if state[i] == S.U_I and listeners[a] == 0:
                continue  # every message it could send would be dropped below
            # Factors of the three uses and their maximum (thinning, module docstring).
            f_queue = f_recruit = f_inhibit = top = 1.0
            if k.modulation and state[i] == S.F_I:
                f = w.send_factor[collective[i], w.target[i]]
                f_queue = f if k.modulate_queue else 1.0
                f_recruit = f if k.modulate_recruitment else 1.0
                f_inhibit = f if k.modulate_inhibition else 1.0
                top = max(f_queue, f_recruit, f_inhibit)
                count, r = stream.poisson_count_of(r, base_mean * top)
            elif base_mean <= 20.0:
                count, r = stream.poisson_count(r, base_limit)
            else:
                count, r = stream.poisson_count_of(r, base_mean)
            for _ in range(count):
                kept = ALL_USES
                if f_queue < top:
                    u, r = stream.unit(r)
                    if u * top >= f_queue:
                        kept ^= QUEUE
                if f_recruit < top:
                    u, r = stream.unit(r)
                    if u * top >= f_recruit:
                        kept ^= RECRUITMENT
                if f_inhibit < top:
                    u, r = stream.unit(r)
                    if u * top >= f_inhibit:
                        kept ^= INHIBITION
                if kept == 0:
                    continue  # a message that keeps no use is not sent
                found = -1
                for _draw in range(k.neighbour_draws):
                    pick, r = stream.index_below(r, n_members)
                    j = members[first + pick]
                    dx = pos[j, 0] - pos[i, 0]
                    dy = pos[j, 1] - pos[i, 1]
                    if j != i and dx * dx + dy * dy <= range2:
                        found = j
                        break
                # A message between two uncommitted agents changes nothing: an
                # uncommitted agent's streak is never used (any change of decision
                # state clears it) and only initiating agents count silence.
                if found < 0 or (state[i] == S.U_I and state[found] == S.U_I):
                    continue
                if n == sender.size:
                    sender = np.concatenate((sender, np.empty(n, dtype=np.int64)))
                    receiver = np.concatenate((receiver, np.empty(n, dtype=np.int64)))
                    uses = np.concatenate((uses, np.empty(n, dtype=np.int8)))
                sender[n] = i
                receiver[n] = found
                uses[n] = kept
                n += 1
    stream.store(w.stream, r)
    return sender[:n], receiver[:n], uses[:n]


@internal
def deliver_messages(
    w: Arrays,
    k: Constants,
    receiver: np.ndarray,
    s_state: np.ndarray,
    s_target: np.ndarray,
    s_estimate: np.ndarray,
    uses: np.ndarray,
    draw: np.ndarray,
    finished: np.ndarray,
) -> None:
    """Apply the messages one after another, each to the state the previous ones left.

    Message m goes to `receiver[m]` from a sender in state `s_state[m]` for
    target `s_target[m]` with estimate `s_estimate[m]` and uses `uses[m]` (a
    message without QUEUE leaves the receiver's window as it was, one without
    RECRUITMENT or INHIBITION cannot recruit or inhibit); `draw[m]` is its
    uniform draw for recruitment and cross-inhibition. Every rule reads the
    receiver's state before the message, so at most one rule fires per
    message. A D(i) quorum marks the receiver's collective in `finished` (the
    first such transition ends its decision). One loop, no per-message call:
    a call that takes the world's arrays costs more than the rules themselves.
    """
    state, target, streak, leg = w.state, w.target, w.streak, w.leg
    for m in range(receiver.size):
        r, sender_state, sender_target = receiver[m], s_state[m], s_target[m]
        old_state, old_target = state[r], target[r]
        w.silence[r] = 0.0
        kept = uses[m]
        counts = (kept & QUEUE) != 0
        if counts:
            key = decision_key(old_state, old_target)
            run = streak[r] + 1 if key == decision_key(sender_state, sender_target) else 0
        else:
            run = streak[r]
        new_state, new_target, new_leg = old_state, old_target, leg[r]
        changed = False
        if sender_state == S.C and S.DELIBERATING[old_state]:  # commitment spreads
            new_state, new_target, changed = S.C, sender_target, True
        elif sender_state == S.I and (
            old_state == S.U_I
            or old_state == S.F_I
            or (old_state == S.C and old_target == sender_target)
        ):  # initiation spreads
            new_state, new_target, changed = S.I, sender_target, True
        elif k.model != M3 and sender_state == S.F_I and draw[m] < s_estimate[m]:
            if old_state == S.U_I:
                if (kept & RECRUITMENT) and not w.abandon_order[w.collective[r], sender_target]:
                    new_state, new_target, new_leg = S.F_L, sender_target, S.TO_TARGET
                    changed = True
            elif (
                S.FAVOURING_IN_HUB[old_state]
                and old_target != sender_target
                and (kept & INHIBITION)
            ):
                new_state, new_target, new_leg, changed = S.U_L, -1, S.EXPLORING, True
        if counts and run >= k.quorum_k and not changed:
            if k.model != M3 and old_state == S.F_I:  # F_I(i) → C(i)
                new_state = S.C
            elif old_state == S.C:  # C(i) → I(i)
                new_state = S.I
            elif old_state == S.I:  # I(i) → X(i)
                new_state, new_leg = S.X, S.TO_TARGET
            elif old_state == S.D:  # a D(i) quorum ends the decision
                finished[w.collective[r]] = True
        new_target = target_in(new_state, new_target)
        state[r], target[r], leg[r] = new_state, new_target, new_leg
        # The window is cleared when the decision state changes (set_state_one's rule).
        streak[r] = 0 if decision_changed(old_state, old_target, new_state, new_target) else run


@internal
def exchange_kernel(w: Arrays, k: Constants, finished: np.ndarray) -> None:
    """Send, deliver and apply one step of messages, in a random order.

    Marks in `finished` the collectives in which a D(i) quorum was reached.
    """
    silence = w.silence
    for i in range(silence.size):
        silence[i] += k.dt_s
    sender, receiver, uses = compose_kernel(w, k)
    n = sender.size
    r = stream.load(w.stream)
    for m in range(n - 1, 0, -1):  # Fisher-Yates shuffle: a random order of arrival
        j, r = stream.index_below(r, m + 1)
        sender[m], sender[j] = sender[j], sender[m]
        receiver[m], receiver[j] = receiver[j], receiver[m]
        uses[m], uses[j] = uses[j], uses[m]
    s_state = np.empty(n, dtype=np.int8)
    s_target = np.empty(n, dtype=np.int32)
    s_estimate = np.empty(n, dtype=np.float64)
    draw = np.empty(n, dtype=np.float64)
    state, target, estimate = w.state, w.target, w.estimate
    for m in range(n):  # senders speak from their state at composition
        s_state[m] = state[sender[m]]
        s_target[m] = target[sender[m]]
        s_estimate[m] = estimate[sender[m]]
        draw[m], r = stream.unit(r)
    stream.store(w.stream, r)
    deliver_messages(w, k, receiver, s_state, s_target, s_estimate, uses, draw, finished)


@internal
def initiating_silence_kernel(w: Arrays, k: Constants) -> None:
    """I(i) → X(i) after k/r_msg seconds without receiving any message."""
    for i in range(w.state.size):
        if w.state[i] == S.I and w.silence[i] >= k.silence_limit_s:
            set_state_one(w.state, w.target, w.streak, i, S.X, w.target[i])
            w.leg[i] = S.TO_TARGET


# ------------------------------------------------------- Python entry points
def compose(world: World, params: Params, model: str) -> Inbox:
    """The messages one step would send (advances the world's stream)."""
    sender, receiver, uses = _compose(world.kernel_arrays(), constants_for(params, model))
    return Inbox(
        sender=sender,
        receiver=receiver,
        sender_state=world.state[sender].copy(),
        sender_target=world.target[sender].copy(),
        sender_estimate=world.estimate[sender].copy(),
        uses=uses,
    )


def deliver(
    world: World, params: Params, model: str, inbox: Inbox, messages: np.ndarray, draw: np.ndarray
) -> np.ndarray:
    """Apply the given messages of an inbox in order, with the given recruitment draws.

    Returns the collectives in which a D(i) quorum was reached.
    """
    finished = np.zeros(world.n_collectives, dtype=np.bool_)
    uses = (
        np.full(len(messages), ALL_USES, dtype=np.int8)
        if inbox.uses is None
        else inbox.uses[messages].astype(np.int8)
    )
    _deliver(
        world.kernel_arrays(),
        constants_for(params, model),
        inbox.receiver[messages].astype(np.int64),
        inbox.sender_state[messages].astype(np.int8),
        inbox.sender_target[messages].astype(np.int32),
        inbox.sender_estimate[messages].astype(np.float64),
        uses,
        np.asarray(draw, dtype=np.float64),
        finished,
    )
    return finished


# The kernels' entries from Python (the kernels themselves have none: jit.internal).
@njit(cache=True)
def _compose(w: Arrays, k: Constants) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return compose_kernel(w, k)


@njit(cache=True)
def _deliver(
    w: Arrays,
    k: Constants,
    receiver: np.ndarray,
    s_state: np.ndarray,
    s_target: np.ndarray,
    s_estimate: np.ndarray,
    uses: np.ndarray,
    draw: np.ndarray,
    finished: np.ndarray,
) -> None:
    deliver_messages(w, k, receiver, s_state, s_target, s_estimate, uses, draw, finished)
