"""Analytic reference solids as exact triangle meshes.

Builders return :class:`massprops.mesh.surface.TriangleMesh` objects wound outward
(right-hand normals point out of the solid).  Trigonometric coordinates are
computed with Python's ``math`` one value at a time, and vertices are placed
with element-wise arithmetic only, so the same call gives the same bits on any
machine: the reference files that ``massprops solids`` writes are
reproducible byte for byte.  Their closed-form values are in
:mod:`massprops.validation.analytic`.
"""

from __future__ import annotations

import math

import numpy as np

from ..mesh.surface import TriangleMesh

__all__ = ["box", "cube", "prism", "regular_prism", "l_bracket", "tetrahedron", "regular_tetrahedron",
           "octahedron", "icosahedron", "icosphere", "hollow_sphere", "combine", "revolve", "cone",
           "uv_sphere", "torus", "ellipsoid", "posed", "ring_angles"]

GOLDEN = (1 + math.sqrt(5)) / 2


def box(size=(1.0, 1.0, 1.0), center=(0.0, 0.0, 0.0)):
    """An axis-aligned box, 8 vertices, 12 triangles."""
    half = np.asarray(size, dtype=float) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return TriangleMesh(corners * half + np.asarray(center, dtype=float), faces)


def cube(edge=1.0, center=(0.0, 0.0, 0.0)):
    """A cube of side ``edge``: :func:`box` with equal sides."""
    return box((edge, edge, edge), center)


def prism(polygon, cap_triangles, height, z0=0.0):
    """Extrude a counter-clockwise polygon (k, 2) along z from ``z0`` to ``z0 + height``.

    ``cap_triangles`` (t, 3) triangulates the polygon, counter-clockwise.
    """
    polygon = np.asarray(polygon, dtype=float)
    k = polygon.shape[0]
    bottom = np.column_stack([polygon, np.full(k, float(z0))])
    top = np.column_stack([polygon, np.full(k, float(z0) + height)])
    caps = np.asarray(cap_triangles, dtype=np.int64)
    faces = [caps[:, ::-1], caps + k]
    i = np.arange(k)
    j = (i + 1) % k
    faces.append(np.column_stack([i, j, j + k]))
    faces.append(np.column_stack([i, j + k, i + k]))
    return TriangleMesh(np.vstack([bottom, top]), np.vstack(faces))


def ring_angles(n):
    """``(cos θ_i, sin θ_i)`` for θ_i = 2πi/n, i < n: two arrays (n,), from ``math``."""
    angles = [2 * math.pi * i / n for i in range(n)]
    return np.array([math.cos(a) for a in angles]), np.array([math.sin(a) for a in angles])


def regular_prism(n, radius=1.0, height=1.0, z0=None):
    """A prism over a regular n-gon inscribed in ``radius``, centred on the origin (a faceted cylinder)."""
    cos, sin = ring_angles(n)
    polygon = np.column_stack([radius * cos, radius * sin])
    fan = np.column_stack([np.zeros(n - 2, dtype=np.int64), np.arange(1, n - 1), np.arange(2, n)])
    return prism(polygon, fan, height, -height / 2 if z0 is None else z0)


def l_bracket(long=3.0, short=1.0, height=1.0):
    """An L-shaped prism: legs ``long`` along x and y, thickness ``short``, extruded by ``height``."""
    polygon = [(0, 0), (long, 0), (long, short), (short, short), (short, long), (0, long)]
    fan = [(3, 4, 5), (3, 5, 0), (3, 0, 1), (3, 1, 2)]
    return prism(polygon, fan, height)


def tetrahedron(points=((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))):
    """A tetrahedron wound outward whatever the order of its points."""
    p = np.asarray(points, dtype=float)
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    if np.linalg.det(p[1:] - p[0]) < 0:
        faces = faces[:, ::-1]
    return TriangleMesh(p, faces)


def regular_tetrahedron(half_edge=1.0):
    """Alternate corners of the cube [−h, h]³: edge ``2√2 h``, centred on the origin, exact coordinates."""
    h = float(half_edge)
    return tetrahedron(((h, h, h), (h, -h, -h), (-h, h, -h), (-h, -h, h)))


def octahedron(radius=1.0):
    """The regular octahedron with vertices ±radius on each axis (edge ``√2 radius``)."""
    r = float(radius)
    v = np.array([[r, 0, 0], [-r, 0, 0], [0, r, 0], [0, -r, 0], [0, 0, r], [0, 0, -r]])
    faces = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    return TriangleMesh(v, faces)


