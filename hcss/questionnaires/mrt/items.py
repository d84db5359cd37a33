"""The MRT item bank: generated from fixed seeds, identical for every participant.

Each item shows a target figure and four alternatives. Two alternatives are
the target turned to another orientation; the other two are its mirror image
or a figure of another structure, also turned. What is true is decided on the
lattice (`shapes`): every stored figure's cubes are the catalogue figure moved
by one of the 24 cube rotations (and a reflection, for mirror distractors).
What is drawn adds an arbitrary, non-right-angle view rotation on top, a
proper rotation, so the drawing of a correct alternative is a rotation in
depth of the drawing of the target and the task cannot be solved by matching
outlines.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from functools import cached_property

import numpy as np

from hcss.questionnaires.mrt import shapes
from hcss.questionnaires.mrt.once import built_once
from hcss.questionnaires.mrt.render import figure_radius, figure_svg

BANK_SEED = 1971
ITEM_COUNT = 24
PRACTICE_COUNT = 4
ALTERNATIVE_COUNT = 4

#: View tilt (looking down on the figure), as in the classic drawings.
_TILT_RANGE_DEG = (16.0, 34.0)
#: Keep the yaw this far from right angles so no arm is seen end-on or square-on.
_MIN_YAW_FROM_RIGHT_ANGLE_DEG = 12.0
#: An arm whose axis points this much toward the viewer is too foreshortened to read.
_MAX_AXIS_TOWARD_VIEWER = 0.9
#: Two drawings of the same figure in one item differ by at least this rotation.
_MIN_ORIENTATION_GAP_DEG = 35.0
#: Drawn cube centres closer than this (in cube widths) mean one cube mostly
#: hides another, and the figure's structure cannot be seen.
_MIN_DRAWN_CENTRE_GAP = 0.6
#: Bound on view draws per figure, so an impossible constraint fails loudly instead of hanging.
_MAX_VIEW_ATTEMPTS = 10_000


class AlternativeKind(StrEnum):
    ROTATION = "rotation"
    MIRROR = "mirror"
    OTHER = "other"


@dataclass(frozen=True)
class Figure:
    """Lattice cubes (the truth) and the view rotation used to draw them."""

    cubes: tuple[tuple[int, int, int], ...]
    view: tuple[tuple[float, float, float], ...]

    def cube_array(self) -> np.ndarray:
        return np.array(self.cubes, dtype=np.int64)

    def view_matrix(self) -> np.ndarray:
        return np.array(self.view, dtype=float)

    def drawn_centres(self) -> np.ndarray:
        """Cube centres as drawn (view coordinates, centroid at the origin)."""
        cells = self.cube_array().astype(float)
        return np.asarray((cells - cells.mean(axis=0)) @ self.view_matrix().T)

    def radius(self) -> float:
        return figure_radius(self.cube_array())

    def svg(self, *, radius: float | None = None, label: str = "") -> str:
        return figure_svg(self.cube_array(), self.view_matrix(), radius=radius, label=label)


@dataclass(frozen=True)
class MrtItem:
    """One test or practice item; `part` is 1 or 2, or 0 for practice."""

    key: str
    number: int
    part: int
    target: Figure
    alternatives: tuple[Figure, ...]
    kinds: tuple[AlternativeKind, ...]

    @property
    def correct(self) -> frozenset[int]:
        """Indices (0-based, as shown left to right) of the two rotated copies."""
        return frozenset(i for i, kind in enumerate(self.kinds) if kind is AlternativeKind.ROTATION)

    def radius(self) -> float:
        """One scale for the whole item, so rotated copies are drawn the same size."""
        return max(figure.radius() for figure in (self.target, *self.alternatives))

    def target_svg(self) -> str:
        return self._drawings[0]

    def alternative_svgs(self) -> tuple[str, ...]:
        return self._drawings[1:]

    @cached_property
    def _drawings(self) -> tuple[str, ...]:
        """The target's and the alternatives' SVGs, drawn once per item.

        An item never changes, and drawing its five figures costs tens of
        milliseconds of CPU, too much to spend on every MRT page.
        """
        radius = self.radius()
        return (
            self.target.svg(radius=radius, label=f"{self.key} target figure"),
            *(
                figure.svg(radius=radius, label=f"{self.key} alternative {chr(ord('A') + i)}")
                for i, figure in enumerate(self.alternatives)
            ),
        )


def _rotation_x(degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rotation_y(degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rotation_angle_deg(rotation: np.ndarray) -> float:
    cosine = (np.trace(rotation) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def draw_view(rng: np.random.Generator) -> np.ndarray:
    """A readable oblique view: a yaw away from right angles, then a downward tilt.

    Views that point an arm nearly at the viewer are redrawn, since that arm
    would collapse to a square and the figure could not be judged.
    """
    while True:
        yaw = float(rng.uniform(0.0, 360.0))
        tilt = float(rng.uniform(*_TILT_RANGE_DEG))
        off_right_angle = abs((yaw + 45.0) % 90.0 - 45.0)
        view = np.asarray(_rotation_x(tilt) @ _rotation_y(yaw))
        if (
            off_right_angle >= _MIN_YAW_FROM_RIGHT_ANGLE_DEG
            and np.abs(view[2]).max() <= _MAX_AXIS_TOWARD_VIEWER
        ):
            return view


def _is_legible(cubes: np.ndarray, orientation: np.ndarray) -> bool:
    """Whether every cube stays visibly apart from every other in the drawing."""
    drawn = (np.asarray(cubes, dtype=float) @ orientation.T)[:, :2]
    gaps = np.linalg.norm(drawn[:, None, :] - drawn[None, :, :], axis=2)
    np.fill_diagonal(gaps, np.inf)
    return bool(gaps.min() >= _MIN_DRAWN_CENTRE_GAP)


def _as_figure(cubes: np.ndarray, view: np.ndarray) -> Figure:
    cells = np.asarray(cubes, dtype=np.int64)
    cells = cells - cells.min(axis=0)
    return Figure(
        cubes=tuple((int(x), int(y), int(z)) for x, y, z in cells),
        view=tuple((float(x), float(y), float(z)) for x, y, z in view),
    )


def _turned_copies(
    base: np.ndarray, count: int, rng: np.random.Generator, shown: list[np.ndarray]
) -> list[Figure]:
    """`count` drawings of `base`, each at an orientation far from all in `shown`.

    `shown` holds the drawn orientations (view times lattice rotation) of the
    same figure already in the item and is extended in place.
    """
    group = shapes.rotation_group()
    figures: list[Figure] = []
    for _ in range(_MAX_VIEW_ATTEMPTS):
        if len(figures) == count:
            return figures
        lattice = group[int(rng.integers(len(group)))].astype(float)
        view = draw_view(rng)
        orientation = view @ lattice
        if _is_legible(base, orientation) and all(
            rotation_angle_deg(orientation @ other.T) >= _MIN_ORIENTATION_GAP_DEG for other in shown
        ):
            shown.append(orientation)
            figures.append(_as_figure(base @ lattice.T, view))
    if len(figures) == count:
        return figures
    raise RuntimeError("no legible, distinct views found for a figure; relax the view limits")


def build_item(
    key: str, number: int, part: int, family: int, other_family: int, seed: int
) -> MrtItem:
    """One item from catalogue entries `family` (target) and `other_family` (a distractor).

    The item's own generator is seeded from (seed, number), so items do not
    depend on one another's random draws.
    """
    rng = np.random.default_rng([seed, number])
    catalogue = shapes.figure_catalogue()
    base = catalogue[family].cubes()
    if rng.random() < 0.5:
        base = shapes.mirror(base)
    mirrored = shapes.mirror(base)
    other = catalogue[other_family].cubes()
    if rng.random() < 0.5:
        other = shapes.mirror(other)

    shown: list[np.ndarray] = []
    target, *rotated = _turned_copies(base, 3, rng, shown)
    distractor_kinds = [AlternativeKind.MIRROR, AlternativeKind(rng.choice(["mirror", "other"]))]
    mirror_count = distractor_kinds.count(AlternativeKind.MIRROR)
    distractors = _turned_copies(mirrored, mirror_count, rng, [])
    if mirror_count == 1:
        distractors += _turned_copies(other, 1, rng, [])

    kinds = [AlternativeKind.ROTATION] * 2 + distractor_kinds
    figures = rotated + distractors
    order = rng.permutation(ALTERNATIVE_COUNT)
    return MrtItem(
        key=key,
        number=number,
        part=part,
        target=target,
        alternatives=tuple(figures[i] for i in order),
        kinds=tuple(kinds[i] for i in order),
    )


def build_bank(seed: int = BANK_SEED) -> tuple[tuple[MrtItem, ...], tuple[MrtItem, ...]]:
    """(test items, practice items), with a different target figure for every item.

    Targets are distinct catalogue entries (never mirror images of one
    another); an "other" distractor comes from the entries no target uses.
    """
    catalogue_size = len(shapes.figure_catalogue())
    families = np.random.default_rng([seed, 0]).permutation(catalogue_size)
    target_families = families[: ITEM_COUNT + PRACTICE_COUNT]
    spare_families = families[ITEM_COUNT + PRACTICE_COUNT :]
    test_items = tuple(
        build_item(
            key=f"mrt_{number:02d}",
            number=number,
            part=1 if number <= ITEM_COUNT // 2 else 2,
            family=int(target_families[number - 1]),
            other_family=int(spare_families[(number - 1) % len(spare_families)]),
            seed=seed,
        )
        for number in range(1, ITEM_COUNT + 1)
    )
    practice_items = tuple(
        build_item(
            key=f"mrt_practice_{number}",
            number=ITEM_COUNT + number,
            part=0,
            family=int(target_families[ITEM_COUNT + number - 1]),
            other_family=int(spare_families[-number]),
            seed=seed,
        )
        for number in range(1, PRACTICE_COUNT + 1)
    )
    return test_items, practice_items


@built_once
def _bank() -> tuple[tuple[MrtItem, ...], tuple[MrtItem, ...]]:
    return build_bank()


def item_bank() -> tuple[MrtItem, ...]:
    """The 24 scored items, in presentation order (part 1 is items 1-12)."""
    return _bank()[0]


def practice_items() -> tuple[MrtItem, ...]:
    """The practice items shown, with feedback, before part 1."""
    return _bank()[1]
