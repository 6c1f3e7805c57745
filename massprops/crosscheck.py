"""Cross-checks against trimesh on the same triangles (imports trimesh; used on request only).

Two views: ``raw`` is what a trimesh user gets (trimesh integrates about the
origin), ``fair`` is trimesh on the same mesh shifted exactly to massprops's
reference point near the part, so only the integration itself is compared.
"""

from __future__ import annotations

import math

import numpy as np

from .report import relative_difference

__all__ = ["trimesh_values", "trimesh_comparison"]


def trimesh_values(vertices, faces, *, shift=None):
    """trimesh's volume, center of mass and inertia about the COM (density 1).

    With ``shift`` the vertices are translated by ``−shift`` first and the
    center of mass is moved back afterwards.
    """
    import trimesh

    vertices = np.asarray(vertices, dtype=np.float64)
    if shift is not None:
        vertices = vertices - shift
    mp = trimesh.triangles.mass_properties(vertices[faces], density=1.0)
    com = np.asarray(mp["center_mass"], dtype=float)
    if shift is not None:
        com = com + shift
    return {"volume": float(mp["volume"]), "center_of_mass": com, "inertia_com": np.asarray(mp["inertia"])}


def compare(ours, theirs):
    """Relative differences per quantity (normwise, as report.relative_difference)."""
    return {key: relative_difference(ours[key], theirs[key]) for key in ("volume", "center_of_mass", "inertia_com")}


def digits_lost(vertices):
    """Roughly how many digits integrating about the origin costs: log10((offset/size)²)."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    size = float((high - low).max()) or 1.0
    offset = float(np.abs(0.5 * (low + high)).max())
    return max(0.0, 2 * math.log10(max(offset / size, 1.0)))


def trimesh_comparison(path, result, *, mesh=None):
    """trimesh's values (raw and fair) for the file behind ``result``, with relative differences.

    Values are for density 1 in mesh units, compared with massprops's at density 1.
    """
    from .integrate import reference_frame
    from .io import read

    mesh = mesh or read(path)
    faces = mesh.faces
    props = result.properties
    scale = props.density
    ours = {"volume": props.volume / _unit_volume(props), "center_of_mass": props.center_of_mass / _unit_length(props),
            "inertia_com": props.inertia_com / (scale * _unit_length(props) ** 5)}
    if result.checks.get("orientation", "").startswith("inward"):
        faces = faces[:, ::-1]
    raw = trimesh_values(mesh.vertices, faces)
    reference, _ = reference_frame(mesh.vertices)
    fair = trimesh_values(mesh.vertices, faces, shift=reference)
    return {"raw": _plainify(raw), "fair": _plainify(fair),
            "relative_difference_raw": compare(ours, raw), "relative_difference": compare(ours, fair),
            "digits_lost_raw": digits_lost(mesh.vertices)}


def _unit_length(props):
    from .properties import unit_factor
    return float(unit_factor(props.unit))


def _unit_volume(props):
    return _unit_length(props) ** 3


def _plainify(values):
    return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in values.items()}
