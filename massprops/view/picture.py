"""What a picture shows, independent of how it is drawn: surfaces, lines, markers, the side panel.

A :class:`Picture` is made from results (:func:`part_picture`, and
:mod:`massprops.view.robot` / :mod:`massprops.view.scene` for robots and
assemblies) and drawn by :func:`massprops.view.html.write_html` or
:func:`massprops.view.png.write_png`.  Every coordinate is in the global
frame (a part's pose applied, SI units when a unit was given).  Items carry a
``group`` (a file, a link, a part): selecting a table row focuses its group.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import BOX_EDGES, box_mesh, decimated, equivalent_box, equivalent_ellipsoid

__all__ = ["Surface", "Lines", "Marker", "Row", "Picture", "part_picture", "glyph_lines", "axis_lines",
           "DISPLAY_TRIANGLES", "COLORS"]

DISPLAY_TRIANGLES = 200_000       # more are sampled for display (the numbers use every triangle)
PART_OPACITY = 0.6                # see-through, so the axes and the box inside show

COLORS = {
    "part": "#6baed6",            # the solid
    "com": "#ff00ff",             # centre of mass (magenta: used by nothing else)
    "glyph": "#ff7f00",           # equivalent box / ellipsoid
    "axes": ("#e41a1c", "#2ca02c", "#1a1aff"),     # principal axes 1, 2, 3
    "total": "#000000",
    "crossing": "#d62728",        # faces that cross other faces (overlaps, self-intersections)
}
STATUS_COLORS = {"ok": "#2ca02c", "mismatch": "#ff7f00", "invalid": "#d62728", "missing": "#7f7f7f",
                 "no-geometry": "#7f7f7f", "massless": "#7f7f7f", "error": "#9467bd"}
LINK_COLORS = ("#6baed6", "#c994c7", "#74c476", "#fdae6b", "#9e9ac8", "#bcbddc", "#a1d99b", "#fdd0a2")


@dataclass(frozen=True)
class Surface:
    """Triangles to fill: ``vertices`` (n, 3), ``faces`` (f, 3); ``shown`` of ``total`` triangles drawn."""

    name: str
    group: str
    vertices: np.ndarray
    faces: np.ndarray
    color: str
    opacity: float = 1.0
    shown: int = 0
    total: int = 0


@dataclass(frozen=True)
class Lines:
    """Line segments ``segments`` (k, 2, 3); ``label`` is written at the end of the last segment."""

    name: str
    group: str
    segments: np.ndarray
    color: str
    dashed: bool = False
    width: float = 3.0
    label: str = ""


@dataclass(frozen=True)
class Marker:
    """A point: ``kind`` "com" (a computed centre of mass) or "declared" (a declared one)."""

    name: str
    group: str
    point: np.ndarray
    color: str
    kind: str = "com"


@dataclass(frozen=True)
class Row:
    """One row of the side table: its group (what selecting it focuses), cells, a status colour, and the colour
    its group is drawn in (``swatch``)."""

    group: str
    cells: tuple
    color: str = ""
    swatch: str = ""


@dataclass(frozen=True)
class Picture:
    """Everything one page or image shows.

    ``panel`` is preformatted text (the numbers with their bounds);
    ``notes`` sentences shown above it (``alerts`` highlighted: overlaps,
    resolved self-intersections, decimation); ``columns`` and ``rows`` the
    table; ``length_unit`` names the axes' unit.
    """

    title: str
    length_unit: str
    surfaces: tuple = ()
    lines: tuple = ()
    markers: tuple = ()
    panel: str = ""
    notes: tuple = ()
    alerts: tuple = ()
    columns: tuple = ()
    rows: tuple = ()

    def bounds(self, group=None):
        """(2, 3) min and max corner of what is drawn (of one group's items when ``group`` is given)."""
        points = [s.vertices[np.unique(s.faces)] for s in self.surfaces if group in (None, s.group) and len(s.faces)]
        points += [ln.segments.reshape(-1, 3) for ln in self.lines if group in (None, ln.group)]
        points += [m.point.reshape(1, 3) for m in self.markers if group in (None, m.group)]
        if not points:
            return np.zeros((2, 3))
        stacked = np.vstack(points)
        stacked = stacked[np.all(np.isfinite(stacked), axis=1)]
        if not len(stacked):
            return np.zeros((2, 3))
        return np.array([stacked.min(axis=0), stacked.max(axis=0)])


def glyph_lines(name, group, center, axes, moments, mass, glyph, color, *, dashed=False):
    """The equivalent box's 12 edges, or the equivalent ellipsoid's three principal ellipses, as :class:`Lines`.

    ``axes`` rows are the principal axes in the global frame; returns ``(Lines, feasible)``.
    """
    if glyph == "ellipsoid":
        extents = equivalent_ellipsoid(moments, mass)
        angle = np.linspace(0.0, 2 * np.pi, 65)
        circle = np.stack([np.cos(angle), np.sin(angle)], axis=1)
        rings = []
        for i, j in ((0, 1), (0, 2), (1, 2)):
            unit = np.zeros((angle.size, 3))
            unit[:, i], unit[:, j] = circle[:, 0], circle[:, 1]
            points = np.asarray(center) + (unit * extents.half) @ np.asarray(axes)
            rings += [points[:-1], points[1:]]
        segments = np.stack([np.vstack(rings[0::2]), np.vstack(rings[1::2])], axis=1)
    else:
        extents = equivalent_box(moments, mass)
        corners, _ = box_mesh(center, axes, extents.half)
        segments = np.array([[corners[a], corners[b]] for a, b in BOX_EDGES])
    return Lines(name, group, segments, color, dashed=dashed), extents.feasible


def axis_lines(group, center, axes, moments, length, unit_text, *, prefix=""):
    """The principal axes from ``center``, axis k of length ``length · I_k / max I``, labelled with its moment."""
    moments = np.asarray(moments, dtype=float)
    top = float(np.abs(moments).max()) or 1.0
    out = []
    for k in range(3):
        tip = np.asarray(center) + np.asarray(axes[k]) * length * max(abs(moments[k]) / top, 0.15)
        out.append(Lines(f"{prefix}I{k + 1}", group, np.array([[center, tip]]), COLORS["axes"][k], width=5,
                         label=f"{prefix}I{k + 1} = {moments[k]:.4g} {unit_text}"))
    return out


def units(unit):
    """``(length, mass, inertia)`` unit names of a result: SI with a unit, mesh units without."""
    if unit:
        return "m", "kg", "kg·m²"
    return "mesh units", "mass units", "mass·length²"


def part_picture(parts, *, glyph="box", limit=DISPLAY_TRIANGLES, about=()):
    """The picture of one or more parts.

    Parameters
    ----------
    parts : sequence of (Result, dict, vertices (n, 3), faces (f, 3))
        Each result (:class:`massprops.result.Result`), its JSON object
        (:func:`massprops.report.result_dict`), and the triangles it was
        integrated from, in the mesh's own coordinates and unit.
    glyph : {"box", "ellipsoid"}
    limit : int
        Largest number of triangles drawn per part (display only).
    about : sequence of (3,) points
        Points the inertia was also reported about (marked).
    """
    from ..model.properties import unit_factor
    from ..report import to_text
    surfaces, lines, markers, notes, alerts, panels, rows = [], [], [], [], [], [], []
    length_unit = "mesh units"
    for result, obj, vertices, faces in parts:
        props, name = result.properties, result.file
        length_unit, mass_unit, inertia_unit = units(props.unit)
        scale = float(unit_factor(props.unit)) if props.unit else 1.0
        placed = props.pose.apply(np.asarray(vertices, dtype=float) * scale)
        shown_faces, shown, total = decimated(faces, limit)
        surfaces.append(Surface(name, name, placed, shown_faces, COLORS["part"], PART_OPACITY, shown, total))
        if shown < total:
            alerts.append(f"{name}: drawn with {shown} of {total} triangles (display only; the numbers use all "
                          f"{total})")
        com = np.asarray(props.center_of_mass_global, dtype=float)
        markers.append(Marker(f"centre of mass {name}", name, com, COLORS["com"]))
        principal = props.principal
        axes = principal.axes @ props.pose.rotation.T            # rows: A a_k, the axes in the global frame
        box, feasible = glyph_lines(f"equivalent {glyph} {name}", name, com, axes, principal.moments, props.mass,
                                    glyph, COLORS["glyph"])
        lines.append(box)
        reach = float(np.abs(placed[np.unique(faces)] - com).max()) if len(faces) else 1.0
        lines += axis_lines(name, com, axes, principal.moments, reach, inertia_unit)
        checks = result.checks or {}
        if checks.get("overlap"):
            alerts.append(f"{name}: overlapping bodies counted once (overlap volume {checks['overlap']:.4g}); "
                          "the faces that cross are drawn red")
        if checks.get("self_intersection") == "resolved":
            alerts.append(f"{name}: the surface crosses itself; the region it encloses was integrated; the faces "
                          "that cross are drawn red")
        if checks.get("overlap") or checks.get("self_intersection") == "resolved":
            crossing = crossing_faces(vertices, faces)
            if len(crossing):
                surfaces.append(Surface(f"{name}: faces that cross", name, placed, crossing, COLORS["crossing"],
                                        0.45, len(crossing), len(crossing)))
        if not feasible:
            alerts.append(f"{name}: the moments break the triangle inequality; no uniform {glyph} has them")
        notes.append(f"{name}: equivalent uniform {glyph} (same mass and principal moments) in orange; principal "
                     f"axes drawn with length by moment (I1 red, I2 green, I3 blue); centre of mass magenta")
        panels.append(to_text(obj))
        rows.append(Row(name, (name, f"{props.mass:.6g}", f"{props.volume:.6g}",
                               "[" + ", ".join(f"{c:.4g}" for c in com) + "]")))
    for k, point in enumerate(about):
        markers.append(Marker(f"about point {k + 1}", "", np.asarray(point, dtype=float), "#000000", kind="declared"))
    title = parts[0][0].file if len(parts) == 1 else f"{len(parts)} parts"
    return Picture(title, length_unit, tuple(surfaces), tuple(lines), tuple(markers), "\n\n".join(panels),
                   tuple(notes), tuple(alerts), ("part", f"mass [{mass_unit}]", f"volume [{length_unit}³]",
                                                 f"centre of mass [{length_unit}]"), tuple(rows))



def crossing_faces(vertices, faces):
    """The faces (k, 3) that cross another face beyond what they share (exact predicates), for highlighting."""
    from ..core.intersect import ExactGeometry
    faces = np.asarray(faces, dtype=np.int64)
    pairs, _ = ExactGeometry(np.asarray(vertices, dtype=float)).crossing_pairs(faces)
    return faces[np.unique(pairs)] if pairs.size else faces[:0]


def display_triangles(mesh):
    """``(vertices (n, 3), faces (f, 3))`` to draw a mesh as read: a surface's faces, a volume mesh's boundary."""
    from .geometry import boundary_faces
    if hasattr(mesh, "faces"):
        return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=np.int64)
    tets, _ = mesh.tetrahedra()
    return np.asarray(mesh.points, dtype=float), boundary_faces(tets)
