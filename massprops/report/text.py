"""The text report of one result object: every value with the digits its bound leaves significant."""

from __future__ import annotations

import math

import numpy as np

from .digits import bound_text, significant, vector_text

__all__ = ["to_text", "header", "display_bounds", "about_bound"]


def _largest(values):
    flat = np.ravel(np.asarray(values, dtype=object)).tolist()
    return max((abs(v) for v in flat if v is not None), default=0.0)


def display_bounds(obj):
    """Absolute bounds for the text display of each quantity of a result object.

    Quantities with a bound of their own (``error``) use it; those formed from
    them after integration (global axes, other points, momentum and energy) use
    it propagated through those few formulas, with their rounding: an
    orthonormal rotation maps an element bound ``e`` to at most ``3e``, a
    parallel-axis shift ``m P(r)`` adds ``2 e_m |r|² + 4 m |r| e_c + 6 m e_c²``.
    """
    err, u = obj["error"], 2.0 ** -53
    bounds = {key: err.get(key) for key in ("volume", "mass", "center_of_mass", "inertia_com", "principal_moments")}
    axes = err.get("principal_axes_rad")
    bounds["principal_axes"] = max([8 * u, *axes]) if axes is not None else 8 * u      # unit vectors: ≥ rounding
    com, inertia = err.get("center_of_mass"), err.get("inertia_com")
    if com is not None and "center_of_mass_global" in obj:
        local = _largest(obj.get("center_of_mass", [0.0]))
        bounds["center_of_mass_global"] = [None if g is None else 2 * com + 8 * u * (abs(g) + 2 * local)
                                           for g in obj["center_of_mass_global"]]
    if inertia is not None and "inertia_com" in obj:
        rotated = 3 * inertia + 48 * u * _largest(obj["inertia_com"])
        bounds["inertia_com_global"] = rotated
        for key, point in [("inertia_origin", (0.0, 0.0, 0.0))] + [
                (f"inertia_about.{k}", entry["point"]) for k, entry in enumerate(obj.get("inertia_about", []))]:
            bounds[key] = about_bound(obj, bounds, point)
        if "omega" in obj:
            w = max(map(abs, obj["omega"]))
            bounds["angular_momentum"] = 3 * inertia * w * 1.01 + 8 * u * _largest(
                obj["angular_momentum"]["local"])
            bounds["kinetic_energy"] = 4.5 * inertia * w * w * 1.01 + 8 * u * abs(obj["kinetic_energy"] or 0.0)
    return bounds


def about_bound(obj, bounds, point, *, rotations=1):
    """Display bound of the inertia about a global ``point`` (then ``rotations`` more rotations of axes)."""
    u, mass = 2.0 ** -53, obj.get("mass")
    if None in obj["center_of_mass_global"] or mass is None or bounds.get("inertia_com_global") is None:
        return None
    e_c = _largest(bounds["center_of_mass_global"])
    r = math.hypot(*(c - q for c, q in zip(obj["center_of_mass_global"], point)))
    shifted = (bounds["inertia_com_global"] + 2 * obj["error"].get("mass", 0.0) * r * r
               + mass * (4 * r * e_c + 6 * e_c * e_c) + 16 * u * (_largest(obj["inertia_com"]) + 3 * mass * r * r))
    return shifted * 3 ** (rotations - 1) * (1 + 16 * u) ** rotations


# meshio's cell type names as words, one and many.
_CELL_NAMES = {"tetra": ("tetrahedron", "tetrahedra"), "hexahedron": ("hexahedron", "hexahedra"),
               "voxel": ("voxel", "voxels"), "wedge": ("wedge", "wedges"), "pyramid": ("pyramid", "pyramids")}


def _count(n, one, many):
    return f"{n} {one if n == 1 else many}"


