"""Draw a polycube as an SVG line drawing in the style of the classic MRT figures.

Orthographic projection, shaded faces with black edges, and a painter's
algorithm: faces are painted far to near, so nearer faces cover the edges of
the faces behind them and no hidden-line pass is needed. The order comes from
pairwise occlusion tests where projected faces overlap (depth compared at a
point of the overlap), not from sorting by face centre, because sorting by
centre misorders long faces next to short ones at oblique views.

The output is plain text built with fixed number formatting, so the same cubes
and view give the same bytes on every run: every participant sees the same
item bank.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Unit normals of the six cube faces with two in-plane axes, ordered so that
#: (u, v, normal) is right-handed and the corners run counter-clockwise seen
#: from outside.
_FACE_AXES = tuple(
    (np.array(normal), np.array(u), np.array(v))
    for normal, u, v in (
        ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
        ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
        ((0, 1, 0), (0, 0, 1), (1, 0, 0)),
        ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
        ((0, 0, 1), (1, 0, 0), (0, 1, 0)),
        ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
    )
)
_SQUARE = ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5))
_EPSILON = 1e-9


@dataclass(frozen=True)
class DrawingStyle:
    """Look of a figure. The light comes from the upper left, in front of the figure."""

    size: int = 180
    margin: float = 8.0
    stroke_width: float = 1.5
    light: tuple[float, float, float] = (-0.45, 0.6, 0.66)
    ambient: float = 0.55


@dataclass(frozen=True)
class VisibleFace:
    """A cube face turned toward the viewer, in view coordinates (z toward the viewer)."""

    corners: np.ndarray  # (4, 3)
    normal: np.ndarray  # (3,)

    def depth_at(self, x: float, y: float) -> float:
        """z of the face's plane above the point (x, y); larger is nearer."""
        origin = self.corners[0]
        nx, ny, nz = self.normal
        return float(origin[2] - (nx * (x - origin[0]) + ny * (y - origin[1])) / nz)

    def mean_depth(self) -> float:
        return float(self.corners[:, 2].mean())


def visible_faces(cubes: np.ndarray, view: np.ndarray) -> list[VisibleFace]:
    """Exterior cube faces that face the viewer, centred on the figure's centroid.

    Faces shared by two cubes are interior and dropped; back faces are culled.
    """
    cells = np.asarray(cubes, dtype=np.int64)
    occupied = {tuple(int(v) for v in row) for row in cells}
    centroid = cells.mean(axis=0)
    rotation = np.asarray(view, dtype=float)
    faces = []
    for cell in cells:
        for normal, u, v in _FACE_AXES:
            if tuple(int(x) for x in cell + normal) in occupied:
                continue
            turned = rotation @ normal
            if turned[2] <= _EPSILON:
                continue
            corners = np.array(
                [cell - centroid + normal / 2 + a * u + b * v for a, b in _SQUARE], dtype=float
            )
            faces.append(VisibleFace(corners @ rotation.T, turned))
    return faces


