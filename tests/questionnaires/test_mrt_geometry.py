"""Geometric truth of the MRT item bank, checked independently of the generator.

The cube rotation group here comes from scipy (the octahedral group), not from
`shapes.rotation_group`, and chains and bends are read off the cubes with
test-local code, so a bug in the generator cannot hide itself.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hcss.questionnaires.mrt import shapes
from hcss.questionnaires.mrt.items import AlternativeKind, Figure, item_bank, practice_items

ALL_ITEMS = item_bank() + practice_items()
SCIPY_CUBE_ROTATIONS = np.rint(Rotation.create_group("O").as_matrix()).astype(int)


def normalised(cubes: np.ndarray) -> tuple[tuple[int, ...], ...]:
    cubes = np.asarray(cubes, dtype=int)
    return tuple(sorted(map(tuple, (cubes - cubes.min(axis=0)).tolist())))


def lattice_rotations_onto(cubes: np.ndarray, reference: np.ndarray) -> list[np.ndarray]:
    """Every cube rotation R with R @ cubes equal to reference up to translation."""
    goal = normalised(reference)
    return [r for r in SCIPY_CUBE_ROTATIONS if normalised(np.asarray(cubes) @ r.T) == goal]


def chain(cubes: np.ndarray) -> list[int]:
    """Cube indices along the chain from one end; asserts the cubes form a simple chain."""
    cubes = np.asarray(cubes, dtype=int)
    touching = {
        (i, j)
        for i, j in itertools.permutations(range(len(cubes)), 2)
        if np.abs(cubes[i] - cubes[j]).sum() == 1
    }
    assert len(touching) == 2 * (len(cubes) - 1), "only neighbours along the chain may touch"
    neighbours = {i: [j for (a, j) in touching if a == i] for i in range(len(cubes))}
    ends = [i for i, found in neighbours.items() if len(found) == 1]
    assert len(ends) == 2
    order = [min(ends)]
    while len(order) < len(cubes):
        order.append(next(j for j in neighbours[order[-1]] if j not in order))
    return order


def bends(cubes: np.ndarray) -> int:
    ordered = np.asarray(cubes, dtype=int)[chain(cubes)]
    moves = np.diff(ordered, axis=0)
    return sum(not np.array_equal(a, b) for a, b in itertools.pairwise(moves))


def best_proper_fit(points: np.ndarray, reference: np.ndarray) -> float:
    """Least RMS residual of fitting `reference` by a proper rotation of `points` (Kabsch)."""
    covariance = points.T @ reference
    u, _, vt = np.linalg.svd(covariance)
    sign = np.sign(np.linalg.det(u @ vt))
    rotation = (u @ np.diag([1.0, 1.0, sign]) @ vt).T
    return float(np.sqrt(((points @ rotation.T - reference) ** 2).sum(axis=1).mean()))


def drawn_fit(figure: Figure, reference: Figure) -> float:
    """Best proper-rotation fit between two drawings, over both chain correspondences.

    An isometry taking one chain of cubes onto another keeps face-adjacency, so
    it maps the chain to itself forwards or backwards; these two
    correspondences are therefore the only ones any 3-D rotation could realise.
    """
    points = figure.drawn_centres()[chain(figure.cube_array())]
    goal = reference.drawn_centres()[chain(reference.cube_array())]
    return min(best_proper_fit(points, goal), best_proper_fit(points[::-1], goal))


def every_figure() -> list[Figure]:
    return [figure for item in ALL_ITEMS for figure in (item.target, *item.alternatives)]


def test_library_rotation_group_is_the_cube_group() -> None:
    ours = {tuple(r.ravel()) for r in shapes.rotation_group()}
    assert len(ours) == 24
    assert ours == {tuple(r.ravel()) for r in SCIPY_CUBE_ROTATIONS}


def test_every_figure_is_ten_cubes_in_four_straight_arms_using_three_axes() -> None:
    for figure in every_figure():
        cubes = figure.cube_array()
        assert len(cubes) == 10
        assert len({tuple(c) for c in cubes.tolist()}) == 10
        assert bends(cubes) == 3
        ordered = cubes[chain(cubes)]
        assert np.all(np.abs(np.diff(ordered, axis=0)).sum(axis=0) > 0), "figure is planar"


def test_every_figure_is_chiral() -> None:
    """No cube rotation maps the mirror image onto the figure, after translation."""
    for figure in every_figure():
        cubes = figure.cube_array()
        mirrored = cubes * np.array([-1, 1, 1])
        assert lattice_rotations_onto(mirrored, cubes) == []
        assert lattice_rotations_onto(cubes, cubes), "sanity: the identity must match"


def test_catalogue_figures_are_all_chiral_and_distinct_up_to_mirror() -> None:
    forms = set()
    for path in shapes.figure_catalogue():
        cubes = path.cubes()
        assert shapes.is_figure(cubes)
        assert lattice_rotations_onto(shapes.mirror(cubes), cubes) == []
        forms.add(shapes.canonical_form(cubes))
        forms.add(shapes.canonical_form(shapes.mirror(cubes)))
    assert len(forms) == 2 * len(shapes.figure_catalogue())


def test_figure_check_rejects_planar_achiral_and_wrongly_sized_shapes() -> None:
    planar = shapes.ArmPath(((1, 0, 0), (0, 1, 0), (1, 0, 0), (0, 1, 0)), (3, 2, 2, 2))
    assert not shapes.is_figure(planar.cubes())
    assert not shapes.is_chiral(planar.cubes())
    short = shapes.ArmPath(((1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 0)), (2, 2, 2, 2))
    assert not shapes.is_figure(short.cubes())
    touching = shapes.ArmPath(((1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, 0, 1)), (3, 1, 3, 2))
    assert not shapes.is_figure(touching.cubes())


@pytest.mark.parametrize("item", ALL_ITEMS, ids=lambda item: item.key)
def test_correct_alternatives_are_rotations_of_the_target(item) -> None:
    target = item.target.cube_array()
    assert len(item.alternatives) == 4
    assert len(item.correct) == 2
    for index in item.correct:
        alternative = item.alternatives[index]
        assert lattice_rotations_onto(target, alternative.cube_array())
        assert drawn_fit(alternative, item.target) < 1e-9


@pytest.mark.parametrize("item", ALL_ITEMS, ids=lambda item: item.key)
def test_distractors_are_no_rotation_of_the_target(item) -> None:
    target = item.target.cube_array()
    distractors = set(range(4)) - item.correct
    assert len(distractors) == 2
    assert AlternativeKind.MIRROR in {item.kinds[i] for i in distractors}
    for index in distractors:
        alternative = item.alternatives[index]
        assert lattice_rotations_onto(target, alternative.cube_array()) == []
        assert drawn_fit(alternative, item.target) > 0.1


def test_drawings_are_rotated_in_depth_by_non_right_angles() -> None:
    """Views are proper rotations with entries that are not 0 or ±1, and copies look different."""
    for item in ALL_ITEMS:
        for figure in (item.target, *item.alternatives):
            view = figure.view_matrix()
            assert np.allclose(view @ view.T, np.eye(3))
            assert np.isclose(np.linalg.det(view), 1.0)
            assert not np.allclose(np.abs(view), np.rint(np.abs(view)), atol=0.05)
        for index in item.correct:
            target_points = item.target.drawn_centres()[chain(item.target.cube_array())]
            copy = item.alternatives[index]
            copy_points = copy.drawn_centres()[chain(copy.cube_array())]
            identical = min(
                np.abs(copy_points - target_points).max(),
                np.abs(copy_points[::-1] - target_points).max(),
            )
            assert identical > 0.5, f"{item.key}: a correct alternative is drawn like the target"


def test_bank_has_two_parts_of_twelve_with_distinct_targets() -> None:
    bank = item_bank()
    assert [item.key for item in bank] == [f"mrt_{n:02d}" for n in range(1, 25)]
    assert [item.part for item in bank] == [1] * 12 + [2] * 12
    assert all(item.part == 0 for item in practice_items())
    families = set()
    for item in ALL_ITEMS:
        cubes = item.target.cube_array()
        families.add(min(shapes.canonical_form(cubes), shapes.canonical_form(shapes.mirror(cubes))))
    assert len(families) == len(ALL_ITEMS)
