"""Input resolution: how much the result can move within the input's own precision.

A coordinate stored as float32 (binary STL) or float64 is only known to half a
unit in its last place, ``δ = ulp(x)/2``.  Moving the boundary of a solid by a
displacement field ``δx`` changes any integral ``∫ f dV`` (f fixed) by
``∮ f (n·δx) dA`` to first order.  With every coordinate moving by at most
``δ`` (the largest over the mesh), ``|n·δx| ≤ |δx| ≤ √3 δ``, so with ``A`` the
surface area, ``c`` the center of mass, and ``R_i = max|x_i − c_i|``,
``R = max|x − c|`` over the vertices:

* volume:            ``|ΔV| ≤ √3 δ A``
* center of mass:    ``|Δc_i| ≤ √3 δ A R_i / V``  (``c = ∫x/V``; the change of
  ``c`` itself drops out because ``∫(x − c) dV = 0``)
* inertia about COM: ``‖ΔJ‖₂ ≤ ρ √3 δ A R²``, since ``|r|²I − r rᵀ`` has spectral
  norm ``|r|²``; this also bounds every element and, by Weyl, every principal
  moment.

The bounds are first order in ``δ`` (second-order terms are smaller by
``δ/size``) and cost one pass over the vertices.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .principal import axis_angle_bounds, physical_checks
from .properties import unit_length
from .records import replace
from ..core import _core
from ..core.arrays import as_points

__all__ = ["coordinate_resolution", "vertex_box", "with_input_resolution", "resolution_warning", "annotate"]

# The storage step (ulp) above which a warning says the input's precision limits
# the result, relative to the part's largest extent.
WARN_RELATIVE_STEP = 1e-5


def vertex_box(vertices):
    """``(low, high)``: each axis's lowest and highest coordinate of ``vertices`` (n ≥ 1, 3; finite), as tuples.

    One compiled pass over the rows (no copy), the values numpy's ``min`` and ``max`` along axis 0 give.
    """
    return _core.bounding_box(as_points(vertices))


@lru_cache(maxsize=None)
def _storage_type(source_dtype):
    dtype = np.dtype(source_dtype)
    return dtype.type if dtype.kind == "f" else np.float64


def _half_ulp(largest, source_dtype):
    return 0.5 * float(np.spacing(_storage_type(source_dtype)(largest)))


def coordinate_resolution(vertices, source_dtype):
    """Half a unit in the last place of the largest coordinate, in the precision it was stored with.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
    source_dtype : numpy dtype
        float32 for binary STL, float64 otherwise.

    Returns
    -------
    float: ``δ ≥ 0``, mesh units.
    """
    return _half_ulp(float(np.abs(vertices).max()) if vertices.size else 0.0, source_dtype)


def _largest_squared_distance(vertices, center):
    """``max |x − c|²`` over the vertices (n, 3), each ``(dx² + dz²) + dy²`` with every operation rounded.

    That order is the one ``numpy.einsum("ij,ij->i", d, d)`` used on the rows
    ``d = x − c`` before (its paired accumulation), so the values are unchanged;
    one compiled pass over the rows (``massprops/core/src/post.c``).
    """
    return _core.largest_squared_distance(as_points(vertices), tuple(center))


def with_input_resolution(props, mesh, *, mass_given=False, vertices=None):
    """``props`` with ``error.input_resolution`` filled in for ``mesh``.

    Keys (absolute, in the output's units): ``coordinates`` (the largest δ),
    ``volume``, ``mass``, ``center_of_mass``, ``inertia_com`` and
    ``principal_moments`` (both a bound on the tensor's spectral norm change),
    ``principal_axes_rad`` (per axis, Davis–Kahan over the eigen-gap).

    Parameters
    ----------
    props : MassProperties
        Computed from ``mesh`` (its center of mass is used).
    mesh : TriangleMesh
    mass_given : bool
        The total mass was given (density derived), so mass does not move and
        the density does.
    vertices : (low, high), optional
        :func:`vertex_box` of ``mesh.vertices``, if already found.
    """
    length = unit_length(props.unit)
    low, high = vertices if vertices is not None else vertex_box(mesh.vertices)
    # max |x| is the larger of |min| and |max|: exactly coordinate_resolution's input.
    delta = _half_ulp(max(abs(max(high)), abs(min(low))), mesh.source_dtype)
    volume = props.volume / length ** 3
    swept = math.sqrt(3.0) * delta * props.surface_area / length ** 2
    resolution = {"coordinates": delta * length, "volume": swept * length ** 3,
                  "mass": 0.0 if mass_given else props.density * swept * length ** 3}
    center = ([0.0, 0.0, 0.0] if props.center_of_mass is None
              else [c / length for c in np.asarray(props.center_of_mass, dtype=float).tolist()])
    if props.center_of_mass is not None:
        # Rounding is monotone, so max |x − c| over the vertices is at a face of the bounding box, bit for bit.
        farthest = max(max(h - c, c - l) for l, h, c in zip(low, high, center))
        resolution["center_of_mass"] = swept * farthest / volume * length
    if props.inertia_com is not None:
        inertia = props.density * swept * _largest_squared_distance(mesh.vertices, center) * length ** 5
        if mass_given:
            # J = (M / V) C: the derived density moves with the volume.
            inertia += float(np.linalg.norm(props.inertia_com, 2)) * swept / volume
        resolution.update(inertia_com=inertia, principal_moments=inertia)
    props = replace(props, error=replace(props.error, input_resolution=resolution))
    if props.inertia_com is not None:
        # The degenerate groups depend on the resolution itself (it widens the tolerance).
        groups = props.principal.degenerate
        resolution["principal_axes_rad"] = list(axis_angle_bounds(props.principal.moments, inertia, groups))
    return props


def resolution_warning(props, mesh, *, vertices=None):
    """A warning when the coordinates' storage step is coarse against the part's size, else None.

    ``vertices``: :func:`vertex_box` of ``mesh.vertices``, if already found.
    """
    low, high = vertices if vertices is not None else vertex_box(mesh.vertices)
    step = 2.0 * props.error.input_resolution.get("coordinates", 0.0)
    extent = max(h - l for l, h in zip(low, high)) * unit_length(props.unit)
    if not step or not extent or step / extent <= WARN_RELATIVE_STEP:
        return None
    dtype = np.dtype(mesh.source_dtype).name
    return (f"coordinates are stored as {dtype} and resolve only to steps of {step:.2g} "
            f"({step / extent:.1e} of the part's size) this far from the origin; the results can move by "
            "error.input_resolution within that precision — store the part near the origin or in double "
            "precision")


def annotate(props, mesh, *, mass_given=False):
    """Input resolution, physical validity checks and their warnings for ``props`` of ``mesh``.

    Returns
    -------
    props : MassProperties
        With ``error.input_resolution`` filled in.
    checks : dict
        ``positive_definite``, ``triangle_inequality``, ``triangle_margin``
        (when the inertia was computed; see
        :func:`massprops.model.principal.physical_checks`).
    warnings : list of str
    """
    vertices = vertex_box(mesh.vertices)
    props = with_input_resolution(props, mesh, mass_given=mass_given, vertices=vertices)
    warnings = [w for w in (resolution_warning(props, mesh, vertices=vertices),) if w]
    checks = {}
    if props.inertia_com is not None:
        moments = props.principal.moments
        checks = physical_checks(moments, props.principal.moments_error)
        if not checks["positive_definite"]:
            warnings.append(f"the smallest principal moment {moments[0]:.6g} is negative beyond its error bound: "
                            "no rigid body has this inertia — the mesh may intersect itself")
        if not checks["triangle_inequality"]:
            warnings.append("the principal moments violate I1 + I2 >= I3 beyond their error bound: no rigid body "
                            "has this inertia (physics engines reject it) — the mesh may intersect itself")
    return props, checks, warnings
