"""Thin shells: a surface, open or closed, as a sheet of uniform thickness.

The shell approximation puts the sheet's mass on the surface, with area
density ``ρ·t``: mass ``ρ t A``, center of mass the area centroid, inertia
``ρ t ∫ (sᵀs I₃ − s sᵀ) dA``.  Read the mesh as the sheet's mid-surface: a flat
sheet's mass is then exact, and the relative error of every quantity is
O((t/L)²), L the smallest size or radius of curvature of the part (at edges
where sheets meet, the overlap inside and the gap outside cancel to first
order).

Per triangle (a, b, c) of area A, ``s = a + b + c``::

    ∫ 1 dA = A,   ∫ x dA = A s / 3,   ∫ x xᵀ dA = A (s sᵀ + a aᵀ + b bᵀ + c cᵀ) / 12

These are the sums :func:`massprops.core.integrate` forms with
``measure="area"`` (``2A`` in place of ``det``); scaled by ``3t``, ``4t`` and
``5t`` they are exactly the solid sums of a body of volume ``t A`` with those
moments, so :meth:`MassProperties.from_moments` does the rest as for a solid.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..core import U, edge_summary, integrate, shells
from ..model.errors import MeshGeometryError, OpenMeshError, OptionError, WindingError
from ..model.properties import MassProperties
from .surface import TriangleMesh, check_mesh, distinct_faces

__all__ = ["shell_moments", "shell_mass_properties"]


def _times(value, error, factor):
    """``value · factor`` (one rounding) and the bound on its error."""
    product = value * factor
    return product, error * abs(factor) * (1 + 2 * U) + 2 * U * float(np.max(np.abs(product)))


def shell_moments(vertices, faces, thickness, *, order=2):
    """The solid-equivalent :class:`massprops.core.Moments` of a sheet.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
        Mid-surface coordinates, mesh units, local frame.
    faces : ndarray, shape (m, 3), int
        Triangles, either winding.
    thickness : float
        Sheet thickness, mesh units.
    """
    area = integrate(vertices, faces, order=order, measure="area")
    t = math.ldexp(thickness, -area.scale_exp)          # exact: a power-of-two scale
    det_sum, det_error = _times(area.det_sum, area.det_error, 3 * t)
    first, first_error = _times(area.first, area.first_error, 4 * t)
    second, second_error = _times(area.second, area.second_error, 5 * t)
    # 3t and 5t are rounded once more: a relative u on each sum.
    det_error += U * abs(det_sum)
    second_error += U * float(np.max(np.abs(second)))
    return replace(area, det_sum=det_sum, det_error=det_error, first=first, first_error=first_error,
                   second=second, second_error=second_error)


def _without_duplicates(mesh, repair, path):
    """Refuse faces listed twice (they would count twice), or drop them under ``repair``."""
    keep = distinct_faces(mesh.faces)
    duplicates = mesh.faces.shape[0] - keep.size
    if not duplicates:
        return mesh, []
    if not repair:
        raise OpenMeshError(f"{duplicates} faces are duplicated (the same triangle twice)", path=path,
                            fix="remove the duplicates, or pass {repair}")
    return TriangleMesh(mesh.vertices, mesh.faces[keep], mesh.source_dtype), [f"removed {duplicates} duplicated face{'' if duplicates == 1 else 's'}"]


def shell_mass_properties(mesh, thickness, *, density=None, mass=None, unit=None, pose=None, repair=False,
                          order=2, path=None):
    """Mass properties of a surface as a sheet of ``thickness`` (mesh units).

    Returns
    -------
    properties : MassProperties
        ``volume`` is the sheet's, ``t · area``.
    checks : dict
    warnings : list of str
    """
    if not (math.isfinite(thickness) and thickness > 0):
        raise OptionError(f"{{shell}} thickness must be a positive number, got {thickness!r}")
    if not isinstance(mesh, TriangleMesh):
        raise OptionError("{shell} takes a surface mesh; this file holds volume cells", path=path,
                          fix="leave out {shell} to integrate the cells")
    mesh, warnings = _without_duplicates(mesh, repair, path)
    try:
        check_mesh(mesh, path=path)        # finite coordinates, valid indices
    except (OpenMeshError, WindingError):
        pass                               # a sheet need not bound a solid
    edges = edge_summary(mesh.faces, mesh.vertices.shape[0])
    boundary_edges = edges.boundary
    moments = shell_moments(mesh.vertices, mesh.faces, thickness, order=order)
    if not moments.det_sum > moments.det_error:
        raise MeshGeometryError("the surface has zero area", path=path, fix="check the export")
    properties = MassProperties.from_moments(moments, density=density, mass=mass, unit=unit, pose=pose,
                                             path=path)
    checks = {"closed": boundary_edges == 0 and not edges.odd, "orientation": "not needed (shell)",
              "shells": shells(mesh.faces, mesh.vertices.shape[0], labels=False)[1], "boundary_edges": boundary_edges,
              "duplicate_faces": 0, "shell_thickness": thickness,
              "self_intersection": "not checked"}
    return properties, checks, warnings
