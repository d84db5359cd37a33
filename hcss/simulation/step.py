"""One step of the agent rules, fused into one compiled entry point (`steps`).

`advance_agents` runs, in the spec's order, movement, arrival at targets and
hubs, then standing orders, discovery and the rate transitions (one pass,
`rules.agent_rules_kernel`); the engine then
serves operator requests (Python, rare) and `exchange_and_report` runs the
message round, the initiating agents' silence rule and the hub reports. Each
rule is the single compiled function of its own module; this module only
chains them so that a step costs one call from Python instead of dozens of
array operations. The two halves are inlined into `steps`, which Python calls
for whole steps or for either half: compiled once, not once per entry point
(numba compiles and links a function again into each compiled caller).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from hcss.simulation import states as S
from hcss.simulation.constants import Constants
from hcss.simulation.jit import internal
from hcss.simulation.messaging import exchange_kernel, initiating_silence_kernel
from hcss.simulation.movement import move_kernel
from hcss.simulation.rules import agent_rules_kernel, reach_hub_kernel, reach_target_kernel
from hcss.simulation.world import Arrays


@njit(cache=True, inline="always")
def advance_agents(
    w: Arrays, k: Constants, at_target: np.ndarray, at_hub: np.ndarray, newly_visible: np.ndarray
) -> int:
    """Move, arrive, enforce orders, discover, rate transitions. Returns the newly visible count."""
    n_target, n_hub = move_kernel(w, k, at_target, at_hub)
    reach_target_kernel(w, k, at_target, n_target)
    n_visible: int = reach_hub_kernel(w, at_hub, n_hub, newly_visible)
    # Plain booleans, as the rules' Python entry points pass them: a literal True
    # is a type of its own, for which the kernel would be compiled a second time.
    every = bool(True)  # noqa: UP018 - bool() makes it a plain bool for numba
    agent_rules_kernel(w, k, every, every, every)
    return n_visible


@njit(cache=True, inline="always")
def exchange_and_report(
    w: Arrays,
    k: Constants,
    finished: np.ndarray,
    state_counts: np.ndarray,
    committed: np.ndarray,
    moving: np.ndarray,
) -> None:
    """Messages, the silence rule, and each agent in its hub reporting its state (spec §9).

    `finished` marks collectives whose D(i) quorum was reached; `state_counts`
    receives the number of agents in each state, and `committed` and `moving`
    the (collective, target) counts of C and X agents, so the engine only
    looks for commitments and moves when there are any.
    """
    finished[:] = False
    exchange_kernel(w, k, finished)
    initiating_silence_kernel(w, k)
    state_counts[:] = 0
    committed[:] = 0
    moving[:] = 0
    for i in range(w.state.size):
        state = w.state[i]
        state_counts[state] += 1
        if state == S.C:
            committed[w.collective[i], w.target[i]] += 1
        elif state == S.X:
            moving[w.collective[i], w.target[i]] += 1
        if w.leg[i] == S.AT_HUB:
            w.reported_quadrant[i] = S.QUADRANT_OF_STATE[state]


# What `steps` runs: whole steps, or one half of a step (the engine serves
# operator requests between the two halves).
WHOLE, ADVANCE, EXCHANGE = 0, 1, 2


@njit(cache=True)
def steps(
    w: Arrays,
    k: Constants,
    at_target: np.ndarray,
    at_hub: np.ndarray,
    newly_visible: np.ndarray,
    finished: np.ndarray,
    state_counts: np.ndarray,
    committed: np.ndarray,
    moving: np.ndarray,
    commit_announced: np.ndarray,
    executing: np.ndarray,
    max_steps: int,
    part: int,
) -> tuple[int, int]:
    """Up to `max_steps` whole steps, stopping after the first one that needs the engine;
    or, for `part` ADVANCE or EXCHANGE, that half of one step.

    A step needs the engine (Python) when a target became visible, a
    collective's committed agents favour a target not yet announced, a
    collective without a move under way has executing agents, or a D(i)
    quorum was reached. Returns (steps taken, targets made visible in the
    last). The one compiled entry point of a step: each rule is compiled once.
    """
    done = 0
    n_visible = 0
    while done < max_steps:
        done += 1
        if part != EXCHANGE:
            n_visible = advance_agents(w, k, at_target, at_hub, newly_visible)
        if part != ADVANCE:
            exchange_and_report(w, k, finished, state_counts, committed, moving)
        if part != WHOLE or n_visible > 0:
            return done, n_visible
        for c in range(committed.shape[0]):
            if finished[c]:
                return done, n_visible
            lead = leading(committed[c]) if state_counts[S.C] else -1
            if lead >= 0 and lead != commit_announced[c]:
                return done, n_visible
            if state_counts[S.X] and executing[c] < 0 and leading(moving[c]) >= 0:
                return done, n_visible
    return done, n_visible


@internal
def leading(counts: np.ndarray) -> int:
    """The first index of the largest count, or -1 if all are zero (counts are >= 0).

    A loop rather than numpy's max and argmax: each of those is a further
    function to compile on the first call, for rows of a few targets.
    """
    best = -1
    for t in range(counts.size):
        if counts[t] > 0 and (best < 0 or counts[t] > counts[best]):
            best = t
    return best