def _clip(subject: np.ndarray, clipper: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman: the part of convex polygon `subject` inside convex `clipper`."""

    def side(point: np.ndarray, start: np.ndarray, end: np.ndarray) -> float:
        edge, offset = end - start, point - start
        return float(edge[0] * offset[1] - edge[1] * offset[0])

    orientation = 1.0 if _signed_area(clipper) > 0 else -1.0
    output = list(subject)
    for index in range(len(clipper)):
        start, end = clipper[index], clipper[(index + 1) % len(clipper)]
        points, output = output, []
        for current_index, current in enumerate(points):
            following = points[(current_index + 1) % len(points)]
            inside_now = orientation * side(current, start, end) >= 0
            inside_next = orientation * side(following, start, end) >= 0
            if inside_now:
                output.append(current)
            if inside_now != inside_next:
                a = side(current, start, end)
                b = side(following, start, end)
                output.append(current + (following - current) * (a / (a - b)))
        if not output:
            break
    return np.array(output).reshape(-1, 2)


def _signed_area(polygon: np.ndarray) -> float:
    x, y = polygon[:, 0], polygon[:, 1]
    return float(0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def paint_order(faces: list[VisibleFace]) -> list[int]:
    """Indices of `faces` from farthest to nearest.

    Where two faces overlap on screen, the one whose plane is nearer at the
    centre of the overlap is painted later. The resulting constraints are
    sorted topologically, breaking ties (and, defensively, cycles) by mean
    depth and then index, so the order is deterministic.
    """
    count = len(faces)
    outlines = [face.corners[:, :2] for face in faces]
    later: list[set[int]] = [set() for _ in range(count)]
    blockers = [0] * count
    for first in range(count):
        for second in range(first + 1, count):
            lower = np.maximum(outlines[first].min(axis=0), outlines[second].min(axis=0))
            upper = np.minimum(outlines[first].max(axis=0), outlines[second].max(axis=0))
            if np.any(upper - lower <= 1e-6):
                continue
            overlap = _clip(outlines[first], outlines[second])
            if len(overlap) < 3 or abs(_signed_area(overlap)) < 1e-6:
                continue
            x, y = overlap.mean(axis=0)
            if faces[first].depth_at(x, y) < faces[second].depth_at(x, y):
                far, near = first, second
            else:
                far, near = second, first
            later[far].add(near)
            blockers[near] += 1
    order: list[int] = []
    remaining = set(range(count))
    while remaining:
        ready = [index for index in remaining if blockers[index] == 0] or list(remaining)
        chosen = min(ready, key=lambda index: (faces[index].mean_depth(), index))
        order.append(chosen)
        remaining.discard(chosen)
        for near in later[chosen]:
            blockers[near] -= 1
    return order


def shade(normal: np.ndarray, style: DrawingStyle) -> str:
    """Grey level of a face lit by one directional light, as an SVG colour."""
    light = np.asarray(style.light, dtype=float)
    light = light / np.linalg.norm(light)
    brightness = style.ambient + (1 - style.ambient) * max(0.0, float(np.dot(normal, light)))
    level = int(round(255 * min(1.0, brightness)))
    return f"#{level:02x}{level:02x}{level:02x}"


def figure_radius(cubes: np.ndarray) -> float:
    """Largest distance of a cube corner from the centroid: a rotation-invariant size."""
    cells = np.asarray(cubes, dtype=float)
    offsets = np.array(list(np.ndindex(2, 2, 2)), dtype=float) - 0.5
    corners = (cells[:, None, :] + offsets[None, :, :]).reshape(-1, 3) - cells.mean(axis=0)
    return float(np.linalg.norm(corners, axis=1).max())


def figure_svg(
    cubes: np.ndarray,
    view: np.ndarray,
    *,
    radius: float | None = None,
    label: str = "",
    style: DrawingStyle | None = None,
) -> str:
    """An SVG document of the figure seen through rotation `view`.

    `radius` sets the scale (lattice units from centre to frame edge); give the
    same radius to all figures of an item so rotated copies are drawn the same
    size. By default the figure's own radius is used.
    """
    style = style or DrawingStyle()
    radius = radius if radius is not None else figure_radius(cubes)
    scale = (style.size / 2 - style.margin) / radius
    centre = style.size / 2
    faces = visible_faces(cubes, view)
    polygons = []
    for index in paint_order(faces):
        face = faces[index]
        points = " ".join(
            f"{centre + scale * x:.2f},{centre - scale * y:.2f}" for x, y in face.corners[:, :2]
        )
        polygons.append(f'<polygon points="{points}" fill="{shade(face.normal, style)}"/>')
    title = f"<title>{_escape(label)}</title>" if label else ""
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {style.size} {style.size}" '
        f'width="{style.size}" height="{style.size}" role="img">'
        f"{title}"
        f'<g stroke="#000" stroke-width="{style.stroke_width}" stroke-linejoin="round">'
        + "".join(polygons)
        + "</g></svg>"
    )


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
