"""Shepard-Metzler figures as polycubes on the integer lattice.

The published Mental Rotations Test drawings are under copyright, so the
figures are generated. A figure is ten unit cubes joined face to face in four
straight arms (three right-angle bends) that use all three axes, which makes it
chiral: its mirror image is a different figure that no rotation can produce.

Geometric truth is decided on the lattice, exactly, with integers. Any rotation
that maps one lattice polycube onto another (up to translation) maps the cube
face normals, i.e. the coordinate axes, onto themselves, so it is one of the 24
rotations of the cube. Comparing canonical forms under those 24 rotations
therefore answers "is B a rotation of A?" for *every* 3-D rotation, not only
the 90-degree ones. The arbitrary view angles used for drawing are applied
afterwards and do not change what is true.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import cache

import numpy as np

from hcss.questionnaires.mrt.once import built_once

CUBE_COUNT = 10
ARM_COUNT = 4
#: Arm lengths in cubes (corner cubes count in both arms). Two-cube stubs and
#: very long arms make figures that read poorly, so at most one stub is allowed
#: and no arm is longer than five cubes; that still leaves 78 figure pairs.
MIN_ARM_CUBES = 2
MAX_ARM_CUBES = 5
MAX_STUB_ARMS = 1

#: Reflection through the plane x = 0; any single reflection serves, because
#: all mirror images of a shape are rotations of one another.
MIRROR = np.diag([-1, 1, 1])

#: A figure's cells in a canonical, hashable form (sorted integer triples).
CanonicalForm = tuple[tuple[int, int, int], ...]


@cache
def rotation_group() -> np.ndarray:
    """The 24 proper rotations of the cube, as (24, 3, 3) integer matrices.

    They are the signed permutation matrices with determinant +1.
    """
    matrices = []
    for permutation in itertools.permutations(range(3)):
        for signs in itertools.product((1, -1), repeat=3):
            matrix = np.zeros((3, 3), dtype=np.int64)
            for row, (column, sign) in enumerate(zip(permutation, signs, strict=True)):
                matrix[row, column] = sign
            if round(np.linalg.det(matrix)) == 1:
                matrices.append(matrix)
    group = np.array(matrices)
    group.setflags(write=False)
    return group


@dataclass(frozen=True)
class ArmPath:
    """A figure described as it is built: four arms, each a direction and a step count.

    `steps[i]` cubes are added along `directions[i]`; with the first cube at
    the origin, the figure has `1 + sum(steps)` cubes.
    """

    directions: tuple[tuple[int, int, int], ...]
    steps: tuple[int, ...]

    def cubes(self) -> np.ndarray:
        """Cube positions in build order, shape (n, 3)."""
        position = np.zeros(3, dtype=np.int64)
        cells = [position.copy()]
        for direction, count in zip(self.directions, self.steps, strict=True):
            for _ in range(count):
                position = position + np.asarray(direction, dtype=np.int64)
                cells.append(position.copy())
        return np.array(cells)


def normalise(cubes: np.ndarray) -> CanonicalForm:
    """Translate to the origin and sort, so equal cube sets compare equal."""
    shifted = np.asarray(cubes, dtype=np.int64) - np.asarray(cubes).min(axis=0)
    return tuple(sorted((int(row[0]), int(row[1]), int(row[2])) for row in shifted))


def canonical_form(cubes: np.ndarray) -> CanonicalForm:
    """The least normalised form over the 24 cube rotations: equal iff rotations of each other."""
    return min(normalise(np.asarray(cubes) @ rotation.T) for rotation in rotation_group())


def mirror(cubes: np.ndarray) -> np.ndarray:
    return np.asarray(cubes) @ MIRROR.T


def is_rotation_of(cubes: np.ndarray, reference: np.ndarray) -> bool:
    return canonical_form(cubes) == canonical_form(reference)


def is_chiral(cubes: np.ndarray) -> bool:
    """True when no rotation maps the mirror image onto the figure."""
    return canonical_form(mirror(cubes)) != canonical_form(cubes)


def path_order(cubes: np.ndarray) -> np.ndarray:
    """Indices of the cubes in order along the figure, from one end.

    Raises ValueError unless the face-adjacency graph is a simple path. That is
    what makes the arms readable in a drawing: no two cubes touch except
    neighbours along the figure, so the figure cannot be read as a block.
    """
    cells = np.asarray(cubes, dtype=np.int64)
    if len({tuple(row) for row in cells}) != len(cells):
        raise ValueError("two cubes occupy the same cell")
    gaps = np.abs(cells[:, None, :] - cells[None, :, :]).sum(axis=2)
    adjacent = gaps == 1
    degree = adjacent.sum(axis=1)
    ends = np.flatnonzero(degree == 1)
    if len(ends) != 2 or np.any(degree > 2) or np.any(degree == 0):
        raise ValueError("the cubes do not form a single unbranched chain")
    order = [int(ends.min())]
    previous = -1
    while len(order) < len(cells):
        neighbours = [int(n) for n in np.flatnonzero(adjacent[order[-1]]) if n != previous]
        if len(neighbours) != 1:
            raise ValueError("the cubes do not form a single unbranched chain")
        previous = order[-1]
        order.append(neighbours[0])
    if int(adjacent.sum()) // 2 != len(cells) - 1:
        raise ValueError("cubes that are not neighbours along the chain touch")
    return np.array(order)


def arm_cube_counts(cubes: np.ndarray) -> tuple[int, ...]:
    """Cubes in each straight arm, read off the cubes alone (corners count twice)."""
    ordered = np.asarray(cubes, dtype=np.int64)[path_order(cubes)]
    moves = np.diff(ordered, axis=0)
    counts = []
    run = 1
    for index in range(1, len(moves)):
        if np.array_equal(moves[index], moves[index - 1]):
            run += 1
        else:
            counts.append(run + 1)
            run = 1
    counts.append(run + 1)
    return tuple(counts)


def spans_three_axes(cubes: np.ndarray) -> bool:
    ordered = np.asarray(cubes, dtype=np.int64)[path_order(cubes)]
    moves = np.abs(np.diff(ordered, axis=0))
    return bool(np.all(moves.sum(axis=0) > 0))


def is_figure(cubes: np.ndarray) -> bool:
    """Whether the cubes make a valid test figure: 10 cubes, 4 straight arms, 3-D, chiral.

    Chirality is checked, not assumed: a non-planar four-arm chain is almost
    always chiral, but the test's logic depends on it for every figure.
    """
    if len(cubes) != CUBE_COUNT:
        return False
    try:
        arms = arm_cube_counts(cubes)
    except ValueError:
        return False
    return (
        len(arms) == ARM_COUNT
        and min(arms) >= MIN_ARM_CUBES
        and max(arms) <= MAX_ARM_CUBES
        and arms.count(MIN_ARM_CUBES) <= MAX_STUB_ARMS
        and spans_three_axes(cubes)
        and is_chiral(cubes)
    )


def _step_splits(total: int, parts: int) -> list[tuple[int, ...]]:
    """All ways to split `total` steps into `parts` arms of at least one step."""
    return [
        tuple(b - a for a, b in zip((0, *cuts), (*cuts, total), strict=True))
        for cuts in itertools.combinations(range(1, total), parts - 1)
    ]


@built_once
def figure_catalogue() -> tuple[ArmPath, ...]:
    """Every valid figure up to rotation, one chiral pair per entry, in a fixed order.

    The first two arms are fixed to +x then +y without loss of generality (the
    24 rotations act simply transitively on such ordered pairs of axes). Of
    each mirror pair only the member with the smaller canonical form is kept,
    so that two entries are never mirror images of each other and a mirror can
    always serve as a distractor for exactly one target.
    """
    perpendicular = {
        axis: [other for other in _axis_directions() if np.dot(axis, other) == 0 and other != axis]
        for axis in _axis_directions()
    }
    seen: set[CanonicalForm] = set()
    catalogue: list[tuple[CanonicalForm, ArmPath]] = []
    for steps in _step_splits(CUBE_COUNT - 1, ARM_COUNT):
        for third in perpendicular[(0, 1, 0)]:
            for fourth in perpendicular[third]:
                path = ArmPath(((1, 0, 0), (0, 1, 0), third, fourth), steps)
                cubes = path.cubes()
                if not is_figure(cubes):
                    continue
                own, mirrored = canonical_form(cubes), canonical_form(mirror(cubes))
                if own in seen or mirrored in seen:
                    continue
                seen.update((own, mirrored))
                if own < mirrored:
                    catalogue.append((own, path))
                else:
                    catalogue.append((mirrored, _mirror_path(path)))
    catalogue.sort(key=lambda entry: entry[0])
    return tuple(path for _, path in catalogue)


def _axis_directions() -> list[tuple[int, int, int]]:
    return [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]


def _mirror_path(path: ArmPath) -> ArmPath:
    mirrored = (MIRROR @ np.asarray(d) for d in path.directions)
    flipped = tuple((int(x), int(y), int(z)) for x, y, z in mirrored)
    return ArmPath(flipped, path.steps)
