"""Decisions: difficulty, correctness and the records the analysis reads (spec §2, §9).

A decision runs from its start (section start, or the relocation that ended
the collective's previous decision) to the relocation that ends it. Its
difficulty is fixed at its start; its correctness is judged against the
targets available when the collective began executing the move.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any

from hcss.simulation.messages import collective_name
from hcss.simulation.params import Params
from hcss.tablespec import DECISIONS

if TYPE_CHECKING:
    from hcss.simulation.world import World

#: The columns of the decisions table, in order: its contract's (hcss.tablespec.DECISIONS).
DECISION_COLUMNS: tuple[str, ...] = DECISIONS.names


@dataclass
class OpenDecision:
    """A collective's decision under way."""

    collective: int
    section: int
    index: int
    start_s: float
    difficulty: str
    best_target: int = -1  # set when the move begins
    best_value: float = math.nan
    requests: dict[str, int] = field(
        default_factory=lambda: {
            "investigate": 0,
            "abandon": 0,
            "decide": 0,
            "cancel": 0,
            "interventions": 0,
        }
    )


@dataclass(frozen=True)
class DecisionRecord:
    """One finished decision, with the columns the simulation itself knows."""

    model: str
    scenario_id: str
    seed: int
    first_section: str
    section: int  # 1-based
    section_kind: str
    collective: int
    decision_index: int
    difficulty: str
    start_s: float
    end_s: float
    timed_out: bool
    chosen_target: int | None
    chosen_value: float | None
    chosen_distance_m: float | None
    best_target: int | None
    best_value: float | None
    correct: bool
    n_investigate: int
    n_abandon: int
    n_decide: int
    n_interventions: int

    @property
    def decision_time_s(self) -> float:
        return self.end_s - self.start_s

    def as_row(
        self, source: str = "simulation", participant: str = "", trial_id: str = "", run: int = 0
    ) -> dict[str, Any]:
        """The record as a row of the decisions table (docs/data-dictionary.md)."""
        row = asdict(self)
        row.update(
            source=source,
            participant=participant,
            trial_id=trial_id,
            run=run,
            collective=collective_name(self.collective),
            decision_time_s=self.decision_time_s,
            n_requests=self.n_investigate + self.n_abandon + self.n_decide,
        )
        return {column: row[column] for column in DECISION_COLUMNS}


def in_range_targets(world: World, collective: int, params: Params) -> list[int]:
    """Active targets within R of the hub and not reserved by another collective.

    Under the reading `foreign_targets="own_only"`, only the targets placed
    around the collective's own start hub. Plain Python over the few targets:
    numpy's per-call cost dominates on arrays this small, and the engine asks
    at every move and every new decision.
    """
    own_only = params.foreign_targets == "own_only"
    limit = params.exploration_range_m
    return [
        t
        for t, (active, distance, owner, around) in enumerate(
            zip(
                world.active.tolist(),
                world.hub_distance[collective].tolist(),
                world.reserved_by.tolist(),
                world.target_around.tolist(),
                strict=True,
            )
        )
        if active
        and distance <= limit
        and (owner < 0 or owner == collective)
        and (not own_only or around == collective)
    ]


def best_available(world: World, collective: int, params: Params) -> int:
    """The highest-valued available target (nearest on ties), or -1 when there is none."""
    candidates = in_range_targets(world, collective, params)
    if not candidates:
        return -1
    value, distance = world.target_value.tolist(), world.hub_distance[collective].tolist()
    return min(candidates, key=lambda t: (-value[t], distance[t]))


NEARER_TOLERANCE_M = 0.01  # target coordinates are stored to the millimetre


def label_distance(distance_m: float, params: Params) -> float:
    """A hub-to-target distance as the label compares it: exact, or its ring's index."""
    if params.label_distances == "ring":
        # to the millimetre first, so a site placed on a ring's edge keeps its ring
        return float(math.floor(round(distance_m, 3) / params.label_ring_m))
    return distance_m


def difficulty(
    world: World, collective: int, params: Params, layout_kind: str | None = None
) -> str:
    """Easy or difficult, fixed at the decision's start, under the chosen label.

    "best_nearest": difficult if a lower-valued target in range is strictly
    nearer than the best one. "best_not_furthest": difficult only when,
    besides, no other target in range is strictly farther than the best; a
    section's first decision (`layout_kind` given) keeps its layout's kind.
    Distances are exact or by ring (`params.label_distances`); "strictly"
    allows for the millimetre rounding of stored coordinates.
    """
    if layout_kind is not None and params.difficulty_label == "best_not_furthest":
        return layout_kind
    best = best_available(world, collective, params)
    if best < 0:
        return "easy"
    value = world.target_value.tolist()
    distance = [label_distance(d, params) for d in world.hub_distance[collective].tolist()]
    tolerance = NEARER_TOLERANCE_M if params.label_distances == "exact" else 0.0
    others = [t for t in in_range_targets(world, collective, params) if t != best]
    lower_nearer = any(
        value[t] < value[best] and distance[t] < distance[best] - tolerance for t in others
    )
    if params.difficulty_label == "best_not_furthest" and lower_nearer:
        farther = any(distance[t] > distance[best] + tolerance for t in others)
        return "easy" if farther else "difficult"
    return "difficult" if lower_nearer else "easy"
