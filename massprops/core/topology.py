"""Edges, shells and duplicate faces: what the mesh checks count, from the compiled core.

All three look at vertex indices only (coordinates are welded before, see
:mod:`.weld`), run without the GIL, and give the same answer whatever the
thread count.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from ..model.records import record
from . import _core
from .arrays import as_indices
from .threads import threads_for

# Faces above which edges are matched on several threads: below, starting a thread costs more than it saves.
_PARALLEL_ABOVE = 1 << 14

__all__ = ["EdgeSummary", "edge_summary", "edge_shells", "shells", "FaceGroups", "face_groups", "group_rows", "distinct_faces"]


@record
class EdgeSummary:
    """Counts over the undirected edges of a triangle mesh.

    A directed edge runs from corner k to corner k+1 of a face.  An edge's
    ``uses`` counts its directed edges either way; its ``balance`` is the
    uses from its lower vertex to its higher minus the uses back.  A closed,
    consistently wound surface has balance 0 on every edge.

    Attributes
    ----------
    edges, boundary, odd, unbalanced, nonmanifold : int
        Distinct edges; used once; used an odd number of times; with a
        non-zero balance; used more than twice.
    max_uses : int
    collapsed : int
        Directed edges from a vertex to itself.
    degenerate_faces : int
        Faces with a repeated vertex.
    first_boundary, first_unbalanced : (int, int) or None
        The (lower, higher) vertices of the first such edge, in vertex order.
    edge_vertices : ndarray, shape (k, 2), int64, or None
        With ``arrays=True``: every edge's vertices, by lower then higher vertex.
    uses, balance : ndarray, shape (k,), int32, or None
    """

    edges: int
    boundary: int
    odd: int
    unbalanced: int
    nonmanifold: int
    max_uses: int
    collapsed: int
    degenerate_faces: int
    first_boundary: Optional[tuple]
    first_unbalanced: Optional[tuple]
    edge_vertices: Optional[np.ndarray] = None
    uses: Optional[np.ndarray] = None
    balance: Optional[np.ndarray] = None

    @property
    def balanced(self):
        """Every edge used as often forward as backward."""
        return self.unbalanced == 0


def edge_summary(faces, n_vertices, *, arrays=False):
    """Match the directed edges of ``faces`` into undirected edges and count them.

    Parameters
    ----------
    faces : array_like, shape (m, 3), int
        Vertex indices, each below ``n_vertices``.
    n_vertices : int
    arrays : bool
        Also return every edge with its uses and balance.

    Returns
    -------
    EdgeSummary

    Raises
    ------
    IndexError
        A face refers to a vertex that does not exist.
    ValueError
        2**31 vertices or more.
    """
    faces = as_indices(faces)
    found = _core.edge_summary(faces, int(n_vertices), threads_for(faces.shape[0], _PARALLEL_ABOVE), arrays)
    for name in ("first_boundary", "first_unbalanced"):
        found[name] = None if found[name][0] < 0 else found[name]
    for name in ("edge_vertices", "uses", "balance"):
        if name in found:
            found[name] = np.asarray(found[name])
    return EdgeSummary(**found)


def edge_shells(faces, n_vertices):
    """:func:`edge_summary` (without the arrays) and :func:`shells` at once, the shells found beside the edges.

    Returns
    -------
    summary : EdgeSummary
    labels : ndarray, shape (m,), int64, or None
        Each face's shell as :func:`shells` numbers them; None when there is one shell.
    count : int
    """
    faces = as_indices(faces)
    found, labels, count = _core.edge_shells(faces, int(n_vertices), threads_for(faces.shape[0], _PARALLEL_ABOVE))
    boundary, unbalanced = found["first_boundary"], found["first_unbalanced"]
    # every field by position: the record's quickest construction (once a part in a batch)
    summary = EdgeSummary(found["edges"], found["boundary"], found["odd"], found["unbalanced"], found["nonmanifold"],
                          found["max_uses"], found["collapsed"], found["degenerate_faces"],
                          None if boundary[0] < 0 else boundary, None if unbalanced[0] < 0 else unbalanced,
                          None, None, None)
    return summary, (None if labels is None else np.asarray(labels)), count


def shells(faces, n_vertices, *, labels=True):
    """Connected components of faces that share a vertex.

    Returns
    -------
    labels : ndarray, shape (m,), int64, or None
        Each face's shell, numbered 0, 1, ... in order of each shell's first
        face (None with ``labels=False``).
    count : int
    """
    found, count = _core.shells(as_indices(faces), int(n_vertices), labels)
    return (None if found is None else np.asarray(found)), count


@record
class FaceGroups:
    """Faces grouped by their set of three vertices.

    Attributes
    ----------
    labels : ndarray, shape (m,), int64
        Each face's group, numbered in order of each group's first face.
    first : ndarray, shape (k,), int64
        The first face of each group (ascending).
    same_orientation, opposite_orientation : int
        Faces that repeat their group's first face, wound the same way or
        the other way (a face with a repeated vertex counts as the same).
    """

    labels: np.ndarray
    first: np.ndarray
    same_orientation: int
    opposite_orientation: int

    @property
    def duplicates(self):
        """Faces whose vertex set an earlier face already has."""
        return self.same_orientation + self.opposite_orientation


def face_groups(faces):
    """Group the faces with the same three vertices (:class:`FaceGroups`)."""
    labels, first, same, opposite = _core.row_groups(as_indices(faces), 3)
    return FaceGroups(np.asarray(labels), np.asarray(first), same, opposite)


def group_rows(rows):
    """Group rows of vertex indices that hold the same set of indices (quadrilaterals, cells...).

    Parameters
    ----------
    rows : array_like, shape (m, k), int, k <= 8

    Returns
    -------
    labels : ndarray, shape (m,), int64
        Each row's group, numbered in order of each group's first row.
    first : ndarray, shape (g,), int64
        The first row of each group (ascending).
    """
    rows = np.asarray(rows)
    columns = rows.shape[1] if rows.ndim == 2 else 3
    labels, first, _, _ = _core.row_groups(as_indices(rows, columns, "rows"), columns)
    return np.asarray(labels), np.asarray(first)


def distinct_faces(faces):
    """Indices (ascending) of the first face of each set of vertices: duplicates left out."""
    return face_groups(faces).first
