"""The simulation state as a structure of arrays.

Every agent attribute is one array over all agents of all collectives, so each
rule of the spec is a handful of masked vector operations (Mesa's advice for
scale, VMAS's shape). Collective- and target-level attributes are small arrays
too. The world holds no random generator and no rules: it is plain state, which
is what makes snapshots and restores exact.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from hcss.simulation import states as S
from hcss.simulation.params import Params
from hcss.simulation.scenario import Scenario
from hcss.simulation.stream import seed_stream


class Arrays(NamedTuple):
    """The World's arrays as the compiled kernels take them (one argument, cheap to pass)."""

    collective: np.ndarray
    state: np.ndarray
    target: np.ndarray
    leg: np.ndarray
    pos: np.ndarray
    heading: np.ndarray
    estimate: np.ndarray
    arrival_state: np.ndarray
    report_target: np.ndarray
    streak: np.ndarray
    silence: np.ndarray
    reported_quadrant: np.ndarray
    hub: np.ndarray
    target_pos: np.ndarray
    target_value: np.ndarray
    target_around: np.ndarray
    active: np.ndarray
    reserved_by: np.ndarray
    report_sum: np.ndarray
    report_count: np.ndarray
    abandon_order: np.ndarray
    hub_distance: np.ndarray
    discovery_gap: np.ndarray
    round_trip_gap: np.ndarray
    send_factor: np.ndarray
    site_rate: np.ndarray
    stream: np.ndarray


