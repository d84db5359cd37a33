"""The stochastic mean-field chain: N agents of one collective, the paper's rates, no space.

Each agent has a state, a target, a flight timer and a quorum streak. Every
step of dt: flights end, explorers discover sites at g(d)·scale per agent
and adopt with probability v̂, the rates of spec §4–5 fire, and every hub
agent in an interactive state sends Poisson(r_msg·M_i·dt) messages, each to
one uniformly random member of its hub area (the whole hub: no 30 m range);
M_i's uses (queue, recruitment, inhibition) are thinned from the stream as in
the engine: sent at r·max(f), each use kept with probability f_use/max(f).
Receivers apply the rules of spec §4 and §7 one message at a time, in rounds
of distinct receivers, reading the sender's state from the step's start. The
decision ends at the first D quorum, as in the agent model.

Flights take their fixed duration (d/speed each way; an explorer stopping
flies home from the mean explorer distance 2R/3). This reimplements the
rules independently of the engine, so that the two can check each other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hcss.experiments.meanfield import Rates, Site
from hcss.simulation.params import Params

# Chain states: uncommitted (exploring, flying home, in hub), favouring
# (returning from discovery, flying to assess, flying back, F_I, F_D, F_R),
# and the commitment chain.
UL, UH, UI, FA, FGO, FBACK, FI, FD, FR, C, INIT, X, D = range(13)
PHASE = np.array([0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 3, 4, 5])
FLYING = np.zeros(13, dtype=bool)
FLYING[[UH, FA, FGO, FBACK, X]] = True
IN_HUB = np.zeros(13, dtype=bool)
IN_HUB[[UI, FI, FD, FR, C, INIT]] = True
SENDS = np.zeros(13, dtype=bool)
SENDS[[UI, FI, C, INIT, D]] = True
DELIBERATING = np.zeros(13, dtype=bool)
DELIBERATING[[UI, FI, FD, FR]] = True


@dataclass(frozen=True)
class ChainOutcome:
    """One run of the chain: the chosen site (-1 if timed out) and when."""

    chosen: int
    time_s: float


class Chain:
    """One collective of N agents deciding among `sites` under one model's rates."""

    def __init__(
        self,
        sites: list[Site],
        model: str,
        params: Params,
        rng: np.random.Generator,
        discovery_scale: float = 1.0,
    ):
        if params.abandonment != "per_visit":
            raise ValueError(
                "the chain applies abandonment per visit only (abandonment='per_visit')"
            )
        self.sites, self.p, self.rng, self.m2 = sites, params, rng, model == "M2"
        self.rates = Rates.of(sites, model, params, discovery_scale)
        self.distance = np.array([s.distance_m for s in sites])
        n = params.n_agents
        self.state = np.full(n, UI)
        self.target = np.full(n, -1)
        self.timer = np.zeros(n)
        self.estimate = np.zeros(n)
        self.abandoning = np.zeros(n, dtype=bool)
        self.streak = np.zeros(n, dtype=np.int64)
        self.silence = np.zeros(n)

    # ----------------------------------------------------------- helpers
    def per_step(self, rate: np.ndarray | float) -> np.ndarray:
        return -np.expm1(-np.asarray(rate) * self.p.dt_s)

    def assess(self, agents: np.ndarray) -> np.ndarray:
        e = self.rng.uniform(-self.p.value_error, self.p.value_error, agents.size)
        return np.asarray(np.clip(self.rates.value[self.target[agents]] * (1.0 + e), 1e-9, 1.0))

    def key(self, agents: np.ndarray) -> np.ndarray:
        return np.asarray(PHASE[self.state[agents]] * 64 + self.target[agents])

    def become(
        self, agents: np.ndarray, new_state: int, new_target: np.ndarray | None = None
    ) -> None:
        """Change state; the quorum streak is cleared when the decision state changes."""
        if agents.size == 0:
            return
        before = self.key(agents)
        self.state[agents] = new_state
        if new_target is not None:
            self.target[agents] = new_target
        if PHASE[new_state] == 0:
            self.target[agents] = -1
        self.streak[agents[self.key(agents) != before]] = 0

    def fly(self, agents: np.ndarray, new_state: int) -> None:
        """Start a flight of d/speed to (or back from) the agent's site."""
        self.become(agents, new_state)
        self.timer[agents] = self.rates.flight_s[self.target[agents]]

    # -------------------------------------------------------------- step
    def run(self) -> ChainOutcome:
        """From everyone uncommitted in the hub to the first D quorum, or the time-out."""
        limit = self.p.decision_timeout_s or 1800.0
        t = 0.0
        while t < limit:
            t += self.p.dt_s
            self.land()
            self.discover()
            self.rate_transitions()
            if self.exchange():
                return ChainOutcome(int(self.target[self.state == D][0]), t)
            quiet = np.flatnonzero((self.state == INIT) & (self.silence >= self.p.silence_limit_s))
            self.fly(quiet, X)
            self.begin_move()
        return ChainOutcome(-1, t)

    def land(self) -> None:
        flying = FLYING[self.state]
        self.timer[flying] -= self.p.dt_s
        landed = np.flatnonzero(flying & (self.timer <= 1e-9))
        st = self.state[landed].copy()
        self.become(landed[st == UH], UI)
        self.become(landed[st == FA], FD if self.m2 else FI)
        self.become(landed[st == X], D)
        back = landed[st == FBACK]
        self.become(back[self.abandoning[back]], UI)
        self.become(back[~self.abandoning[back]], FR if self.m2 else FI)
        at_site = landed[st == FGO]  # a fresh estimate; abandon with P_α
        self.estimate[at_site] = self.assess(at_site)
        d = self.distance[self.target[at_site]]
        p_abandon = np.minimum(
            1.0,
            self.p.abandon_alpha
            * self.p.abandon_scale
            * (d / self.p.abandon_unit_m)
            / self.estimate[at_site],
        )
        self.abandoning[at_site] = self.rng.random(at_site.size) < p_abandon
        self.fly(at_site, FBACK)

    def discover(self) -> None:
        """Per agent at rate Σ g_i; the site drawn in proportion to g_i; adopted with probability v̂."""
        explorers = np.flatnonzero(self.state == UL)
        total = self.rates.discovery.sum()
        found = explorers[self.rng.random(explorers.size) < self.per_step(total)]
        if found.size == 0:
            return
        site = self.rng.choice(len(self.sites), size=found.size, p=self.rates.discovery / total)
        self.target[found] = site
        self.estimate[found] = self.assess(found)
        adopt = self.rng.random(found.size) < self.estimate[found]
        self.target[found[~adopt]] = -1
        self.become(found[adopt], FA, site[adopt])
        self.fly(found[adopt], FA)

    def rate_transitions(self) -> None:
        p, state, draw = self.p, self.state, self.rng.random(self.state.size)
        stop = np.flatnonzero((state == UL) & (draw < self.per_step(p.stop_exploring_rate)))
        state[stop] = UH
        self.timer[stop] = (2.0 * p.exploration_range_m / 3.0) / p.speed_mps
        leave = self.per_step(p.resume_rate)
        resume = np.flatnonzero((state == UI) & (draw < leave))
        reassess = np.flatnonzero((state == FI) & (draw < leave))
        state[resume] = UL
        self.fly(reassess, FGO)
        if not self.m2:
            return
        for waiting, rate in ((FD, self.rates.leave_delay), (FR, self.rates.leave_reassess)):
            w = np.flatnonzero(state == waiting)
            t = self.target[w]
            r = rate[t] * self.estimate[w] / self.rates.value[t]  # the agent's own v̂ in place of v
            go = (r == np.inf) | (draw[w] < self.per_step(np.where(r == np.inf, 0.0, r)))
            state[w[go]] = FI

    def begin_move(self) -> None:
        """When the move begins, agents committed to other sites return to deliberation."""
        moving = np.flatnonzero(self.state == X)
        if moving.size:
            going = int(np.bincount(self.target[moving]).argmax())
            rivals = np.flatnonzero(
                ((self.state == C) | (self.state == INIT)) & (self.target != going)
            )
            self.become(rivals, UI)

    # ---------------------------------------------------------- messages
    def exchange(self) -> bool:
        """One step of messages; True when a D quorum ends the decision."""
        self.silence += self.p.dt_s
        senders, receivers, uses = self.compose()
        if senders.size == 0:
            return False
        state, target = self.state, self.target
        sender = (state[senders].copy(), target[senders].copy(), self.estimate[senders].copy())
        sender_key = PHASE[sender[0]] * 64 + sender[1]
        order = self.rng.permutation(receivers.size)
        ranked = receivers[order]
        by = np.argsort(ranked, kind="stable")
        first = np.r_[0, np.flatnonzero(ranked[by][1:] != ranked[by][:-1]) + 1]
        counts = np.diff(np.r_[first, ranked.size])
        rank = np.empty(ranked.size, dtype=np.int64)
        rank[by] = np.arange(ranked.size) - np.repeat(first, counts)
        draws = self.rng.random(receivers.size)
        for rnd in range(int(rank.max()) + 1):
            m = order[rank == rnd]
            if self.deliver(
                receivers[m],
                sender[0][m],
                sender[1][m],
                sender[2][m],
                sender_key[m],
                draws[m],
                uses[:, m],
            ):
                return True
        return False

    def compose(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """This step's messages: senders, receivers and uses (3 × messages: queue,
        recruitment, inhibition)."""
        p, state, target = self.p, self.state, self.target
        senders = np.flatnonzero(SENDS[state])
        rate = np.full(senders.size, p.message_rate)
        favouring = state[senders] == FI
        top = self.rates.send_modulation
        rate[favouring] *= top[target[senders[favouring]]]
        senders = np.repeat(senders, self.rng.poisson(rate * p.dt_s))
        # Each message's uses (queue, recruitment, inhibition): kept with f_use/max(f).
        uses = np.ones((3, senders.size), dtype=bool)
        fi = state[senders] == FI
        site = target[senders[fi]]
        for row, factor in enumerate(
            (
                self.rates.queue_modulation,
                self.rates.recruit_modulation,
                self.rates.inhibit_modulation,
            )
        ):
            keep = factor[site] / top[site]
            if np.any(keep < 1.0):
                uses[row, fi] = self.rng.random(site.size) < keep
        sent = uses.any(axis=0)
        senders, uses = senders[sent], uses[:, sent]
        area = np.where(state == D, 1, np.where(IN_HUB[state], 0, -1))
        receivers = np.full(senders.size, -1)
        for a in (0, 1):
            members = np.flatnonzero(area == a)
            mine = np.flatnonzero(area[senders] == a)
            if members.size > 1 and mine.size:
                receivers[mine] = members[self.rng.integers(0, members.size, mine.size)]
        ok = (receivers >= 0) & (receivers != senders)
        return senders[ok], receivers[ok], uses[:, ok]

    def deliver(
        self,
        r: np.ndarray,
        s_state: np.ndarray,
        s_target: np.ndarray,
        s_estimate: np.ndarray,
        s_key: np.ndarray,
        draw: np.ndarray,
        uses: np.ndarray,
    ) -> bool:
        """Spec §4 and §7 for one message to each of the distinct receivers r; `uses` (3, n):
        whether each message counts in the queue, can recruit, can inhibit."""
        queue, recruits, inhibits = uses
        st, tg = self.state[r].copy(), self.target[r].copy()
        self.silence[r] = 0.0
        streak = np.where(
            queue, np.where(self.key(r) == s_key, self.streak[r] + 1, 0), self.streak[r]
        )
        self.streak[r] = streak
        commit = (s_state == C) & DELIBERATING[st]
        initiate = (s_state == INIT) & ((st == UI) | (st == FI) | ((st == C) & (tg == s_target)))
        persuaded = (s_state == FI) & (draw < s_estimate) & ~commit & ~initiate
        recruit = persuaded & (st == UI) & recruits
        inhibit = persuaded & ((st == FI) | (st == FD) | (st == FR)) & (tg != s_target) & inhibits
        quorum = queue & (streak >= self.p.quorum_k) & ~(commit | initiate | recruit | inhibit)
        self.become(r[commit], C, s_target[commit])
        self.become(r[initiate], INIT, s_target[initiate])
        self.become(r[recruit], FGO, s_target[recruit])
        self.fly(r[recruit], FGO)
        self.become(r[inhibit], UL)
        self.become(r[quorum & (st == FI)], C)
        self.become(r[quorum & (st == C)], INIT)
        self.fly(r[quorum & (st == INIT)], X)
        return bool(np.any(quorum & (st == D)))


def run_chain(
    sites: list[Site],
    model: str,
    params: Params | None,
    rng: np.random.Generator,
    discovery_scale: float = 1.0,
) -> ChainOutcome:
    """Run one decision of the stochastic chain."""
    return Chain(sites, model, params or Params(), rng, discovery_scale).run()
