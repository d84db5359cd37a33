"""Scenarios: the target layout of every section and the trial's seed (spec §2).

A scenario is a value object. The same scenario is used by a human trial and by
the simulation-only experiment, so it can be saved to JSON, loaded and
replayed. Layouts are drawn from the seed's own stream, independent of the
stream that drives the agents, so replicates of one scenario share a layout.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from hcss.simulation.params import Params

KINDS = ("easy", "difficult")
START_HUBS = ((-1.0, 1.0), (1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))  # I, II, III, IV (× offset)
MAX_COLLECTIVES = 64  # the study has 4; more only for scaling runs
_MAX_DRAWS = 10_000


class ScenarioError(ValueError):
    """A scenario cannot be built or loaded as asked."""


@dataclass(frozen=True)
class PlacedTarget:
    """One target of one section, placed around the hub of the collective it was drawn for."""

    id: int  # 1-based over the whole trial, as shown to the operator
    x: float
    y: float
    value: float
    around: int  # index of the collective whose start hub it was placed around


@dataclass(frozen=True)
class Section:
    """One section: every collective's first-decision kind and the targets placed for it."""

    kinds: tuple[str, ...]  # one per collective: "easy" or "difficult"
    targets: tuple[PlacedTarget, ...]


@dataclass(frozen=True)
class Scenario:
    """Target layouts for every section, the start hubs and the trial seed."""

    scenario_id: str
    seed: int
    first_section: str
    hubs: tuple[tuple[float, float], ...]
    sections: tuple[Section, ...]

    @property
    def n_collectives(self) -> int:
        return len(self.hubs)

    @property
    def n_targets(self) -> int:
        return sum(len(s.targets) for s in self.sections)

    @classmethod
    def generate(
        cls,
        seed: int,
        first_section: str = "easy",
        n_collectives: int = 4,
        scenario_id: str | None = None,
        params: Params | None = None,
    ) -> Scenario:
        """A two-section trial: one section easy for every collective, one difficult."""
        if first_section not in KINDS:
            raise ScenarioError(
                f"first_section must be 'easy' or 'difficult', not {first_section!r}"
            )
        second = "difficult" if first_section == "easy" else "easy"
        kinds = [(first_section,) * n_collectives, (second,) * n_collectives]
        return cls._build(seed, kinds, scenario_id or f"s{seed}-{first_section}", params)

    @classmethod
    def training(cls, seed: int, params: Params | None = None) -> Scenario:
        """The training trial: two collectives, one easy decision and one difficult."""
        return cls._build(seed, [("easy", "difficult")], f"training-{seed}", params)

    @classmethod
    def _build(
        cls,
        seed: int,
        kinds_per_section: list[tuple[str, ...]],
        scenario_id: str,
        params: Params | None,
    ) -> Scenario:
        params = params or Params()
        n_collectives = len(kinds_per_section[0])
        if not 1 <= n_collectives <= MAX_COLLECTIVES:
            raise ScenarioError(f"between 1 and {MAX_COLLECTIVES} collectives, not {n_collectives}")
        hubs = start_hubs(n_collectives, params)
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(0,)))
        sections = []
        next_id = 1
        for kinds in kinds_per_section:
            targets = _place_section(rng, hubs, kinds, params, next_id)
            next_id += len(targets)
            sections.append(Section(kinds=tuple(kinds), targets=tuple(targets)))
        return cls(
            scenario_id=scenario_id,
            seed=int(seed),
            first_section=kinds_per_section[0][0],
            hubs=hubs,
            sections=tuple(sections),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "scenario_id": self.scenario_id,
            "seed": self.seed,
            "first_section": self.first_section,
            "hubs": [list(h) for h in self.hubs],
            "sections": [
                {
                    "kinds": list(s.kinds),
                    "targets": [
                        {"id": t.id, "x": t.x, "y": t.y, "value": t.value, "around": t.around}
                        for t in s.targets
                    ],
                }
                for s in self.sections
            ],
        }

    @classmethod
    def from_dict(cls, raw: dict[str, Any]) -> Scenario:
        try:
            return cls(
                scenario_id=str(raw["scenario_id"]),
                seed=int(raw["seed"]),
                first_section=str(raw["first_section"]),
                hubs=tuple((float(x), float(y)) for x, y in raw["hubs"]),
                sections=tuple(
                    Section(
                        kinds=tuple(s["kinds"]),
                        targets=tuple(PlacedTarget(**t) for t in s["targets"]),
                    )
                    for s in raw["sections"]
                ),
            )
        except (KeyError, TypeError, ValueError) as error:
            raise ScenarioError(f"not a scenario: {error}") from error


