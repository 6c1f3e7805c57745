"""Exact geometric decisions about a mesh's triangles: the Python face of ``_intersect``.

Every answer here is decided by the signs of orient3d and orient2d computed
exactly (a certified floating-point filter with an error-free expansion
behind it), so "these triangles do not meet" is never a rounding accident.

Coordinates are first shifted and scaled by a power of two, exactly (the
frame of :func:`massprops.core.reference_frame`), so the compiled
predicates work on numbers of about unit size.  Their expansions are exact
while no non-zero scaled coordinate is below ``2**-200`` (no product of
differences can underflow).  Smaller ones (a value 1e-60 of the part's size
that is not zero) are taken as zero for the decisions; the vertices moved
that way, and by how much, are listed (``moved_vertices``, ``moved``) so the
caller can bound what the decisions could miss.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.records import record
from . import _core
from .arrays import as_points
from .frame import frame_of
from .threads import threads_for

# Faces above which the intersection tests run on several threads (below, a thread costs more than it saves).
_PARALLEL_ABOVE = 1 << 16

__all__ = ["ExactGeometry", "Intersections"]

_SMALLEST = 2.0 ** -200


_LOADED = []


def _extension():
    """The compiled module, imported when first asked for (an import statement costs microseconds a call)."""
    if not _LOADED:
        from . import _intersect
        _LOADED.append(_intersect)
    return _LOADED[0]


@record
class Intersections:
    """Triangle pairs that share a point they should not.

    Attributes
    ----------
    self_found : ndarray, shape (shells,), bool
        Shells in which two faces meet other than along what they share
        (a self-intersection); only filled when asked for (``within``).
    examples : ndarray, shape (k, 2), int64
        Up to a few such face pairs (face indices of the mesh given).
    shell_pairs : ndarray, shape (p, 2), int64
        Pairs of different shells whose closed surfaces meet (touching counts), lower shell first.
    face_pairs : ndarray, shape (p, 2), int64
        For each shell pair, one pair of faces that meet.
    candidates, tests : int
        Face pairs the grid proposed, and pairs that reached the exact test.
    certified_shells, certified_vertices : int
        Shells, and vertices' stars, certified embedded as a whole (their face
        pairs need no test; see :meth:`ExactGeometry.certificates`).  Stars are
        only certified for the faces no patch covers (a patch: the faces of a
        cell of a coarse grid proved to be one embedded disk).
    pinched : int or None
        Vertices whose faces do not turn once around them (two bodies
        touching at a vertex or an edge, an edge of more than two faces);
        None when not looked at (``within`` off, or too many faces).
    """

    self_found: np.ndarray
    examples: np.ndarray
    shell_pairs: np.ndarray
    face_pairs: np.ndarray
    candidates: int
    tests: int
    certified_shells: int = 0
    certified_vertices: int = 0
    pinched: int | None = None


class ExactGeometry:
    """A mesh's vertices in the exact frame the compiled predicates use.

    Parameters
    ----------
    vertices : ndarray, shape (n, 3), float64
        Local-frame coordinates, mesh units (finite).

    Attributes
    ----------
    moved_vertices : ndarray of int, moved : ndarray of float
        Vertices with a coordinate below ``2**-200`` of the part's size, taken
        as zero, and a bound on each one's move (mesh units).
    frame : massprops.core.frame.Frame
        The vertices' integration frame (:func:`massprops.core.frame.frame_of`).
    unsnapped : ndarray or None
        ``vertices`` when they are exactly what the integration computes in
        ``frame`` (nothing snapped, the scale a normal power of two), else None.
    """

    def __init__(self, vertices):
        vertices = as_points(vertices)
        frame = frame_of(vertices)
        # (x - reference) * 2**-scale_exp, both steps exact; values below 2**-200 taken as zero.
        scaled, moved = _core.scale_snapped(vertices, frame.reference, frame.scale_exp, _SMALLEST)
        self.moved_vertices = np.asarray(moved)
        # Each snapped coordinate moves by less than 2**-200 (scaled): the vertex by less than √3 times that.
        self.moved = np.full(self.moved_vertices.size, math.ldexp(1.8, frame.scale_exp - 200))
        self.vertices = np.asarray(scaled)
        self.frame = frame
        # Both scale as (x - reference) * 2**-scale_exp, one rounding, when that power is a normal double.
        same = self.moved_vertices.size == 0 and -1023 <= frame.scale_exp <= 1022
        self.unsnapped = self.vertices if same else None

    def zero_area(self, faces):
        """Flags (m,) of the faces whose three corners are collinear or coincide, exactly."""
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        out = np.zeros(faces.shape[0], dtype=np.uint8)
        _extension().degenerate(self.vertices, faces, out)
        return out.view(bool)

    def intersections(self, faces, shells, n_shells, *, within, between, active=None, max_examples=8,
                      closed=False, threads=None):
        """Which faces meet, through a hierarchical grid and exact tests.

        Parameters
        ----------
        faces : ndarray, shape (m, 3), int
        shells : ndarray, shape (m,), int
            Shell label of each face, ``0 .. n_shells - 1``.  Faces of one
            shell that share vertices (by index) are neighbours: they meet
            only if they fold over each other beyond what they share.
        within, between : bool
            Look for self-intersections, and for meeting shells.
        active : ndarray, shape (m,), bool, optional
            Faces to consider (default all); faces of zero area never take part.
        max_examples : int
            Self-intersecting face pairs to keep as ``examples``; -1 keeps every
            meeting pair, within shells and between them.
        closed : bool
            Every edge is used as often in each direction (see :meth:`crossing_pairs`).

        Returns
        -------
        Intersections
        """
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        if threads is None:
            threads = threads_for(faces.shape[0], _PARALLEL_ABOVE)
        shells = np.ascontiguousarray(shells, dtype=np.int64)
        active = (np.ones(faces.shape[0], dtype=np.uint8) if active is None
                  else np.ascontiguousarray(active, dtype=np.uint8))
        flags, examples, found, candidates, tests, shells_certified, vertices_certified, pinched = _extension().pairs(
            self.vertices, faces, shells, active, max(1, int(n_shells)), bool(within), bool(between),
            int(max_examples), int(threads), bool(closed))
        found = np.frombuffer(found, dtype=np.int64).reshape(-1, 4)
        if found.shape[0] > 1:
            # Each shell pair once, with the faces found first (the search's order does not depend on threads).
            found = found[np.lexsort((found[:, 1], found[:, 0]))]
            first = np.ones(found.shape[0], dtype=bool)
            first[1:] = np.any(found[1:, :2] != found[:-1, :2], axis=1)
            found = found[first]
        return Intersections(np.frombuffer(flags, dtype=np.uint8).astype(bool)[:n_shells],
                             np.frombuffer(examples, dtype=np.int64).reshape(-1, 2).copy(),
                             found[:, :2].copy(), found[:, 2:].copy(), int(candidates), int(tests),
                             int(shells_certified), int(vertices_certified), None if pinched < 0 else int(pinched))

    def crossing_pairs(self, faces, shells=None, n_shells=1, *, closed=False, threads=None):
        """Every pair of faces that meet beyond the vertices and edges they share (by index).

        Faces that share vertices meet only if they fold over each other
        beyond what they share; faces of zero area take no part.

        Parameters
        ----------
        faces : ndarray, shape (m, 3), int
        shells : ndarray, shape (m,), int, optional
            Shell labels (``0 .. n_shells - 1``).  Each shell may be certified
            embedded as a whole, which spares the search within it; the pairs
            are the same as without labels.
        closed : bool
            The caller guarantees that every edge is used as often in each
            direction (a closed, consistently wound surface, as
            :func:`massprops.mesh.surface.check_shells` checks).  A one-shell
            mesh star-shaped about its centroid is then certified from its
            faces alone (a degree count), without each vertex's faces; the
            answers are the same.

        Returns
        -------
        pairs : ndarray, shape (p, 2), int64
            Face index pairs, lower first, each once.
        pinched : int or None
            Vertices whose faces do not turn once around them (see
            :attr:`Intersections.pinched`); None when unknown.
        """
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        if threads is None:
            threads = threads_for(faces.shape[0], _PARALLEL_ABOVE)
        # One shell: no labels (the core takes every face as shell 0) and no pairs between shells, so a
        # shell certified embedded as a whole needs no patch or grid at all.
        one = shells is None or n_shells <= 1
        shells = None if one else np.ascontiguousarray(shells, dtype=np.int64)
        found = _extension().pairs(self.vertices, faces, shells, None, 1 if one else int(n_shells), True, not one, -1,
                                   int(threads), bool(closed))
        pairs = np.frombuffer(found[1], dtype=np.int64).reshape(-1, 2)
        pinched = None if found[7] < 0 else int(found[7])
        if pairs.shape[0] <= 1:
            return pairs.copy(), pinched
        # each pair once, lexicographically: as np.unique(pairs, axis=0), on one key per pair (faces < m)
        m = max(faces.shape[0], 1)
        keys = np.unique(pairs[:, 0] * m + pairs[:, 1])
        return np.stack([keys // m, keys % m], axis=1), pinched

    def certificates(self, faces, shells=None, n_shells=1, *, threads=None):
        """Which vertex stars and which shells are certified to meet themselves only where they share.

        A vertex's star (its faces) is certified when, seen along some
        direction, its faces turn once around it in one sense; a shell, when
        it is star-shaped about its centroid in the same exact sense.  A
        certificate is a proof: the faces it covers meet only along the
        vertices and edges they share.  A missing one proves nothing.

        Parameters
        ----------
        faces : ndarray, shape (m, 3), int
        shells : ndarray, shape (m,), int, optional
            Shell label of each face (default: one shell).

        Returns
        -------
        stars : ndarray, shape (n,), bool
            Per vertex: its star is certified (only computed for vertices of shells
            not certified as a whole).
        shells : ndarray, shape (n_shells,), bool
            Per shell: certified as a whole.
        """
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        shells = (np.zeros(faces.shape[0], dtype=np.int64) if shells is None
                  else np.ascontiguousarray(shells, dtype=np.int64))
        if threads is None:
            threads = threads_for(faces.shape[0], _PARALLEL_ABOVE)
        stars, whole = _extension().certificates(self.vertices, faces, shells, max(1, int(n_shells)), int(threads))
        return (np.frombuffer(stars, dtype=np.uint8).astype(bool),
                np.frombuffer(whole, dtype=np.uint8).astype(bool)[:n_shells])

    def winding(self, faces, points):
        """Winding numbers of the closed surface ``faces`` about vertices ``points``.

        Parameters
        ----------
        faces : ndarray, shape (m, 3), int
            A closed, consistently wound surface (any number of shells).
        points : ndarray, shape (k,), int
            Vertex indices; none may lie on the surface.

        Returns
        -------
        ndarray, shape (k,), int64
            +1 inside a shell wound outward, -1 inside one wound inward, summed over shells.
        """
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        where = np.ascontiguousarray(self.vertices[np.asarray(points, dtype=np.int64)])
        return np.frombuffer(_extension().winding(self.vertices, faces, where), dtype=np.int64).copy()


def orient3d_signs(points):
    """Exact signs of ``det[a - d, b - d, c - d]`` for points (k, 4, 3) given as (a, b, c, d).

    Coordinates must be of about unit size with no non-zero magnitude below
    ``2**-200`` (see :class:`ExactGeometry`); negative when d is on the side
    the right-hand normal of (a, b, c) points to.
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 4, 3)   # noqa
    return np.frombuffer(_extension().orient3d_signs(points), dtype=np.int8).copy()