@dataclass
class World:
    """All state of one trial. Target arrays are indexed by target id - 1."""

    # agents -------------------------------------------------------------
    collective: np.ndarray  # int32, fixed
    state: np.ndarray  # int8, states.U_L ... states.D
    target: np.ndarray  # int32, target index, or -1 exactly when uncommitted
    leg: np.ndarray  # int8, AT_HUB / EXPLORING / TO_TARGET / TO_HUB
    pos: np.ndarray  # float64 (A, 2)
    heading: np.ndarray  # float64 (A, 2), unit vector of the walk's direction
    estimate: np.ndarray  # float64, latest v̂ of the agent's own target
    arrival_state: np.ndarray  # int8, state entered on reaching the hub
    report_target: np.ndarray  # int32, target whose estimate the agent brings home, or -1
    streak: np.ndarray  # int32, running quorum streak (the k-window)
    silence: np.ndarray  # float64, seconds since the agent last received a message
    reported_quadrant: np.ndarray  # int8, last U/F/C/X quadrant reported at the hub
    # collectives --------------------------------------------------------
    hub: np.ndarray  # float64 (C, 2), current hub
    start_hub: np.ndarray  # float64 (C, 2)
    executing: np.ndarray  # int32, target being moved to, or -1
    commit_announced: np.ndarray  # int32, target whose commitment was announced, or -1
    # targets ------------------------------------------------------------
    target_pos: np.ndarray  # float64 (T, 2)
    target_value: np.ndarray  # float64
    target_section: np.ndarray  # int32, 0-based section
    target_around: np.ndarray  # int32, collective whose start hub it was placed around
    active: np.ndarray  # bool: placed and not yet taken
    reserved_by: np.ndarray  # int32, collective executing a move to it, or -1
    report_sum: np.ndarray  # float64, sum of estimates reported at hubs
    report_count: np.ndarray  # int32
    abandon_order: np.ndarray  # bool (C, T): standing abandon requests
    hub_distance: np.ndarray  # float64 (C, T): distance from each hub to each target
    # M2 (C, T), derived from hub_distance by rules.refresh_geometry
    discovery_gap: np.ndarray  # float64, 1/g(d_max) - 1/g(d): discovery delay's denominator
    round_trip_gap: np.ndarray  # float64, τ_max - τ_i: reassessment delay's denominator
    send_factor: np.ndarray  # float64, M_i = d_i/d_min: message rate factor of F_I(i) senders
    site_rate: np.ndarray  # float64, g(d) per explorer (discovery "per_agent"), before eligibility
    # the kernels' random stream (stream.py) --------------------------------
    stream: np.ndarray  # uint64 (4,), xoshiro256** state
    # clock --------------------------------------------------------------
    step_count: int = 0
    time: float = 0.0
    section: int = 0
    decisions_in_section: int = 0
    finished: bool = False
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def n_collectives(self) -> int:
        return int(self.hub.shape[0])

    @classmethod
    def new(cls, scenario: Scenario, params: Params, run: int = 0) -> World:
        n_c, n = scenario.n_collectives, params.n_agents
        a = n_c * n
        placed = [t for section in scenario.sections for t in section.targets]
        if [t.id for t in placed] != list(range(1, len(placed) + 1)):
            raise ValueError("scenario target ids must run 1..n over the whole trial")
        n_t = len(placed)
        hubs = np.array(scenario.hubs, dtype=float)
        world = cls(
            collective=np.repeat(np.arange(n_c, dtype=np.int32), n),
            state=np.full(a, S.U_I, dtype=np.int8),
            target=np.full(a, -1, dtype=np.int32),
            leg=np.full(a, S.AT_HUB, dtype=np.int8),
            pos=np.zeros((a, 2)),
            heading=np.tile([1.0, 0.0], (a, 1)),
            estimate=np.zeros(a),
            arrival_state=np.full(a, S.U_I, dtype=np.int8),
            report_target=np.full(a, -1, dtype=np.int32),
            streak=np.zeros(a, dtype=np.int32),
            silence=np.zeros(a),
            reported_quadrant=np.zeros(a, dtype=np.int8),
            hub=hubs.copy(),
            start_hub=hubs.copy(),
            executing=np.full(n_c, -1, dtype=np.int32),
            commit_announced=np.full(n_c, -1, dtype=np.int32),
            target_pos=np.array([(t.x, t.y) for t in placed], dtype=float).reshape(n_t, 2),
            target_value=np.array([t.value for t in placed], dtype=float),
            target_section=np.array(
                [i for i, s in enumerate(scenario.sections) for _ in s.targets], dtype=np.int32
            ),
            target_around=np.array([t.around for t in placed], dtype=np.int32),
            active=np.zeros(n_t, dtype=bool),
            reserved_by=np.full(n_t, -1, dtype=np.int32),
            report_sum=np.zeros(n_t),
            report_count=np.zeros(n_t, dtype=np.int32),
            abandon_order=np.zeros((n_c, n_t), dtype=bool),
            hub_distance=np.zeros((n_c, n_t)),
            discovery_gap=np.zeros((n_c, n_t)),
            round_trip_gap=np.zeros((n_c, n_t)),
            send_factor=np.ones((n_c, n_t)),
            site_rate=np.zeros((n_c, n_t)),
            stream=seed_stream(scenario.seed, run),
        )
        return world

    def kernel_arrays(self) -> Arrays:
        """The arrays the kernels read and write in place."""
        return Arrays(
            self.collective,
            self.state,
            self.target,
            self.leg,
            self.pos,
            self.heading,
            self.estimate,
            self.arrival_state,
            self.report_target,
            self.streak,
            self.silence,
            self.reported_quadrant,
            self.hub,
            self.target_pos,
            self.target_value,
            self.target_around,
            self.active,
            self.reserved_by,
            self.report_sum,
            self.report_count,
            self.abandon_order,
            self.hub_distance,
            self.discovery_gap,
            self.round_trip_gap,
            self.send_factor,
            self.site_rate,
            self.stream,
        )

    # -- derived views ----------------------------------------------------
    def refresh_hub_distance(self) -> None:
        """Recompute hub-to-target distances; called when a hub moves."""
        delta = self.hub[:, None, :] - self.target_pos[None, :, :]
        np.hypot(delta[..., 0], delta[..., 1], out=self.hub_distance)

    def home(self) -> np.ndarray:
        """Centre of each agent's hub area: its collective's hub, or the new site for X and D."""
        return np.stack(self.home_xy(), axis=1)

    def home_xy(self) -> tuple[np.ndarray, np.ndarray]:
        """`home()` as separate x and y arrays (1-D gathers are much cheaper on the hot path)."""
        hx = self.hub[:, 0][self.collective]
        hy = self.hub[:, 1][self.collective]
        at_site = np.flatnonzero(self.state >= S.X)  # X or D
        if at_site.size:
            site = self.target[at_site]
            hx[at_site] = self.target_pos[site, 0]
            hy[at_site] = self.target_pos[site, 1]
        return hx, hy

    def favouring(self) -> np.ndarray:
        return np.asarray(S.FAVOURING[self.state])

    def support(self) -> np.ndarray:
        """(C, T) fraction of each collective favouring each target (true state)."""
        fav = self.favouring()
        counts = np.zeros((self.n_collectives, self.target_pos.shape[0]))
        np.add.at(counts, (self.collective[fav], self.target[fav]), 1.0)
        return np.asarray(counts / (self.collective.shape[0] / self.n_collectives))

    def set_state(
        self, agents: np.ndarray, new_state: int, new_target: np.ndarray | int | None = None
    ) -> None:
        """Move agents to a new state, clearing the quorum streak where the decision state changes."""
        agents = np.asarray(agents)
        if agents.dtype == bool:
            agents = np.flatnonzero(agents)
        if agents.size == 0:
            return
        if new_target is None:
            targets = self.target[agents]
        else:
            targets = np.broadcast_to(np.asarray(new_target, dtype=np.int32), agents.shape)
        set_states_kernel(
            self.state,
            self.target,
            self.streak,
            agents.astype(np.int64),
            np.full(agents.size, new_state, dtype=np.int8),
            np.ascontiguousarray(targets, dtype=np.int32),
        )

    def send_home(self, agents: np.ndarray) -> None:
        """Reset agents to uncommitted; those away from the hub fly back to it."""
        send_home_kernel(
            self.state,
            self.target,
            self.streak,
            self.leg,
            self.arrival_state,
            np.asarray(agents, dtype=np.int64),
        )

    def reset_agents_of(self, collective: int) -> None:
        """After a decision: a collective's agents at the new site rest there, the rest go home."""
        reset_collective_kernel(
            self.state,
            self.target,
            self.streak,
            self.leg,
            self.arrival_state,
            self.collective,
            collective,
        )

    # -- persistence ------------------------------------------------------
    def arrays(self) -> dict[str, np.ndarray]:
        return {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if isinstance(getattr(self, f.name), np.ndarray)
        }

    def copy(self) -> World:
        values = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                value = value.copy()
            elif isinstance(value, dict):
                value = dict(value)
            values[f.name] = value
        return World(**values)