_ICOSAHEDRON_FACES = np.array([
    [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
    [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
    [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])


def icosahedron(half_edge=1.0):
    """The regular icosahedron with vertices (0, ±1, ±φ) cyclically, times ``half_edge`` (edge ``2 h``)."""
    t = GOLDEN
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    return TriangleMesh(v * float(half_edge), _ICOSAHEDRON_FACES.copy())


def icosphere(subdivisions=2, radius=1.0):
    """A geodesic sphere: an icosahedron subdivided and projected onto the sphere."""
    base = icosahedron()
    v, f = base.vertices, base.faces
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.vstack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = v[unique].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = inverse.reshape(3, -1) + len(v)
        a, b, c = f.T
        f = np.vstack([np.column_stack([a, m[0], m[2]]), np.column_stack([b, m[1], m[0]]),
                       np.column_stack([c, m[2], m[1]]), np.column_stack([m[0], m[1], m[2]])])
        v = np.vstack([v, mid])
    return TriangleMesh(v * radius, f)


def combine(*meshes):
    """Several meshes as one (several shells of one solid)."""
    vertices, faces, offset = [], [], 0
    for m in meshes:
        vertices.append(m.vertices)
        faces.append(m.faces + offset)
        offset += m.vertices.shape[0]
    return TriangleMesh(np.vstack(vertices), np.vstack(faces))


def hollow_sphere(outer=1.0, inner=0.5, subdivisions=2):
    """A thick spherical shell: an outward outer sphere and an inward (cavity) inner sphere."""
    return combine(icosphere(subdivisions, outer), icosphere(subdivisions, inner).flipped())


def revolve(profile, n, *, closed=False):
    """A solid of revolution about z with ``n`` sections: every profile point becomes a regular n-gon ring.

    Parameters
    ----------
    profile : array_like, shape (k, 2)
        Points ``(ρ, z)`` of the meridian, counter-clockwise around the region
        they bound in the (ρ, z) half-plane.  An open profile (``closed=False``)
        runs from a pole on the axis (ρ = 0) to a pole; a closed one (a torus's
        tube) stays off the axis.
    n : int
        Sections around the axis; the rings' vertices all sit at the angles
        2πi/n, so every side quad is a planar trapezoid and each cross-section
        is a regular n-gon (the closed forms of :mod:`massprops.validation.analytic` rely
        on both).
    """
    profile = np.asarray(profile, dtype=float)
    cos, sin = ring_angles(n)
    vertices, ring = [], []
    for rho, z in profile:
        ring.append(len(vertices))
        if rho == 0:
            vertices.append([0.0, 0.0, z])
        else:
            vertices.extend(np.column_stack([rho * cos, rho * sin, np.full(n, z)]).tolist())
    i = np.arange(n)

    def ids(k, step):
        # A pole is one vertex that every section shares.
        return ring[k] + (i + step) % n if profile[k, 0] else np.full(n, ring[k])

    faces = []
    for low in range(len(profile) if closed else len(profile) - 1):
        high = (low + 1) % len(profile)
        if profile[low, 0]:
            faces.append(np.column_stack([ids(low, 0), ids(low, 1), ids(high, 1)]))
        if profile[high, 0]:
            faces.append(np.column_stack([ids(low, 0), ids(high, 1), ids(high, 0)]))
    return TriangleMesh(np.array(vertices, dtype=float), np.vstack(faces).astype(np.int64))


def cone(n=32, radius=1.0, height=1.0):
    """A right circular cone with ``n`` sections: base on z = 0 (centre on the axis), apex at z = height."""
    return revolve([(0.0, 0.0), (radius, 0.0), (0.0, height)], n)


def sphere_profile(m, radius=1.0):
    """Meridian of a UV sphere with ``m`` stacks: (ρ, z) from the south pole to the north pole, (m + 1, 2)."""
    angles = [math.pi * j / m for j in range(1, m)]
    inner = [(radius * math.sin(a), -radius * math.cos(a)) for a in angles]
    return np.array([(0.0, -float(radius))] + inner + [(0.0, float(radius))])


def uv_sphere(n=32, m=16, radius=1.0):
    """A latitude–longitude sphere: ``n`` sections around z, ``m`` stacks pole to pole."""
    return revolve(sphere_profile(m, radius), n)


def torus_profile(m, major=2.0, minor=0.5):
    """The tube's cross-section: an m-gon of radius ``minor`` about (ρ, z) = (major, 0), counter-clockwise."""
    angles = [2 * math.pi * j / m for j in range(m)]
    return np.array([(major + minor * math.cos(a), minor * math.sin(a)) for a in angles])


def torus(n=32, m=16, major=2.0, minor=0.5):
    """A torus about z: ``n`` sections around the axis, ``m`` around the tube."""
    return revolve(torus_profile(m, major, minor), n, closed=True)


def ellipsoid(semi_axes=(3.0, 2.0, 1.0), n=32, m=16):
    """The affine image of :func:`uv_sphere` (radius 1) under diag(semi_axes)."""
    unit = uv_sphere(n, m, 1.0)
    return TriangleMesh(unit.vertices * np.asarray(semi_axes, dtype=float), unit.faces)


def posed(mesh, pose):
    """The mesh with every vertex moved to ``A x + t`` (a :class:`massprops.model.frames.Pose`).

    Written out element by element (no matrix product), so the bits do not
    depend on the BLAS library.
    """
    a, t = pose.rotation, pose.translation
    x = mesh.vertices
    moved = np.column_stack([((x[:, 0] * a[i, 0] + x[:, 1] * a[i, 1]) + x[:, 2] * a[i, 2]) + t[i]
                             for i in range(3)])
    return TriangleMesh(moved, mesh.faces)
