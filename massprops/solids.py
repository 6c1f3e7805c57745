"""Analytic reference solids as exact triangle meshes, with their closed-form values.

Builders return :class:`massprops.mesh.TriangleMesh` objects wound outward.
"""

from __future__ import annotations

import math

import numpy as np

from .mesh import TriangleMesh

__all__ = ["box", "prism", "regular_prism", "l_bracket", "tetrahedron", "icosphere", "hollow_sphere", "combine"]


def box(size=(1.0, 1.0, 1.0), center=(0.0, 0.0, 0.0)):
    """An axis-aligned box, 8 vertices, 12 triangles."""
    half = np.asarray(size, dtype=float) / 2
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return TriangleMesh(corners * half + np.asarray(center, dtype=float), faces)


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


def regular_prism(n, radius=1.0, height=1.0, z0=None):
    """A prism over a regular n-gon inscribed in ``radius``, centred on the origin (a faceted cylinder)."""
    angles = 2 * np.pi * np.arange(n) / n
    polygon = np.column_stack([radius * np.cos(angles), radius * np.sin(angles)])
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


def icosphere(subdivisions=2, radius=1.0):
    """A geodesic sphere: an icosahedron subdivided and projected onto the sphere."""
    t = (1 + math.sqrt(5)) / 2
    v = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                  [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=float)
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
                  [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5],
                  [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]])
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