# Integer arguments of any width are widened to these signatures' int64, so
# these functions are compiled once each, not once per combination of types.
@njit("int64(int64, int64)", cache=True)
def target_in(new_state: int, new_target: int) -> int:
    """Uncommitted agents have no target (-1): the invariant decision keys rely on."""
    return -1 if S.PHASE_OF_STATE[new_state] == 0 else new_target


@njit("boolean(int64, int64, int64, int64)", cache=True)
def decision_changed(old_state: int, old_target: int, new_state: int, new_target: int) -> bool:
    """Whether the decision state (phase and target) changes: the quorum window is then cleared."""
    return S.PHASE_OF_STATE[old_state] != S.PHASE_OF_STATE[new_state] or old_target != new_target


@njit(cache=True, inline="always")
def set_state_one(
    state: np.ndarray,
    target: np.ndarray,
    streak: np.ndarray,
    agent: int,
    new_state: int,
    new_target: int,
) -> None:
    """The one rule for a change of state: uncommitted agents have no target, and the
    quorum streak is cleared when the decision state (phase and target) changes."""
    new_target = target_in(new_state, new_target)
    if decision_changed(state[agent], target[agent], new_state, new_target):
        streak[agent] = 0
    state[agent] = new_state
    target[agent] = new_target


@njit(cache=True)
def set_states_kernel(
    state: np.ndarray,
    target: np.ndarray,
    streak: np.ndarray,
    agents: np.ndarray,
    new_states: np.ndarray,
    new_targets: np.ndarray,
) -> None:
    for i in range(agents.size):
        set_state_one(state, target, streak, agents[i], new_states[i], new_targets[i])


@njit(cache=True, inline="always")
def send_home_one(
    state: np.ndarray,
    target: np.ndarray,
    streak: np.ndarray,
    leg: np.ndarray,
    arrival_state: np.ndarray,
    agent: int,
) -> None:
    """The one rule for sending an agent home: uncommitted, flying back if away from the hub."""
    set_state_one(state, target, streak, agent, S.U_I, -1)
    if leg[agent] != S.AT_HUB:
        set_state_one(state, target, streak, agent, S.U_L, -1)
        leg[agent] = S.TO_HUB
        arrival_state[agent] = S.U_I


@njit(cache=True)
def send_home_kernel(
    state: np.ndarray,
    target: np.ndarray,
    streak: np.ndarray,
    leg: np.ndarray,
    arrival_state: np.ndarray,
    agents: np.ndarray,
) -> None:
    for i in range(agents.size):
        send_home_one(state, target, streak, leg, arrival_state, agents[i])


@njit(cache=True)
def reset_collective_kernel(
    state: np.ndarray,
    target: np.ndarray,
    streak: np.ndarray,
    leg: np.ndarray,
    arrival_state: np.ndarray,
    collective: np.ndarray,
    c: int,
) -> None:
    for i in range(state.size):
        if collective[i] != c:
            continue
        if state[i] == S.D and leg[i] == S.AT_HUB:  # arrived at the new site
            set_state_one(state, target, streak, i, S.U_I, -1)
        else:
            send_home_one(state, target, streak, leg, arrival_state, i)
