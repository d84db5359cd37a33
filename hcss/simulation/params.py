"""Every parameter of the model, in one place.

The study leaves many details open; SPEC-simulation.md makes a choice for each
and marks it [choice]. They all live here, named and documented, so that a
researcher can change one without touching the engine. M1, M2 and M3 share
every value: the models differ only in their rules, never in their parameters.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

# Named readings of the paper where it can be read more than one way. Each
# option is a string, so that a trial's stored params record which one it used.
DISCOVERY_READINGS = ("spatial", "per_agent")
M2_DISTANCE_BOUNDS = ("site_distances", "search_space", "fitted")
M2_BEYOND_DMAX = ("guard", "clamp")
FOREIGN_TARGETS = ("eligible", "own_only")
M2_MECHANISMS = ("discovery_delay", "reassessment_delay", "modulation")
ABANDONMENT_READINGS = ("per_visit", "rate")
G_READINGS = ("distance_only", "value_inside")
EASY_LAYOUT_OTHERS = ("anywhere", "strictly_farther")
DIFFICULTY_LABELS = ("best_nearest", "best_not_furthest")
LABEL_DISTANCES = ("exact", "ring")
MODULATION_USES = ("queue", "recruitment", "inhibition")
M1_QUEUE_MODULATION = ("unmodulated", "modulated")
M2_D_MIN = ("search_space", "nearest_site")


@dataclass(frozen=True)
class Params:
    """Parameters of the world, the agents, the requests and the trial.

    Units are metres and seconds. Quantities called *rates* are per second and
    become a per-step probability 1 - exp(-rate * dt); quantities called
    *probabilities* apply once per event.
    """

    # --- world (spec §1) -------------------------------------------------
    arena_side_m: float = 1414.0  # square of about 2 km², origin at its centre
    hub_offset_m: float = 300.0  # hubs on a 600 m square centred in the arena
    n_agents: int = 200  # simulated UAVs per collective
    speed_mps: float = 60.0 / 3.6  # 60 km/h for every moving agent
    exploration_range_m: float = 500.0  # R, around the collective's current hub
    comm_range_m: float = 30.0  # peer-to-peer range inside the hub area
    hub_radius_m: float = 50.0  # [choice] hub area disc
    # [calibrated] An explorer this close encounters a target (discovery="spatial").
    # Fitted by `hcss simulate calibrate` so that a collective's FIRST explorer
    # finds a site at d after 1/g(d) on average (the study's g(d): 40/89/167 s
    # at 150/250/350 m): the per-collective reading of the paper's discovery rate.
    sensing_radius_m: float = 4.5
    value_error: float = 0.1  # [choice] "10% error": v·(1+e), e ~ U[-0.1, 0.1]
    dt_s: float = 1.0  # time step
    turn_sd_rad: float = 0.5  # [choice] correlated random walk turning sd

    # --- targets and scenarios (spec §2) ---------------------------------
    target_values: tuple[float, ...] = (0.7, 0.8, 0.9, 1.0)
    target_distances_m: tuple[float, ...] = (150.0, 250.0, 350.0)
    min_separation_m: float = 50.0  # [choice] from every other target and hub
    decisions_per_section: int = 6
    decision_timeout_s: float | None = 30 * 60.0  # [choice]; None in live trials

    # --- rates (spec §4) --------------------------------------------------
    resume_factor: float = 9.0  # P_L = 9 · P_U^I
    # [calibrated] r_msg, messages per second per sender. Fitted by `hcss simulate
    # calibrate` so that M1's mean decision time in the simulation-only
    # experiment is the study's published 2.46 min.
    message_rate: float = 1.65
    abandon_alpha: float = 0.05  # [choice] "5% per metre", read per 100 m
    abandon_unit_m: float = 100.0
    # [fitted in the study-calibrated preset] The scale of α: the paper's "5% per
    # metre travelled" states no unit of time or distance, so α's size is not
    # published. Multiplies α under either abandonment reading.
    abandon_scale: float = 1.0
    neighbour_draws: int = 8  # [choice] rejection-sampling draws to find a neighbour

    # --- M2 (spec §5) -----------------------------------------------------
    discovery_mu: float = 0.058  # g(d) = mu · exp(xi · d) / d, d in 100 m
    discovery_xi: float = -0.29
    discovery_unit_m: float = 100.0  # [choice] the fit's distance unit
    site_d_min_m: float = 150.0  # [choice] minimum site distance of the problem
    site_d_max_m: float = 350.0  # [choice] maximum site distance of the problem
    # [fitted in the study-calibrated preset] d_max under m2_distance_bounds="fitted":
    # a search-space bound the paper does not state, between the sites' 350 m and R.
    fitted_d_max_m: float = 500.0

    # --- readings of the paper (named options; see docs/simulation-notes.md) ---
    # How an explorer discovers a site.
    #   "spatial": by encounter within sensing_radius_m during its walk. With the
    #     calibrated radius this is the per-collective reading of g(d): "the
    #     fitted discovery rate" is the rate at which the collective's first
    #     explorer finds a site at distance d.
    #   "per_agent": the paper's P_γ = v·g(d) read per agent: every exploring
    #     agent discovers each eligible in-range site at rate g(d_i) and adopts
    #     it with probability v̂; its flights stay spatial (it flies home from
    #     where it is).
    discovery: str = "per_agent"
    # d_min and d_max of M2's delays and modulation. The paper: "the minimum and
    # maximum site distances (d_min and d_max) that define the collective's
    # search space", assuming every site distance is below d_max.
    #   "site_distances": (site_d_min_m, site_d_max_m), the problem's site
    #     distances, 150 and 350 m.
    #   "search_space": d_max is the search space's bound, R (exploration_range_m);
    #     d_min stays site_d_min_m (the search space has no inner bound but the
    #     hub, and M_i's scale is the calibrated message rate's).
    m2_distance_bounds: str = "search_space"
    # A site at d ≥ d_max (another collective's target, or any site after the hub
    # moved). The paper assumes none exists ("all site distances are below d_max").
    #   "guard": spec §5: the delays are skipped (the state is left at once) and
    #     M_i = d/d_min grows without bound (up to 3.3 at 500 m).
    #   "clamp": d is clamped to [d_min, d_max] in the delays and in M_i: such a
    #     site is treated as one at d_max (no delay, M_i = d_max/d_min).
    m2_beyond_dmax: str = "clamp"
    # Whether another collective's targets are eligible for a collective's
    # decisions. The paper's problem is one collective's search space with its
    # own sites; the study's shared arena puts neighbours' sites in range.
    #   "eligible": every active in-range target (spec §2).
    #   "own_only": only the targets placed around the collective's start hub
    #     (discovery, best target and difficulty all use only those).
    foreign_targets: str = "own_only"
    # M2's mechanisms, all on by default. Removing one is an ablation for
    # diagnosis (`hcss simulate fidelity`), never a setting of the study:
    # "discovery_delay" (F_D), "reassessment_delay" (F_R), "modulation" (M_i).
    m2_mechanisms: tuple[str, ...] = M2_MECHANISMS
    # How abandonment is applied. The paper: "P_α = α/v", abandonment of "5% per
    # metre travelled".
    #   "per_visit": once per assessment visit, on arrival at the site, with
    #     probability min(1, α·(d/100 m)/v̂) (spec §4): distance and value.
    #   "rate": a spontaneous rate α/v̂ per second while favouring and in the hub
    #     (F_I, F_D, F_R → U_I), value only: the spontaneous abandonment of Reina
    #     et al.'s design pattern, which lets supporters of poor sites drop out
    #     over time whatever their distance.
    abandonment: str = "per_visit"
    # Whether v is inside g in M2's discovery delay. The paper prints
    # g(d_i) = v_i·μ·e^(ξ·d_i)/d_i in places, and g(d) = μ·e^(ξ·d)/d where it fits it.
    #   "distance_only": P_D(i) = v̂/(1/g(d_max) − 1/g(d_i)) (spec §5).
    #   "value_inside": g carries the agent's v̂ at both distances, so the gap is
    #     divided by v̂ and P_D(i) = v̂²/(1/g(d_max) − 1/g(d_i)): poorer sites wait longer.
    #   Per-agent discovery is v̂·g(d) under both (P_γ = v·g(d) with g as fitted).
    m2_g_reading: str = "distance_only"
    # A scale on M2's discovery wait (F_D): P_D = v̂/(scale·(1/g(d_max) − 1/g(d_i))).
    # The unit of d inside g is printed as 100 m, but the paper's g was fitted to its
    # own discovery data; a longer unit shortens the wait by about a constant
    # factor, which this scale stands for. 1 is the printed reading.
    m2_discovery_wait_scale: float = 1.0
    # Where an easy layout's other three sites lie (spec §2). The paper "placed the
    # optimal site value closest".
    #   "anywhere": at any of the distances, so they may tie the best at 150 m.
    #   "strictly_farther": strictly farther than the best (250 or 350 m).
    # The difficult layout is strict under both (the best alone at 350 m).
    easy_layout_others: str = "anywhere"
    # A decision's easy/difficult label, fixed at its start (spec §2).
    #   "best_nearest": difficult when some lower-valued site is strictly nearer
    #     than the best (easy only when the best is the nearest).
    #   "best_not_furthest": difficult only when, besides that, the best is the
    #     furthest (no other site strictly farther): the layouts' own definitions,
    #     easy = optimal closest, difficult = optimal furthest. A section's first
    #     decisions keep their layout's kind.
    difficulty_label: str = "best_nearest"
    # How the label compares distances from the collective's current hub:
    # "exact" (to the millimetre) or "ring" (by label_ring_m rings: 0-100 m, 100-200 m, ...).
    label_distances: str = "exact"
    label_ring_m: float = 100.0
    # Which uses of an F_I(i) agent's messages carry M2's M_i (any non-empty set). The
    # paper's Eq. 4 puts M_i on recruitment (P_ρ) and cross-inhibition (P_σ); its quorum
    # text writes the queue's rate as M_i·P_U^L.
    #   "queue": the message counts in the receiver's quorum window (k in a row);
    #   "recruitment": it can recruit an uncommitted receiver;
    #   "inhibition": it can cross-inhibit a receiver favouring another site.
    # All three (the engine's reading before issue 39) send the whole stream at r·M_i.
    # Otherwise the sender sends at r·max(f) (f = M_i for a modulated use, 1 for the
    # others) and each message keeps each use with probability f_use/max(f), drawn
    # independently: thinning one Poisson stream, so every use's rate is exactly
    # r·f_use, and a message that keeps no use is not sent.
    m2_modulation_uses: tuple[str, ...] = MODULATION_USES
    # Whether M1's queue messages carry M_i too (the quorum's states are shared by the
    # models, and the paper's quorum text has "M_i·P_U^L"): "modulated" sends an M1
    # F_I(i) agent's queue messages at r·M_i, its recruitment and inhibition at r.
    m1_queue_modulation: str = "unmodulated"
    # d_min of M_i = d_i/d_min.
    #   "search_space": site_d_min_m (150 m), the search space's minimum site distance;
    #   "nearest_site": the distance of the nearest site of the collective's current
    #     layout (active, in range, and its own under foreign_targets="own_only"),
    #     recomputed whenever a hub moves or a section starts: the nearest site has
    #     M_i = 1 after every move.
    m2_d_min: str = "search_space"
    # The named preset these values came from (presets.py), stored with every
    # trial's params. Values changed after choosing a preset are stored beside it.
    preset: str = "literal"

    # --- quorum (spec §7) -------------------------------------------------
    quorum_k: int = 15

    # --- operator requests (spec §8) --------------------------------------
    investigate_agents: int = 10  # 5% of N
    abandon_min_supporters: int = 2
    decide_min_support: float = 0.30
    decide_agents: int = 2
    intervention_support: float = 0.10  # an abandon at or above this is an intervention
    outline_support: float = 0.30  # blue outline on the map
    visible_reports: int = 1  # reports before a target appears to the operator
    drawn_reports: int = 2  # reports before it is drawn with its value colour

    def __post_init__(self) -> None:
        for name, allowed in (
            ("discovery", DISCOVERY_READINGS),
            ("m2_distance_bounds", M2_DISTANCE_BOUNDS),
            ("m2_beyond_dmax", M2_BEYOND_DMAX),
            ("foreign_targets", FOREIGN_TARGETS),
            ("abandonment", ABANDONMENT_READINGS),
            ("m2_g_reading", G_READINGS),
            ("easy_layout_others", EASY_LAYOUT_OTHERS),
            ("difficulty_label", DIFFICULTY_LABELS),
            ("label_distances", LABEL_DISTANCES),
            ("m1_queue_modulation", M1_QUEUE_MODULATION),
            ("m2_d_min", M2_D_MIN),
        ):
            if getattr(self, name) not in allowed:
                raise ValueError(
                    f"{name} must be one of {', '.join(allowed)}, not {getattr(self, name)!r}"
                )
        unknown = set(self.m2_mechanisms) - set(M2_MECHANISMS)
        if unknown:
            raise ValueError(
                f"m2_mechanisms must be among {', '.join(M2_MECHANISMS)}, not {sorted(unknown)}"
            )
        uses = self.m2_modulation_uses
        if not uses or set(uses) - set(MODULATION_USES) or len(set(uses)) != len(uses):
            raise ValueError(
                f"m2_modulation_uses must be a non-empty set of {', '.join(MODULATION_USES)}, "
                f"not {list(uses)}"
            )
        # One order for one set, so that equal readings are equal params (and digests).
        canonical = tuple(u for u in MODULATION_USES if u in uses)
        object.__setattr__(self, "m2_modulation_uses", canonical)
        if not self.sensing_radius_m > 0 or not self.message_rate > 0:
            raise ValueError("sensing_radius_m and message_rate must be positive")
        if not self.m2_discovery_wait_scale > 0 or not self.label_ring_m > 0:
            raise ValueError("m2_discovery_wait_scale and label_ring_m must be positive")
        if not self.abandon_scale > 0 or not self.turn_sd_rad >= 0:
            raise ValueError("abandon_scale must be positive and turn_sd_rad not negative")
        if not self.site_d_min_m < self.fitted_d_max_m <= self.exploration_range_m:
            raise ValueError(
                "fitted_d_max_m must lie above site_d_min_m and at most exploration_range_m"
            )

    # --- derived quantities ----------------------------------------------
    def m2_uses(self, model: str, mechanism: str) -> bool:
        """Whether `model` runs one of M2's mechanisms (only M2 does; ablations remove them)."""
        return model == "M2" and mechanism in self.m2_mechanisms

    def modulated_uses(self, model: str) -> frozenset[str]:
        """The uses of an F_I agent's messages that carry M_i in `model` (may be empty)."""
        uses: set[str] = set()
        if self.m2_uses(model, "modulation"):
            uses |= set(self.m2_modulation_uses)
        if model == "M1" and self.m1_queue_modulation == "modulated":
            uses.add("queue")
        return frozenset(uses)

    def stored_dict(self) -> dict[str, object]:
        """The values a trial's snapshot stores and its state digest covers, in field order.

        Readings added after a release's stored snapshots (its fixtures) are left out
        while they hold their default, which is the behaviour from before they
        existed: a run under them keeps its digest and its snapshot's layout, and
        `from_dict` restores the default. (A previous version reading a snapshot that
        sets one would ignore it: only new presets set them.)
        """
        return {
            name: value
            for name, value in self.to_dict().items()
            if not (name in _LATER_READINGS and value == _LATER_READINGS[name])
        }

    @property
    def m2_d_min_m(self) -> float:
        """d_min of M2's delays and modulation, under the chosen reading."""
        return self.site_d_min_m

    def modulation_d_min_m(self, nearest_site_m: float | None) -> float:
        """d_min of M_i = d_i/d_min under `m2_d_min`: the search space's (site_d_min_m) or
        the nearest eligible site's distance (as M2 reads distances: clamped or not);
        `nearest_site_m` None (no eligible site) falls back to the search space's."""
        if self.m2_d_min == "nearest_site" and nearest_site_m is not None:
            return float(self.m2_distance(np.asarray(nearest_site_m)))
        return self.m2_d_min_m

    @property
    def m2_d_max_m(self) -> float:
        """d_max of M2's delays, under the chosen reading."""
        if self.m2_distance_bounds == "search_space":
            return self.exploration_range_m
        if self.m2_distance_bounds == "fitted":
            return self.fitted_d_max_m
        return self.site_d_max_m

    def m2_distance(self, distance_m: np.ndarray) -> np.ndarray:
        """The distance M2's delays and M_i use: as is ("guard") or clamped to [d_min, d_max]."""
        if self.m2_beyond_dmax == "clamp":
            return np.asarray(np.clip(distance_m, self.m2_d_min_m, self.m2_d_max_m))
        return np.asarray(distance_m, dtype=float)

    @property
    def mean_round_trip_s(self) -> float:
        """τ̄ = 2·(2R/3)/speed: mean round trip over the exploration disc [choice]."""
        return 2.0 * (2.0 * self.exploration_range_m / 3.0) / self.speed_mps

    @property
    def stop_exploring_rate(self) -> float:
        """P_U^I = 1/τ̄."""
        return 1.0 / self.mean_round_trip_s

    @property
    def resume_rate(self) -> float:
        """P_L = 9·P_U^I, for resuming exploration and for leaving to reassess."""
        return self.resume_factor * self.stop_exploring_rate

    @property
    def silence_limit_s(self) -> float:
        """An initiating agent executes after k/r_msg seconds without a message."""
        return self.quorum_k / self.message_rate

    def discovery_rate(self, distance_m: float | np.ndarray) -> float | np.ndarray:
        """g(d) = μ·e^(ξ·d)/d per second, d in 100 m units (works on arrays).

        The exponential is libm's (`math.exp`), not numpy's: numpy picks its float64 exp
        by CPU (AVX-512 or not), and the two differ in the last bit for a few arguments,
        which made one trial's state differ between two hosts (and a release's snapshot
        fixtures fail on another machine). g is computed per hub move, on a few values.
        """
        d = np.asarray(distance_m, dtype=float) / self.discovery_unit_m
        exp = np.asarray(np.frompyfunc(math.exp, 1, 1)(self.discovery_xi * d), dtype=float)
        return self.discovery_mu * exp / d

    def discovery_wait_gap_s(self, distance_m: np.ndarray) -> np.ndarray:
        """M2's discovery wait gap, scale·(1/g(d_max) − 1/g(d)), at M2's distance d (already
        clamped or guarded by the caller); P_D = v̂ divided by it."""
        gap = 1.0 / self.discovery_rate(self.m2_d_max_m) - 1.0 / self.discovery_rate(distance_m)
        return np.asarray(self.m2_discovery_wait_scale * gap)

    def round_trip_s(self, distance_m: float | np.ndarray) -> float | np.ndarray:
        """τ_i = 2·d_i/speed."""
        return 2.0 * distance_m / self.speed_mps

    def with_changes(self, **changes: Any) -> Params:
        """A copy with some values changed, e.g. ``params.with_changes(dt_s=0.5)``."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, object]:
        return {name: getattr(self, name) for name in self.__dataclass_fields__}

    @classmethod
    def from_dict(cls, values: Mapping[str, Any]) -> Params:
        known = {k: v for k, v in values.items() if k in cls.__dataclass_fields__}
        for key in ("target_values", "target_distances_m", "m2_mechanisms", "m2_modulation_uses"):
            if key in known:
                known[key] = tuple(known[key])  # JSON turns tuples into lists
        return cls(**known)


# Readings added after release 0.1.0 and their defaults (which reproduce the engine
# before them): `Params.stored_dict` leaves them out of a state digest while default.
_LATER_READINGS: dict[str, object] = {
    "m2_modulation_uses": MODULATION_USES,
    "m1_queue_modulation": "unmodulated",
    "m2_d_min": "search_space",
}

MODELS: tuple[str, ...] = ("M1", "M2", "M3")


def _roman(n: int) -> str:
    numerals = ((50, "L"), (40, "XL"), (10, "X"), (9, "IX"), (5, "V"), (4, "IV"), (1, "I"))
    out = ""
    for value, numeral in numerals:
        count, n = divmod(n, value)
        out += numeral * count
    return out


# Collective names: the study has four; scaling runs go up to 64.
ROMAN: tuple[str, ...] = tuple(_roman(i) for i in range(1, 65))
