"""The paper's equations as a mean-field model of one collective (spec §4–5).

Two readings of the same transition rates, for one collective of N agents and
any set of sites (distance, value), with no space and a well-mixed hub:

- `solve_meanfield`: ordinary differential equations for the fractions of the
  collective in each state (scipy `solve_ivp`). Flights are exponential stages
  with the flight's mean duration. A quorum (k messages in a row from the
  receiver's own opinion) is a hazard: an F_I(i) agent receives messages at
  rate λ = S/h (S the hub's send rate, h the hub's population) and completes
  a run of k from F_I(i) senders at rate λ·(1 − p_i)·p_i^k, p_i being F_I(i)'s
  share of the messages. The first quorum's site and time follow from the
  competing hazards: P(i first) = ∫ H_i'·e^(−ΣH) dt.
- `chain.run_chain` (hcss/experiments/meanfield_chain.py): the stochastic
  version, N agents with the same rates, flights as fixed delays, messages to
  random hub members, the quorum window and the commitment chain of spec §7.

They predict which site a collective chooses and when; the agent model
(`Simulation`) adds space, four collectives and sequential decisions. The
tests compare them on simple layouts (one collective, its own sites), so each
model checks the other. Discovery is the paper's P_γ = v·g(d) per agent;
`discovery_scale` slows it (e.g. to this world's spatial encounter rate).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from hcss.simulation.params import Params


@dataclass(frozen=True)
class Site:
    """One site of the decision: its distance from the hub and its true value."""

    distance_m: float
    value: float


@dataclass(frozen=True)
class Prediction:
    """What a mean-field reading predicts for one decision."""

    win_probability: tuple[float, ...]  # per site: P(the first quorum is for it)
    undecided: float  # P(no quorum before the time-out)
    quorum_s: float  # expected time of the first quorum, given one
    decision_s: float  # quorum_s plus the commitment latency (see `commitment_latency_s`)

    @property
    def winner(self) -> int:
        return int(np.argmax(self.win_probability))


@dataclass(frozen=True)
class Rates:
    """The per-site rates of spec §4–5 for one model and parameter set."""

    discovery: np.ndarray  # g(d_i)·scale, per exploring agent
    value: np.ndarray
    flight_s: np.ndarray  # d_i / speed
    abandon: np.ndarray  # P_α(i) with v̂ = v, per visit (0 under the "rate" reading)
    abandon_rate: np.ndarray  # scale·α/v per second in F_I (0 under "per_visit")
    leave_delay: np.ndarray  # P_D(i); inf where the guard applies (M1: inf)
    leave_reassess: np.ndarray  # P_R(i)
    # M_i on each use of an F_I(i) agent's messages (1 where the use is not modulated):
    # the quorum's queue, recruitment, cross-inhibition (params.modulated_uses).
    queue_modulation: np.ndarray
    recruit_modulation: np.ndarray
    inhibit_modulation: np.ndarray

    @property
    def send_modulation(self) -> np.ndarray:
        """The factor of an F_I(i) agent's whole stream: the largest of its uses' (thinning)."""
        top = np.maximum(self.queue_modulation, self.recruit_modulation)
        return np.asarray(np.maximum(top, self.inhibit_modulation))

    @classmethod
    def of(
        cls, sites: list[Site], model: str, params: Params, discovery_scale: float = 1.0
    ) -> Rates:
        d = np.array([s.distance_m for s in sites], dtype=float)
        v = np.array([s.value for s in sites], dtype=float)
        discovery = np.asarray(params.discovery_rate(d)) * discovery_scale
        alpha = params.abandon_alpha * params.abandon_scale
        if params.abandonment == "rate":
            abandon, abandon_rate = np.zeros(d.size), alpha / v
        else:
            abandon = np.minimum(1.0, alpha * (d / params.abandon_unit_m) / v)
            abandon_rate = np.zeros(d.size)
        inf = np.full(d.size, np.inf)
        dm = params.m2_distance(d)
        # M_i = d_i/d_min; the sites are the collective's layout, so the nearest is theirs.
        m_i = dm / params.modulation_d_min_m(float(d.min()))
        uses = params.modulated_uses(model)
        queue, recruit, inhibit = (
            m_i if use in uses else np.ones(d.size)
            for use in ("queue", "recruitment", "inhibition")
        )
        if model != "M2":
            return cls(
                discovery,
                v,
                d / params.speed_mps,
                abandon,
                abandon_rate,
                inf,
                inf,
                queue,
                recruit,
                inhibit,
            )
        gap_d = params.discovery_wait_gap_s(dm)
        gap_r = params.round_trip_s(params.m2_d_max_m) - params.round_trip_s(dm)
        if params.m2_g_reading == "value_inside":
            gap_d = gap_d / v
        with np.errstate(divide="ignore"):
            leave_d = np.where(gap_d > 0, v / np.where(gap_d > 0, gap_d, 1.0), np.inf)
            leave_r = np.where(gap_r > 0, v / np.where(gap_r > 0, gap_r, 1.0), np.inf)
        # An ablation removes a mechanism here as in the agent model (params.m2_uses;
        # M_i's through params.modulated_uses above).
        if not params.m2_uses(model, "discovery_delay"):
            leave_d = inf
        if not params.m2_uses(model, "reassessment_delay"):
            leave_r = inf
        return cls(
            discovery,
            v,
            d / params.speed_mps,
            abandon,
            abandon_rate,
            leave_d,
            leave_r,
            queue,
            recruit,
            inhibit,
        )


FAST = 1e3  # a rate standing for "at once" (the guard of spec §5) in the ODEs


def commitment_latency_s(site: Site, params: Params) -> float:
    """From the first quorum to the relocation: three quorums of k messages and the flight.

    A rough reading (C, I and D each need k messages in a row at r_msg, and
    the collective flies d/speed); the stochastic chain runs the chain itself.
    """
    return 3.0 * params.quorum_k / params.message_rate + site.distance_m / params.speed_mps


def solve_meanfield(
    sites: list[Site],
    model: str,
    params: Params | None = None,
    discovery_scale: float = 1.0,
    horizon_s: float | None = None,
) -> Prediction:
    """Integrate the M1 or M2 ODEs from everyone uncommitted in the hub (a section start)."""
    params = params or Params()
    rates = Rates.of(sites, model, params, discovery_scale)
    n = len(sites)
    horizon = horizon_s or params.decision_timeout_s or 1800.0
    r, k, big_n = params.message_rate, params.quorum_k, float(params.n_agents)
    stop, resume = params.stop_exploring_rate, params.resume_rate
    home = 1.0 / ((2.0 * params.exploration_range_m / 3.0) / params.speed_mps)
    fly = 1.0 / rates.flight_s
    leave_d = np.minimum(rates.leave_delay, FAST)
    leave_r = np.minimum(rates.leave_reassess, FAST)
    m2 = model == "M2"

    # y = [uL, uH, uI, a(n), go(n), back(n), fI(n), fD(n), fR(n), H(n), survival, win(n)]
    def unpack(y: np.ndarray) -> tuple[Any, ...]:
        parts = np.split(y[3:], [n, 2 * n, 3 * n, 4 * n, 5 * n, 6 * n, 7 * n, 7 * n + 1])
        return (y[0], y[1], y[2], *parts)

    def derivative(_t: float, y: np.ndarray) -> np.ndarray:
        uL, uH, uI, a, go, back, fI, fD, fR, hazard, _surv, _win = unpack(y)
        fI, fD, fR = np.maximum(fI, 0), np.maximum(fD, 0), np.maximum(fR, 0)
        hub = max(uI + fI.sum() + fD.sum() + fR.sum(), 1e-12)
        # F_I(i)'s messages per unit of N, per use (each use at r·M_i or r: thinning).
        send = r * rates.queue_modulation * fI  # counted in quorum windows
        total_send = r * max(uI, 0.0) + send.sum()
        weighted = r * fI * rates.value / hub  # per receiver fraction: v̂_s-weighted messages
        persuade = weighted * rates.recruit_modulation
        dissuade = weighted * rates.inhibit_modulation
        found = rates.discovery * rates.value * max(uL, 0.0)
        recruit = persuade * max(uI, 0.0)
        inhibit_rate = dissuade.sum() - dissuade  # from every other site's F_I
        inhibited = inhibit_rate * (fI + fD + fR)
        returned = fly * back
        kept = returned * (1.0 - rates.abandon)
        arrive = fly * a
        d_uL = -found.sum() - stop * uL + resume * uI + inhibited.sum()
        d_uH = stop * uL - home * uH
        dropped = rates.abandon_rate * fI  # the "rate" reading: F_I abandons in the hub
        d_uI = (
            home * uH
            - resume * uI
            - recruit.sum()
            + (returned * rates.abandon).sum()
            + dropped.sum()
        )
        d_a = found - arrive
        d_go = recruit + resume * fI - fly * go
        d_back = fly * go - returned
        if m2:
            d_fD = arrive - leave_d * fD - inhibit_rate * fD
            d_fR = kept - leave_r * fR - inhibit_rate * fR
            into_fI = leave_d * fD + leave_r * fR
        else:
            d_fD = np.zeros(n)
            d_fR = np.zeros(n)
            into_fI = arrive + kept
        d_fI = into_fI - resume * fI - inhibit_rate * fI - dropped
        # Quorum hazard of F_I(i) agents (expected quorum events per second).
        receive = total_send / hub
        share = np.clip(send / max(total_send, 1e-12), 0.0, 1.0)
        d_hazard = big_n * fI * receive * (1.0 - share) * share**k
        survival = np.exp(-y[3 + 6 * n : 3 + 7 * n].sum())
        return np.concatenate(
            (
                [d_uL, d_uH, d_uI],
                d_a,
                d_go,
                d_back,
                d_fI,
                d_fD,
                d_fR,
                d_hazard,
                [survival],
                d_hazard * survival,
            )
        )

    y0 = np.zeros(3 + 8 * n + 1)
    y0[2] = 1.0
    solution = solve_ivp(derivative, (0.0, horizon), y0, method="LSODA", rtol=1e-6, atol=1e-9)
    end = solution.y[:, -1]
    win = end[-n:]
    decided = float(win.sum())
    survival_integral = float(end[-n - 1])
    undecided = 1.0 - decided
    # E[T | T ≤ horizon] = (∫_0^h S dt − h·S(h)) / (1 − S(h)).
    quorum_s = (survival_integral - horizon * undecided) / decided if decided > 1e-9 else np.inf
    best = int(np.argmax(win))
    return Prediction(
        win_probability=tuple(float(w) for w in win),
        undecided=undecided,
        quorum_s=float(quorum_s),
        decision_s=float(quorum_s + commitment_latency_s(sites[best], params)),
    )