def header(obj):
    """What a result was computed from, and with what density: ``12 triangles, 1 shell, density 1``."""
    checks = obj.get("checks", {})
    if "cells" in checks:
        types = ", ".join(_count(n, *_CELL_NAMES.get(kind, (kind, kind + "s")))
                          for kind, n in checks.get("cell_types", {}).items())
        what = _count(checks["cells"], "cell", "cells") + (f" ({types})" if types else "")
    else:
        shells = checks.get("shells")
        what = _count(obj["triangles"], "triangle", "triangles") + (
            f", {_count(shells, 'shell', 'shells')}" if isinstance(shells, int) else "")
        if checks.get("shell_thickness") is not None:
            what += f", a sheet {checks['shell_thickness']:g} thick"
    if checks.get("density") == "per cell":
        density = "density per cell"
    elif obj.get("density") is not None:
        mean = "mean " if "parts" in checks else ""            # an assembly's total: mass / volume
        density = f"{mean}density {obj['density']:.6g}" + (" kg/m³" if obj.get("unit") else "")
    else:
        density = None
    return ", ".join(filter(None, (what, density)))


def to_text(obj, *, digits=None):
    """A readable block for one result object (as made by :func:`result_dict`).

    Every value shows the digits its error bound leaves significant (see
    :func:`significant`), or ``digits`` significant digits when given.
    """
    lines = [f"{obj['file']}  ({header(obj)})"]
    err, bounds = obj["error"], display_bounds(obj)

    def row(label, value, bound=None, shown=None):
        if isinstance(value, list) and value and not isinstance(value[0], list):
            text = vector_text(value, bound, digits)
        else:
            text = significant(value, bound, digits) if isinstance(value, (int, float)) or value is None \
                else str(value)
        lines.append(f"  {label:<22} {text}" + (f"   ± {bound_text(shown)}" if shown is not None else ""))

    def matrix(label, rows, bound, shown=None):
        for i, values in enumerate(rows):
            lines.append(f"  {label if i == 0 else '':<22} {vector_text(values, bound, digits)}"
                         + (f"   ± {bound_text(shown)}" if shown is not None and i == 0 else ""))

    posed = obj["pose"]["rotation"] != np.eye(3).tolist() or any(obj["pose"]["translation"])
    skip = set() if posed else {"center_of_mass_global", "inertia_com_global"}
    for key, label, own in (("volume", "volume", True), ("mass", "mass", True),
                            ("surface_area", "surface area", False), ("center_of_mass", "center of mass", True),
                            ("center_of_mass_global", "center of mass global", False)):
        if key in obj and key not in skip:
            row(label, obj[key], bounds.get(key), err.get(key) if own else None)
    for key, label, own in (("inertia_com", "inertia about COM", True), ("inertia_com_global", "  global axes", False),
                            ("inertia_origin", "about global origin", False)):
        if key in obj and key not in skip:
            matrix(label, obj[key], bounds.get(key), err.get(key) if own else None)
    if "principal_moments" in obj:
        row("principal moments", obj["principal_moments"], bounds["principal_moments"], err["principal_moments"])
        for k, axis in enumerate(obj["principal_axes"]):
            row(f"  axis {k + 1}", axis, bounds["principal_axes"])
        if obj["degenerate"]:
            lines.append(f"  {'degenerate':<22} {obj['degenerate']} (axes chosen by the rule in docs/conventions.md)")
    for k, extra in enumerate(obj.get("inertia_about", [])):
        matrix("about " + vector_text(extra["point"]), extra["inertia"], bounds.get(f"inertia_about.{k}"))
    if "angular_momentum" in obj:
        row("angular momentum", obj["angular_momentum"]["local"], bounds.get("angular_momentum"))
        row("  global axes", obj["angular_momentum"]["global"], bounds.get("angular_momentum"))
        row("kinetic energy", obj["kinetic_energy"], bounds.get("kinetic_energy"))
    if "trimesh" in obj:
        rel = obj["trimesh"].get("relative_difference", {})
        row("trimesh rel. diff.", ", ".join(f"{k} {v:.1e}" for k, v in rel.items()))
    for w in obj["warnings"]:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)
