"""The picture of an assembly: every part instance where it is placed, each part's centre of mass,
and the total's centre of mass, principal axes and equivalent uniform box."""

from __future__ import annotations

import numpy as np

from .geometry import decimated
from .picture import COLORS, DISPLAY_TRIANGLES, LINK_COLORS, Marker, Picture, Row, Surface, axis_lines, glyph_lines, \
    display_triangles, units

__all__ = ["scene_picture"]

PART_OPACITY = 0.6


def _instances(scene, result, length, limit):
    """Surfaces of every instance (decimated so the whole stays near ``limit`` triangles) and alerts."""
    instances = sum(part.count for part in scene.parts)
    per_instance = max(12, limit // max(instances, 1))
    surfaces, shown_all, total_all = [], 0, 0
    for index, part in enumerate(scene.parts):
        vertices, faces = display_triangles(result.records[part.mesh].mesh)
        if part.stretch is not None:
            vertices = vertices @ np.asarray(part.stretch, dtype=float).T
        faces, shown, total = decimated(faces, per_instance)
        rotation, translation = part.arrays()
        color = LINK_COLORS[index % len(LINK_COLORS)]
        for name, r, t in zip(part.instance_names(), rotation, translation):
            placed = (vertices * length) @ np.asarray(r).T + np.asarray(t) * length
            surfaces.append(Surface(name, name, placed, faces, color, PART_OPACITY, shown, total))
            shown_all, total_all = shown_all + shown, total_all + total
    alerts = () if shown_all == total_all else (
        f"drawn with {shown_all} of {total_all} triangles (display only; the numbers use all {total_all})",)
    return surfaces, alerts


def scene_picture(result, obj, *, glyph="box", limit=DISPLAY_TRIANGLES):
    """The :class:`Picture` of a :class:`massprops.scene.assembly.SceneResult` and its JSON object ``obj``."""
    from ..model.properties import unit_factor
    scene, unit = result.scene, result.scene.report.unit
    length_unit, mass_unit, inertia_unit = units(unit)
    surfaces, alerts = _instances(scene, result, float(unit_factor(unit)) if unit else 1.0, limit)
    markers, lines, rows = [], [], []
    colors = {s.name: s.color for s in surfaces}
    for placed, props in zip(scene.placed_parts(), result.parts):
        if props.center_of_mass is None:
            continue
        com = np.asarray(props.center_of_mass_global, dtype=float)
        markers.append(Marker(f"{placed.name}: centre of mass", placed.name, com, COLORS["com"]))
        rows.append(Row(placed.name, (placed.name, f"{props.mass:.6g}", "[" + ", ".join(f"{c:.4g}" for c in com)
                                      + "]"), swatch=colors.get(placed.name, "")))
    total = result.total
    panel = ""
    if total is not None and total.inertia_com is not None:
        com = np.asarray(total.center_of_mass, dtype=float)
        principal = total.principal
        box, feasible = glyph_lines(f"total equivalent {glyph}", "", com, principal.axes, principal.moments,
                                    total.mass, glyph, COLORS["glyph"])
        lines.append(box)
        bounds = np.vstack([s.vertices[np.unique(s.faces)] for s in surfaces if len(s.faces)])
        lines += axis_lines("", com, principal.axes, principal.moments,
                            float(np.abs(bounds - com).max()), inertia_unit, prefix="total ")
        markers.append(Marker("total centre of mass", "", com, COLORS["total"]))
        rows.append(Row("", ("total", f"{total.mass:.6g}", "[" + ", ".join(f"{c:.4g}" for c in com) + "]")))
        if not feasible:
            alerts += ("the total's moments break the triangle inequality; no uniform body has them",)
    if "total" in obj:
        from ..report import to_text
        panel = to_text(dict(obj["total"], file="total"))
    notes = (f"each part's centre of mass magenta; the total's in black, with its principal axes (length by moment) "
             f"and equivalent uniform {glyph} in orange",)
    return Picture(scene.path, length_unit, tuple(surfaces), tuple(lines), tuple(markers), panel, notes,
                   tuple(alerts), ("part", f"mass [{mass_unit}]", f"centre of mass [{length_unit}]"), tuple(rows))
