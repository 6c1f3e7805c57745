"""The picture of a robot report: each link's geometry at the joint values, its computed and declared inertia.

The numbers come from the report object :func:`massprops.robot.analyze.analyze`
made (the SPEC's ``robot`` JSON); the model is read again only for what to
draw: the link poses at ``--joints`` and each geometry's triangles (meshes
come from the reader's cache when the report was made in this process).
Computed boxes are solid lines, declared ones dashed, both in the link's
status colour; computed centres of mass are filled dots, declared ones
open diamonds.
"""

from __future__ import annotations

import numpy as np

from ..model.errors import MassPropsError
from .geometry import capsule_mesh, cone_mesh, cylinder_mesh, decimated, ellipsoid_mesh
from .picture import (DISPLAY_TRIANGLES, LINK_COLORS, STATUS_COLORS, Marker, Picture, Row, Surface,
                      glyph_lines)

__all__ = ["robot_picture", "declared_principal"]

LINK_OPACITY = 0.55


def _primitive(geometry):
    """Display triangles of a primitive in its own frame, or None."""
    size = geometry.size
    if geometry.kind == "sphere":
        r = float(size["radius"])
        return ellipsoid_mesh(np.zeros(3), np.eye(3), (r, r, r))
    if geometry.kind == "ellipsoid":
        return ellipsoid_mesh(np.zeros(3), np.eye(3), [float(v) for v in size["radii"]])
    if geometry.kind == "cylinder":
        return cylinder_mesh(float(size["radius"]), float(size["length"]))
    if geometry.kind == "cone":
        return cone_mesh(float(size["radius"]), float(size["length"]))
    if geometry.kind == "capsule":
        return capsule_mesh(float(size["radius"]), float(size["length"]))
    return None


def _triangles(geometry, prepared, settings):
    """``(vertices in the link frame, faces)`` of one geometry, or None when it has nothing to draw."""
    from ..robot.geometry import geometry_properties
    primitive = _primitive(geometry) if geometry.kind != "box" else None
    if primitive is not None:
        return geometry.pose.apply(primitive[0]), primitive[1]
    try:
        result = geometry_properties(geometry, 1.0, resolver=prepared.resolver, repair=settings.repair,
                                     on_open=prepared.mass.on_open)
    except MassPropsError:
        return None                     # the report already says why this link failed
    surface = result.surface
    if surface is None:
        return None
    vertices = np.asarray(surface.mesh.vertices, dtype=float) @ np.asarray(surface.linear, dtype=float).T
    return surface.pose.apply(vertices), np.asarray(surface.mesh.faces, dtype=np.int64)


def declared_principal(declared):
    """``(moments ascending, axes as rows)`` of a declared tensor (link axes), or None when there is none."""
    if not declared or declared.get("inertia_com") is None or declared.get("center_of_mass") is None:
        return None
    tensor = np.asarray(declared["inertia_com"], dtype=float)
    if not np.all(np.isfinite(tensor)):
        return None
    moments, vectors = np.linalg.eigh(0.5 * (tensor + tensor.T))
    return moments, vectors.T


def _fmt(value):
    return "" if value is None else f"{value:.5g}"


def _link_items(entry, pose, color, glyph):
    """Lines and markers of one link's computed and declared inertia (global frame)."""
    name, lines, markers, alerts = entry["link"], [], [], []
    status_color = STATUS_COLORS.get(entry["status"], "#000000")
    rotation = np.asarray(pose.rotation, dtype=float)
    if entry.get("principal_moments") is not None and entry.get("mass"):
        com = np.asarray(entry["center_of_mass_global"], dtype=float)
        axes = np.asarray(entry["principal_axes"], dtype=float) @ rotation.T
        box, _ = glyph_lines(f"{name}: computed {glyph}", name, com, axes, entry["principal_moments"], entry["mass"],
                             glyph, status_color)
        lines.append(box)
        markers.append(Marker(f"{name}: computed centre of mass", name, com, status_color))
    declared = entry.get("declared")
    principal = declared_principal(declared)
    if principal is not None and declared.get("mass"):
        com = pose.apply(np.asarray(declared["center_of_mass"], dtype=float))
        box, feasible = glyph_lines(f"{name}: declared {glyph}", name, com, principal[1] @ rotation.T, principal[0],
                                    float(declared["mass"]), glyph, status_color, dashed=True)
        lines.append(box)
        markers.append(Marker(f"{name}: declared centre of mass", name, com, status_color, kind="declared"))
        if not feasible:
            alerts.append(f"{name}: the declared moments break the triangle inequality; its {glyph} is drawn flat")
    return lines, markers, alerts


def robot_picture(path, settings, obj, *, glyph="box", limit=DISPLAY_TRIANGLES):
    """The :class:`Picture` of one robot report object ``obj`` made from ``path`` with ``settings``.

    Raises
    ------
    MassPropsError
        The model cannot be read again (it changed since the report).
    """
    from ..robot.analyze import prepare
    prepared = prepare(path, settings)
    entries = {entry["link"]: entry for entry in obj["links"]}
    surfaces, lines, markers, rows, alerts = [], [], [], [], []
    shown_all = total_all = 0
    for index, link in enumerate(prepared.model.links):
        entry = entries.get(link.name)
        if entry is None:
            continue
        pose = prepared.poses[link.name]
        color = LINK_COLORS[index % len(LINK_COLORS)]
        if not settings.declared_only:
            for geometry in link.chosen(settings.geometry):
                drawn = _triangles(geometry, prepared, settings)
                if drawn is None:
                    continue
                faces, shown, total = decimated(drawn[1], limit)
                shown_all, total_all = shown_all + shown, total_all + total
                surfaces.append(Surface(f"{link.name} ({geometry.name})", link.name, pose.apply(drawn[0]), faces,
                                        color, LINK_OPACITY, shown, total))
        link_lines, link_markers, link_alerts = _link_items(entry, pose, color, glyph)
        lines += link_lines
        markers += link_markers
        alerts += link_alerts
        declared = entry.get("declared") or {}
        rows.append(Row(link.name, (link.name, entry["status"], _fmt(entry.get("mass")), _fmt(declared.get("mass")),
                                    ", ".join(entry.get("diagnoses") or ()), entry.get("message") or ""),
                        STATUS_COLORS.get(entry["status"], ""), color))
    if shown_all < total_all:
        alerts.insert(0, f"drawn with {shown_all} of {total_all} triangles (display only; the numbers use all "
                         f"{total_all})")
    total = obj.get("total")
    if total and total.get("center_of_mass") is not None:
        markers.append(Marker("the robot's centre of mass", "", np.asarray(total["center_of_mass"], dtype=float),
                              "#000000"))
    joints = ", ".join(f"{k}={v:g}" for k, v in (obj.get("joints") or {}).items())
    notes = (f"links at joint values {joints or '(none move)'}; geometry: {obj.get('geometry')}",
             f"equivalent uniform {glyph} of each link: computed solid, declared dashed, coloured by status "
             "(ok green, mismatch orange, invalid red, missing grey); centres of mass: computed dots, declared "
             "open diamonds; the robot's centre of mass black")
    summary = ", ".join(f"{k} {v}" for k, v in (obj.get("summary") or {}).items())
    panel = f"total mass {_fmt(total.get('mass'))} kg" if total else "no total"
    panel += f"\nlinks: {summary}" if summary else ""
    return Picture(obj.get("name") or obj["model"], "m", tuple(surfaces), tuple(lines), tuple(markers), panel,
                   notes, tuple(alerts), ("link", "status", "mass [kg]", "declared [kg]", "diagnoses", "message"),
                   tuple(rows))
