"""SVG drawings: well formed, identical across processes, and correctly layered."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import xml.etree.ElementTree as ElementTree

import numpy as np

from hcss.questionnaires.mrt.items import build_bank, item_bank
from hcss.questionnaires.mrt.render import DrawingStyle, figure_svg, visible_faces

SVG = "{http://www.w3.org/2000/svg}"

DIGEST_SCRIPT = """
import hashlib
from hcss.questionnaires.mrt.items import build_bank
digest = hashlib.sha256()
for item in sum(build_bank(), ()):
    for svg in (item.target_svg(), *item.alternative_svgs()):
        digest.update(svg.encode())
print(digest.hexdigest())
"""


def bank_svgs(bank) -> list[str]:
    return [svg for item in sum(bank, ()) for svg in (item.target_svg(), *item.alternative_svgs())]


def polygons(svg: str) -> list[tuple[np.ndarray, str]]:
    root = ElementTree.fromstring(svg)
    shapes = []
    for element in root.iter(f"{SVG}polygon"):
        points = np.array(
            [[float(v) for v in pair.split(",")] for pair in element.get("points").split()]
        )
        shapes.append((points, element.get("fill")))
    return shapes


def test_same_seed_gives_identical_bytes_in_this_and_a_fresh_process() -> None:
    first, second = bank_svgs(build_bank()), bank_svgs(build_bank())
    assert first == second
    digest = hashlib.sha256("".join(first).encode()).hexdigest()
    environment = {**os.environ, "PYTHONHASHSEED": "12345"}
    fresh = subprocess.run(
        [sys.executable, "-c", DIGEST_SCRIPT],
        capture_output=True,
        text=True,
        check=True,
        env=environment,
    )
    assert fresh.stdout.strip() == digest


def test_another_seed_gives_another_bank() -> None:
    assert bank_svgs(build_bank(seed=7)) != bank_svgs(build_bank())


def test_every_drawing_is_well_formed_svg_inside_its_frame() -> None:
    size = DrawingStyle().size
    for svg in bank_svgs(build_bank()):
        root = ElementTree.fromstring(svg)
        assert root.tag == f"{SVG}svg"
        assert root.get("viewBox") == f"0 0 {size} {size}"
        group = root.find(f"{SVG}g")
        assert group.get("stroke") == "#000"
        shapes = polygons(svg)
        assert len(shapes) >= 10
        for points, fill in shapes:
            assert points.shape == (4, 2)
            assert np.all((points >= 0) & (points <= size))
            assert fill.startswith("#") and len(fill) == 7
        assert len({fill for _, fill in shapes}) >= 2, "faces must be shaded"


def test_painting_order_shows_the_nearest_face_everywhere() -> None:
    """Ray-cast sample points: the last polygon painted over a point is the nearest face there."""
    style = DrawingStyle()
    rng = np.random.default_rng(3)
    for item in item_bank()[:4]:
        for figure in (item.target, *item.alternatives):
            cubes, view = figure.cube_array(), figure.view_matrix()
            radius = figure.radius()
            scale = (style.size / 2 - style.margin) / radius
            faces = visible_faces(cubes, view)
            painted = polygons(figure_svg(cubes, view, radius=radius, style=style))
            screen_faces = [
                np.column_stack(
                    (
                        style.size / 2 + scale * f.corners[:, 0],
                        style.size / 2 - scale * f.corners[:, 1],
                    )
                )
                for f in faces
            ]
            for point in rng.uniform(0, style.size, size=(200, 2)):
                covering = [i for i, outline in enumerate(screen_faces) if inside(point, outline)]
                if not covering:
                    continue
                x = (point[0] - style.size / 2) / scale
                y = (style.size / 2 - point[1]) / scale
                nearest = max(covering, key=lambda i: faces[i].depth_at(x, y))
                shown = [
                    index for index, (outline, _) in enumerate(painted) if inside(point, outline)
                ][-1]
                assert np.allclose(painted[shown][0], np.round(screen_faces[nearest], 2))


def inside(point: np.ndarray, outline: np.ndarray) -> bool:
    """Strictly inside a convex polygon (points near an edge are skipped as ambiguous)."""
    signs = []
    for start, end in zip(outline, np.roll(outline, -1, axis=0), strict=True):
        edge, offset = end - start, point - start
        cross = edge[0] * offset[1] - edge[1] * offset[0]
        if abs(cross) / np.linalg.norm(edge) < 0.05:
            return False
        signs.append(cross > 0)
    return all(signs) or not any(signs)


def test_label_is_escaped_into_the_title() -> None:
    item = item_bank()[0]
    svg = figure_svg(item.target.cube_array(), item.target.view_matrix(), label="a < b & c")
    assert ElementTree.fromstring(svg).find(f"{SVG}title").text == "a < b & c"


def test_an_item_is_drawn_once_however_often_its_page_is_shown(monkeypatch) -> None:
    """Each MRT page shows an item's five drawings; drawing them on every page load
    made the MRT pages the slowest of the study under load (benchmarks/study.py)."""
    from hcss.questionnaires.mrt import items

    drawn = []

    def counting_figure_svg(*args, **kwargs):
        drawn.append(kwargs.get("label"))
        return figure_svg(*args, **kwargs)

    monkeypatch.setattr(items, "figure_svg", counting_figure_svg)
    item = build_bank()[1][0]
    first = (item.target_svg(), item.alternative_svgs())
    for _ in range(3):
        assert (item.target_svg(), item.alternative_svgs()) == first
    assert len(drawn) == 1 + len(item.alternatives)
