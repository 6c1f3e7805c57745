"""Cross-checks against trimesh on the same triangles (imports trimesh; used on request only).

Two views: ``raw`` is what a trimesh user gets (trimesh integrates about the
origin), ``fair`` is trimesh on the same mesh shifted exactly to near its own
bounding-box centre (massprops's reference point, see
:func:`massprops.core.reference_frame`), so only the integration itself
is compared.  Far from the origin, at ``ratio = offset / size``, the raw sums
cancel: each face's term is ``ratio`` times larger than the part's total (one
factor lost in the volume), and the inertia about the center of mass is then
the parallel-axis difference ``J_origin − m (rᵀr I − r rᵀ)`` of two terms
``ratio²`` times larger than it: about ``3 log10(ratio)`` digits lost.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.rounding import U
from ..report import plain, relative_difference

__all__ = ["trimesh_values", "compare", "digits_lost", "trimesh_comparison", "explanation", "COMPARED"]

COMPARED = ("volume", "center_of_mass", "inertia_com", "principal_moments")
_EPS = 2 * U                # machine epsilon: a relative difference below it is rounding


def trimesh_values(vertices, faces, *, shift=None):
    """trimesh's volume, center of mass, inertia about the COM and principal moments (density 1).

    With ``shift`` (3,) the vertices are translated by ``−shift`` first and the
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
    inertia = np.asarray(mp["inertia"], dtype=float)
    return {"volume": float(mp["volume"]), "center_of_mass": com, "inertia_com": inertia,
            "principal_moments": np.linalg.eigvalsh(inertia)}


def compare(ours, theirs, size):
    """Relative differences per quantity (normwise, :func:`massprops.report.relative_difference`).

    The center of mass is judged against at least the part's ``size``.
    """
    return {key: relative_difference(ours[key], theirs[key], floor=size if key == "center_of_mass" else 0.0)
            for key in COMPARED}


def _placement(vertices):
    """(distance of the bounding-box centre from the origin, largest extent)."""
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    return float(np.linalg.norm(0.5 * (low + high))), float((high - low).max()) or 1.0


def digits_lost(vertices):
    """Digits that integrating about the origin costs the inertia about the COM: 3 log10(offset / size).

    At least 0, at most the 16 a double holds.
    """
    offset, size = _placement(vertices)
    return min(16.0, 3 * math.log10(max(offset / size, 1.0)))


def trimesh_comparison(path, result, *, mesh=None):
    """trimesh's values (raw and fair) for the file behind ``result``, with relative differences.

    Values are for density 1 in mesh units, compared with massprops's at density 1.

    Returns
    -------
    dict
        ``raw``, ``fair`` (trimesh's values), ``relative_difference_raw``,
        ``relative_difference`` (fair), ``digits_lost_raw`` (predicted),
        ``offset`` and ``size`` (bounding-box centre's distance from the
        origin, largest extent; mesh units).
    """
    from ..core import reference_frame
    from ..io import read

    mesh = mesh or read(path)
    if not hasattr(mesh, "faces") or "shell_thickness" in result.checks:
        from ..model.errors import OptionError
        raise OptionError("--check-trimesh compares solids bounded by surfaces, not volume meshes or shells",
                          path=path, fix="leave out --check-trimesh here")
    faces = mesh.faces
    props = result.properties
    length = _unit_length(props)
    inertia_scale = props.density * length ** 5
    ours = {"volume": props.volume / length ** 3, "center_of_mass": props.center_of_mass / length,
            "inertia_com": props.inertia_com / inertia_scale,
            "principal_moments": props.principal.moments / inertia_scale}
    if result.checks.get("orientation", "").startswith("inward"):
        faces = faces[:, ::-1]
    raw = trimesh_values(mesh.vertices, faces)
    reference, _ = reference_frame(mesh.vertices)
    fair = trimesh_values(mesh.vertices, faces, shift=reference)
    offset, size = _placement(mesh.vertices)
    return {"raw": plain(raw), "fair": plain(fair),
            "relative_difference_raw": compare(ours, raw, size), "relative_difference": compare(ours, fair, size),
            "digits_lost_raw": digits_lost(mesh.vertices), "offset": offset, "size": size}


def explanation(comparison):
    """Why the raw difference exceeds the fair one, in a sentence; None when they agree.

    ``comparison`` is a :func:`trimesh_comparison` result.
    """
    raw = max(comparison["relative_difference_raw"].values())
    fair = max(comparison["relative_difference"].values())
    if not raw > 10 * max(fair, _EPS):
        return None
    measured = min(16.0, math.log10(raw / max(fair, _EPS)))
    ratio = comparison["offset"] / comparison["size"]
    return (f"trimesh integrates about the origin, and this part sits {comparison['offset']:.3g} from it, "
            f"{ratio:.3g} times its size: its sums cancel, and the inertia about the center of mass is a "
            f"parallel-axis difference of two nearly equal terms, so at this offset it loses about "
            f"3·log10({ratio:.3g}) = {comparison['digits_lost_raw']:.1f} of 16 digits (measured: raw off by "
            f"{raw:.1e}, fair by {fair:.1e}, {measured:.1f} digits lost)")


def _unit_length(props):
    from ..model.properties import unit_factor
    return float(unit_factor(props.unit))
