"""Closed forms for drawing inertia, and the triangles to draw.

The **equivalent uniform box** of a body of mass ``m`` with principal moments
``I1, I2, I3`` is the box of uniform density with the same mass and the same
principal moments, its edges along the principal axes (the box MuJoCo, Gazebo
and RViz draw).  A box of half-extents ``a, b, c`` has ``I1 = m (b² + c²) / 3``
and so on, hence ``a² = 3 (I2 + I3 − I1) / (2 m)`` (cyclically).  The
**equivalent uniform ellipsoid** (the ellipsoid of inertia drawn by
``--glyph ellipsoid``) has ``I1 = m (b² + c²) / 5``, hence
``a² = 5 (I2 + I3 − I1) / (2 m)``.  A tensor that breaks the triangle
inequality (``I1 > I2 + I3``) has no such body: the negative square is drawn
as 0 and :func:`equivalent_box` says so through ``feasible``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Extents", "equivalent_box", "equivalent_ellipsoid", "box_mesh", "ellipsoid_mesh", "cylinder_mesh",
           "cone_mesh", "capsule_mesh", "decimated", "boundary_faces", "BOX_EDGES"]

# Corners of the unit box (±1 in each axis), index = 4 sx + 2 sy + sz with s in {0: −1, 1: +1}.
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
_BOX_FACES = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                       [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], dtype=np.int64)
BOX_EDGES = ((0, 1), (1, 3), (3, 2), (2, 0), (4, 5), (5, 7), (7, 6), (6, 4), (0, 4), (1, 5), (2, 6), (3, 7))


@dataclass(frozen=True)
class Extents:
    """Half-extents (box) or semi-axes (ellipsoid) along the principal axes, and whether such a body exists.

    ``half`` (3,) is in the result's length unit, ``half[k]`` along principal axis ``k``.
    """

    half: np.ndarray
    feasible: bool


def _extents(moments, mass, factor):
    moments = np.asarray(moments, dtype=float)
    if not (mass > 0) or moments.shape != (3,) or not np.all(np.isfinite(moments)):
        return Extents(np.zeros(3), False)
    squares = factor * (moments.sum() - 2 * moments) / (2 * mass)
    # Rounding can leave a flat body's square a few ulps below 0: that is a plate, not an infeasible tensor.
    slack = 8 * np.finfo(float).eps * factor * float(np.abs(moments).max()) / mass
    feasible = bool(np.all(squares >= -slack))
    return Extents(np.sqrt(np.clip(squares, 0.0, None)), feasible)


def equivalent_box(moments, mass):
    """Half-extents of the uniform box with this mass and these principal moments.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Principal moments about the centre of mass [mass·length²].
    mass : float

    Returns
    -------
    Extents
        ``half[k] = sqrt(3 (I_i + I_j − I_k) / (2 m))``; a cuboid of edges
        ``2a, 2b, 2c`` gives back ``a, b, c``.
    """
    return _extents(moments, mass, 3.0)


def equivalent_ellipsoid(moments, mass):
    """Semi-axes of the uniform ellipsoid with this mass and these principal moments (:class:`Extents`)."""
    return _extents(moments, mass, 5.0)


def _placed(points, center, axes):
    """Points given in principal coordinates, placed: ``center + points @ axes`` (``axes`` rows are unit axes)."""
    return np.asarray(center, dtype=float) + points @ np.asarray(axes, dtype=float)


def box_mesh(center, axes, half):
    """``(vertices (8, 3), faces (12, 3))`` of a box: centre, rows of ``axes`` its edge directions, half-extents."""
    return _placed(_CORNERS * np.asarray(half, dtype=float), center, axes), _BOX_FACES.copy()


def _grid(rings, segments):
    """Faces of a (rings × segments) grid wrapped around in the second index."""
    faces = []
    for i in range(rings - 1):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = a + segments, b + segments
            faces += [[a, b, d], [a, d, c]]
    return np.array(faces, dtype=np.int64)


def ellipsoid_mesh(center, axes, radii, *, rings=16, segments=24):
    """Triangles of an ellipsoid with semi-axes ``radii`` along the rows of ``axes`` (poles closed by rings)."""
    theta = np.linspace(0.0, np.pi, rings)
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    unit = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    return _placed(unit * np.asarray(radii, dtype=float), center, axes), _grid(rings, segments)


def _revolved(profile, segments=24):
    """A surface of revolution about z from ``profile`` (k, 2) rows (r, z), first and last r = 0."""
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    r, z = profile[:, :1], profile[:, 1:]
    points = np.stack([r * np.cos(phi), r * np.sin(phi), np.broadcast_to(z, (len(profile), segments))],
                      axis=-1).reshape(-1, 3)
    return points, _grid(len(profile), segments)


def cylinder_mesh(radius, length, segments=24):
    """A z-axis cylinder centred at the origin (display triangles)."""
    h = length / 2
    return _revolved(np.array([[0, -h], [radius, -h], [radius, h], [0, h]], dtype=float), segments)


def cone_mesh(radius, length, segments=24):
    """A z-axis cone, base at ``z = −length/2``, apex at ``+length/2``."""
    h = length / 2
    return _revolved(np.array([[0, -h], [radius, -h], [0, h]], dtype=float), segments)


def capsule_mesh(radius, length, segments=24, rings=6):
    """A z-axis capsule: a cylinder of ``length`` between two hemispheres of ``radius``."""
    angles = np.linspace(0.0, np.pi / 2, rings)
    bottom = np.stack([radius * np.sin(angles), -length / 2 - radius * np.cos(angles)], axis=1)
    top = np.stack([radius * np.cos(angles), length / 2 + radius * np.sin(angles)], axis=1)
    return _revolved(np.vstack([bottom, top]), segments)


def boundary_faces(cells):
    """The triangles of a tetrahedral mesh's boundary: faces that belong to one tetrahedron only.

    ``cells`` (k, 4) node indices; returns (f, 3), as the cells list them (for display, winding not used).
    """
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, 4)
    faces = np.concatenate([cells[:, [0, 1, 2]], cells[:, [0, 1, 3]], cells[:, [0, 2, 3]], cells[:, [1, 2, 3]]])
    keys = np.sort(faces, axis=1)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    return faces[counts[inverse.reshape(-1)] == 1]


def decimated(faces, limit):
    """At most ``limit`` of ``faces``, sampled evenly (display only): ``(faces, shown, total)``.

    Faces are kept in their order, every k-th one from a fixed start, so the
    same file always draws the same way.
    """
    faces = np.asarray(faces)
    total = int(faces.shape[0])
    if total <= limit:
        return faces, total, total
    keep = np.linspace(0, total - 1, int(limit)).round().astype(np.int64)
    keep = np.unique(keep)
    return faces[keep], int(keep.size), total
