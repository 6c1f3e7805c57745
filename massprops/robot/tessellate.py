"""Polyhedra inside and around a curved primitive (sphere, cylinder, capsule, ellipsoid, cone), and certified tests.

Each primitive is, in its own frame (z its axis), a convex solid of
revolution ``{(x, y, z): |(x, y)| ≤ R(z)}`` (the ellipsoid the unit sphere
mapped by ``diag(a, b, c)``).  Two closed triangle surfaces bracket it:

* **inner** ``P_in``: ``n`` points around each of the circles ``|(x, y)| =
  R(z_j)`` at heights ``z_j`` of the meridian (``m`` steps along a half
  circle, ``m/2`` along a capsule's quarter circles; the ends of a cylinder
  or a cone), joined ring to ring, and to a point on the axis at each end.
  Every vertex is on the surface, so the solid the triangles bound lies in
  the convex hull of points of the convex primitive: ``P_in ⊂ P``.
* **outer** ``P_out``: the same rings on the polygon circumscribing the
  meridian (its vertices at ``r / cos(Δ/2)`` from the circle's centre, ``Δ``
  the meridian step: each edge tangent to the circle), each ring the regular
  ``n``-gon around the circle of that radius (vertices at ``1 / cos(π/n)``
  times it).  That solid is ``{g(x, y) ≤ ρ(z)}`` with ``g`` the gauge of the
  ``n``-gon (``g ≤ |·|``) and ``ρ ≥ R`` the circumscribed profile: it holds
  ``P``; its faces between two rings are planar trapezoids (two triangles in
  one plane), ``ρ`` is concave, so it is convex.

Both are built in floats: a vertex is within ``δ = 32u |v|`` of the ideal one
above (``u = 2⁻⁵³``: a correctly rounded ``cos``/``sin`` and a few products),
and callers add ``δ`` to the vertex's placement bound, so the swept-volume
bound of :func:`massprops.mesh.solid.swept_volume` covers the ideal
polyhedra, as it covers placing a mesh.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U

__all__ = ["CURVED", "tessellation", "faces_for", "inside_all", "apart"]

CURVED = ("sphere", "cylinder", "capsule", "ellipsoid", "cone")


def _dims(kind, size):
    if kind == "ellipsoid":
        return [float(x) for x in size["radii"]]
    if kind == "sphere":
        return [float(size["radius"])]
    return [float(size["radius"]), float(size["length"]) / 2]


def _profile(kind, size, m, outer):
    """The meridian ``[(z, ρ)]`` from the bottom pole to the top one (ρ 0 at both ends)."""
    if kind in ("sphere", "ellipsoid"):
        r = 1.0 if kind == "ellipsoid" else _dims(kind, size)[0]
        reach = r / math.cos(math.pi / (2 * m)) if outer else r
        points = [(-reach * math.cos(math.pi * j / m), reach * math.sin(math.pi * j / m)) for j in range(m + 1)]
        points[0], points[-1] = (-reach, 0.0), (reach, 0.0)
        return points
    r, h = _dims(kind, size)
    if kind == "cylinder":
        return [(-h, 0.0), (-h, r), (h, r), (h, 0.0)]
    if kind == "cone":
        return [(-h, 0.0), (-h, r), (h, 0.0)]
    # capsule: a quarter circle (centre z = −h) in q steps, the straight side, the mirror quarter circle
    q = max(1, m // 2)
    reach = r / math.cos(math.pi / (4 * q)) if outer else r
    low = [(-h - reach * math.cos(math.pi / 2 * j / q), reach * math.sin(math.pi / 2 * j / q)) for j in range(q + 1)]
    low[0], low[-1] = (-h - reach, 0.0), (-h, reach)
    return low + [(-z, rho) for z, rho in reversed(low)]


def faces_for(kind, n):
    """How many triangles :func:`tessellation` makes with ``n`` points around."""
    rings = {"sphere": n // 2 - 1, "ellipsoid": n // 2 - 1, "cylinder": 2, "cone": 1}.get(kind, 2 * max(1, n // 4))
    return 2 * n * rings


def tessellation(kind, size, n, outer):
    """``(vertices, faces, δ)``: the inner or outer polyhedron (own frame, outward), ``n`` points around
    (a multiple of 4); ``δ`` per vertex bounds its distance from the ideal vertex (see the module docstring)."""
    m = n // 2
    profile = _profile(kind, size, m, outer)
    grow = 1 / math.cos(math.pi / n) if outer else 1.0
    phi = 2 * math.pi * (np.arange(n) + 0.5) / n
    ring = np.column_stack([np.cos(phi), np.sin(phi)]) * grow
    points = [np.array([[0.0, 0.0, profile[0][0]]])]
    starts = []
    offset = 1
    for z, rho in profile[1:-1]:
        points.append(np.column_stack([ring * rho, np.full(n, z)]))
        starts.append(offset)
        offset += n
    points.append(np.array([[0.0, 0.0, profile[-1][0]]]))
    top = offset
    k = np.arange(n)
    k1 = (k + 1) % n
    faces = [np.column_stack([np.zeros(n, np.int64), starts[0] + k1, starts[0] + k])]
    for a, b in zip(starts, starts[1:]):
        faces.append(np.column_stack([a + k, a + k1, b + k1]))
        faces.append(np.column_stack([a + k, b + k1, b + k]))
    faces.append(np.column_stack([np.full(n, top), starts[-1] + k, starts[-1] + k1]))
    vertices = np.vstack(points)
    faces = np.vstack(faces).astype(np.int64)
    if kind == "ellipsoid":
        vertices = vertices * np.asarray(_dims(kind, size))
    delta = 32 * _U * np.linalg.norm(vertices, axis=1) * (1 + 1e-9) + 16 * math.ldexp(1.0, -1074)
    return vertices, faces, delta


# -- certified tests ------------------------------------------------------------------

def _inside_local(kind, size, y):
    """Exactly: is the point ``y`` (3 Fractions, own frame) in the primitive (its boundary included)?"""
    if kind == "ellipsoid":
        a, b, c = (Fraction(float(x)) for x in size["radii"])
        return (y[0] / a) ** 2 + (y[1] / b) ** 2 + (y[2] / c) ** 2 <= 1
    r = Fraction(float(size["radius"]))
    if kind == "sphere":
        return y[0] ** 2 + y[1] ** 2 + y[2] ** 2 <= r * r
    h = Fraction(float(size["length"])) / 2
    across = y[0] ** 2 + y[1] ** 2
    if kind == "cylinder":
        return across <= r * r and abs(y[2]) <= h
    if kind == "capsule":
        z = min(max(y[2], -h), h)
        return across + (y[2] - z) ** 2 <= r * r
    if not -h <= y[2] <= h:          # cone: base radius r at z = −h, apex at +h
        return False
    return across * (2 * h) ** 2 <= (r * (h - y[2])) ** 2


def _exact_point(x, linear, pose):
    """``R (L x) + t`` in Fractions (the exactly placed vertex)."""
    local = [sum(Fraction(float(linear[i, k])) * Fraction(float(x[k])) for k in range(3)) for i in range(3)]
    rotation, t = pose.rotation, pose.translation
    return [sum(Fraction(float(rotation[i, k])) * local[k] for k in range(3)) + Fraction(float(t[i]))
            for i in range(3)]


def _exact_inverse(matrix):
    a = [[Fraction(float(x)) for x in row] for row in matrix]
    det = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
           + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    if det == 0:
        return None
    cof = [[(a[(j + 1) % 3][(i + 1) % 3] * a[(j + 2) % 3][(i + 2) % 3]
             - a[(j + 1) % 3][(i + 2) % 3] * a[(j + 2) % 3][(i + 1) % 3]) for j in range(3)] for i in range(3)]
    return [[cof[i][j] / det for j in range(3)] for i in range(3)]


def inside_all(prim, surface, placed, exact_budget=20_000):
    """Certified: every point of the placed ``surface`` (a closed mesh, exactly placed) lies in the curved
    primitive ``prim`` (:func:`massprops.robot.curved.prims_of`), so the mesh's solid (inside the hull of its
    vertices) does too, the primitive being convex.

    Floats first: a vertex where the primitive's 1-Lipschitz ``g`` is below minus its move and rounding is
    inside; the others are decided in exact rationals (``y = R⁻¹ (R' L x + t' − t)``), at most ``exact_budget``.
    """
    points, _, moved = placed
    kind, size, rotation, t = prim.kind, prim.size, prim.rotation, prim.translation
    scale = float(np.abs(points).max()) + float(np.abs(t).max()) + float(np.max(prim.dims()))
    margin = moved * (1 + 1e-6) + 64 * _U * scale
    g = prim.g(points)
    if np.any(g > margin):
        return False
    unsure = np.flatnonzero(g >= -margin)
    if unsure.size > exact_budget:
        return False
    if unsure.size == 0:
        return True
    inverse = _exact_inverse(rotation)
    if inverse is None:
        return False
    tp = [Fraction(float(x)) for x in t]
    vertices = surface.mesh.vertices
    for index in unsure:
        x = _exact_point(vertices[index], surface.linear, surface.pose)
        d = [x[i] - tp[i] for i in range(3)]
        local = [sum(inverse[i][k] * d[k] for k in range(3)) for i in range(3)]
        if not _inside_local(kind, size, local):
            return False
    return True


def apart(prim, placed):
    """Certified: a plane separates the curved primitive ``prim`` from the placed mesh's vertices (so from its
    solid, which lies in their hull), with a margin over the moves and the rounding of the support functions."""
    points, _, moved = placed
    scale = float(np.abs(points).max()) + float(np.abs(prim.translation).max()) + float(np.max(prim.dims())) * 2
    eps = 64 * _U * scale + float(moved.max()) * (1 + 1e-6)
    centre = points.mean(axis=0)
    candidates = [centre - prim.translation, *prim.rotation.T, *np.eye(3)]
    for d in candidates:
        length = float(np.linalg.norm(d))
        if not length > 0:
            continue
        for direction in (d / length, -d / length):
            # The primitive below the plane d·x = s, every vertex above it.
            if prim.support(direction) + eps < float((points @ direction).min()):
                return True
    return False