def one_collective(
    sites: list[tuple[float, float]], seed: int, scenario_id: str, bearing_offset_rad: float
) -> Scenario:
    """One collective at the origin, a site per (distance m, value), spread evenly in bearing.

    The simple layouts of the calibration and of the mean-field cross-check;
    each keeps its own bearing offset so that its walks stay as they were.
    """
    bearings = 2.0 * np.pi * np.arange(len(sites)) / len(sites) + bearing_offset_rad
    targets = tuple(
        PlacedTarget(i + 1, round(d * math.cos(b), 3), round(d * math.sin(b), 3), value, 0)
        for i, ((d, value), b) in enumerate(zip(sites, bearings, strict=True))
    )
    return Scenario(
        scenario_id=scenario_id,
        seed=seed,
        first_section="easy",
        hubs=((0.0, 0.0),),
        sections=(Section(kinds=("easy",), targets=targets),),
    )


def start_hubs(n_collectives: int, params: Params) -> tuple[tuple[float, float], ...]:
    """The study's square of four hubs; larger worlds (for scaling runs) use a grid of the same spacing.

    A grid of more than four hubs needs an arena larger than the study's:
    pass ``params.with_changes(arena_side_m=...)``.
    """
    if n_collectives <= len(START_HUBS):
        return tuple(
            (sx * params.hub_offset_m, sy * params.hub_offset_m)
            for sx, sy in START_HUBS[:n_collectives]
        )
    side = int(np.ceil(np.sqrt(n_collectives)))
    spacing = 2.0 * params.hub_offset_m
    offsets = (np.arange(side) - (side - 1) / 2.0) * spacing
    grid = [(float(x), float(-y)) for y in offsets for x in offsets]
    return tuple(grid[:n_collectives])


def _place_section(
    rng: np.random.Generator,
    hubs: tuple[tuple[float, float], ...],
    kinds: tuple[str, ...],
    params: Params,
    first_id: int,
) -> list[PlacedTarget]:
    """Four targets around each hub: values 0.7–1.0, the best near (easy) or far (difficult).

    In an easy layout the others lie anywhere or strictly farther than the best
    (`params.easy_layout_others`); in a difficult one always strictly nearer.
    """
    placed: list[tuple[float, float]] = []
    targets: list[PlacedTarget] = []
    distances = np.array(params.target_distances_m)
    best = max(params.target_values)
    for around, (kind, hub) in enumerate(zip(kinds, hubs, strict=True)):
        for value in params.target_values:
            if value == best:
                choices = distances[[0]] if kind == "easy" else distances[[-1]]
            elif kind == "difficult":
                choices = distances[distances < distances[-1]]
            elif params.easy_layout_others == "strictly_farther":
                choices = distances[distances > distances[0]]
            else:
                choices = distances
            x, y = _draw_position(rng, hub, choices, hubs, placed, params)
            placed.append((x, y))
            targets.append(PlacedTarget(first_id + len(targets), x, y, float(value), around))
    return targets


def _draw_position(
    rng: np.random.Generator,
    hub: tuple[float, float],
    distances: np.ndarray,
    hubs: tuple[tuple[float, float], ...],
    placed: list[tuple[float, float]],
    params: Params,
) -> tuple[float, float]:
    half = params.arena_side_m / 2.0
    others = np.array(list(hubs) + placed, dtype=float)
    for _ in range(_MAX_DRAWS):
        distance = rng.choice(distances)
        bearing = rng.uniform(0.0, 2.0 * np.pi)
        x = hub[0] + distance * math.cos(bearing)  # libm's: numpy's differs by CPU
        y = hub[1] + distance * math.sin(bearing)
        if abs(x) > half or abs(y) > half:
            continue
        if np.min(np.hypot(others[:, 0] - x, others[:, 1] - y)) < params.min_separation_m:
            continue
        return round(float(x), 3), round(float(y), 3)
    raise ScenarioError("could not place a target within the arena and separation rules")
