"""What solid a closed mesh describes: the points of positive winding number.

The SPEC ("What solid a mesh describes") fixes the semantics: after exact
welding a triangle soup is *closed* when every directed edge is balanced by
its reverse, counting multiplicity, and its solid is ``{w > 0}``, whatever its
faces do.  This module (with :func:`massprops.mesh.shells.solid_of`, the
entry point) decides which faces bound that region, and says what it
resolved on the way:

* **Repeated faces** (the same three vertices after welding) become one
  face counted as often as its net orientation says: copies with the same
  orientation count as many times (a body written twice has ``w = 2``
  inside), a face and its reverse cancel.  A soup whose every face comes
  with its reverse (a two-sided export) encloses nothing; when one copy of
  each pair is a closed surface, that surface's solid is integrated, with a
  warning.
* **Shells** (connected components): each one's signed volume with a bound;
  a shell whose volume is zero within its bound contributes nothing and is
  dropped, its moments added to the error bound (its orientation is never
  read from a rounded sign).
* **Faces that meet** beyond the vertices and edges they share (crossing
  themselves, crossing other shells, coinciding, touching) are found
  exactly (:mod:`massprops.core.intersect`); then the exact arrangement
  (:mod:`massprops.mesh.arrangement`) cuts them and keeps the pieces that
  bound ``{w > 0}``.  Without such faces, shells only nest: an exact
  point-in-solid test gives the winding number just outside each one, and a
  shell contributes exactly when it bounds ``{w > 0}``.
"""

from __future__ import annotations

import math
from dataclasses import field

import numpy as np

from ..model.records import record
from ..model.errors import MeshGeometryError
from ..core import _core, edge_summary, face_groups, reference_frame, shell_determinants
from ..core.arrays import as_indices
from ..core import shells as count_shells

__all__ = ["Solid", "without_unused_vertices", "without_repeated_faces",
           "shell_six_volumes", "swept_volume", "swept_sum", "widened", "overlap_warning"]


@record
class Solid:
    """The faces whose signed integrals are the solid's, and what was resolved to get them.

    Attributes
    ----------
    mesh : TriangleMesh
        Outward-wound faces (cavities inward) bounding ``{w > 0}``; may hold
        new vertices where shells were united.
    checks : dict
        ``overlap`` (volume counted more than once, mesh units³),
        ``duplicate_shells``, ``self_intersection`` and, when shells were
        dropped, ``dropped_shells``.
    warnings : tuple of str
    swept_volume : float
        Bound on the volume between the surface integrated and the exact one
        (intersection vertices rounded), mesh units³.
    zero_shell_faces : ndarray of int
        Faces (of ``mesh``'s vertex set) of shells dropped for zero volume:
        their moments, which are within their rounding of zero, bound the error of dropping them.
    flipped : bool
        Every shell was wound inward and was turned outward.
    resolved : tuple of str
        What was united or dropped ("2 shells meet", ...); empty when nothing was.
    naive_six : (float, float)
        Six times the volume the shells enclose counted with multiplicity
        (what summing their signed volumes gives), and a bound on its error:
        the overlap is the difference from the solid's (:func:`overlap_warning`).
    frame : Frame or None
        The integration frame of ``mesh.vertices`` (:func:`massprops.core.frame.frame_of`) when the
        checks already found it.
    scaled : ndarray or None
        ``mesh.vertices`` in ``frame`` exactly as the integration scales them, when the checks
        already have them (:attr:`massprops.core.intersect.ExactGeometry.unsnapped`).
    source : TriangleMesh or None
        The closed soup the solid was found from, when ``mesh`` holds cut pieces.
    """

    mesh: object
    checks: dict
    warnings: tuple = ()
    swept_volume: float = 0.0
    zero_shell_faces: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))
    flipped: bool = False
    resolved: tuple = ()
    naive_six: tuple = (0.0, 0.0)
    frame: object = None
    source: object = None
    scaled: object = None


def without_unused_vertices(mesh):
    """``mesh`` without the vertices no face uses (non-finite ones noted), or ``mesh`` itself."""
    n = mesh.vertices.shape[0]
    faces = mesh.faces
    if faces.size == 0:
        return mesh
    unused, outside = _core.unused_vertices(as_indices(faces), n)      # one compiled pass, no arrays
    if outside or not unused:
        return mesh
    used = np.zeros(n, dtype=bool)
    used[faces.ravel()] = True
    notes = mesh.notes
    bad = int(np.count_nonzero(~used & ~np.isfinite(mesh.vertices).all(axis=1)))
    if bad:
        notes = (*notes, f"ignored {bad} vertices with NaN or infinite coordinates that no face uses")
    kept = np.flatnonzero(used)
    relabel = np.zeros(n, dtype=np.int64)
    relabel[kept] = np.arange(kept.size)
    return type(mesh)(mesh.vertices[kept], relabel[faces], mesh.source_dtype, notes, mesh.unit)


@record
class _Repeats:
    faces: np.ndarray            # faces kept, in input order, each turned to its group's net orientation
    weights: np.ndarray          # how many times each kept face counts (its net multiplicity)
    same: int                    # copies that repeat a face in the same orientation
    cancelled: int               # faces dropped in face-and-reverse pairs
    first: np.ndarray            # one face of every group, as first given (for two-sided exports)


def _repeats(faces):
    """Reduce each set of faces on the same three vertices to one face of its net orientation, or none."""
    groups = face_groups(faces)
    labels, first = groups.labels, groups.first
    if first.size == faces.shape[0]:
        return None
    # +1 or -1: the face is an even or an odd permutation of its sorted triple.
    a, b, c = faces.T
    parity = 1 - 2 * (((a > b).astype(np.int64) + (a > c) + (b > c)) & 1)
    net = np.bincount(labels, weights=parity, minlength=first.size).astype(np.int64)
    count = np.bincount(labels, minlength=first.size)
    # In each group, the first face (in input order) with the net orientation is kept.
    order = np.lexsort((np.arange(faces.shape[0]), labels))
    matching = order[parity[order] == np.sign(net[labels[order]])]
    group = labels[matching]
    leading = np.ones(matching.size, dtype=bool)
    leading[1:] = group[1:] != group[:-1]
    kept = np.sort(matching[leading])
    weights = np.abs(net[labels[kept]])
    return _Repeats(faces[kept], weights, int((weights - 1).sum()), int(np.sum(count - np.abs(net))),
                    faces[np.sort(first)])


def without_repeated_faces(mesh, *, path=None):
    """Count each face as often as its copies say: same-orientation copies add, a face and its reverse cancel.

    Returns
    -------
    mesh : TriangleMesh
        One face per group of repeated faces (in its net orientation).
    checks : dict
        ``duplicate_shells`` (shells written more than once) and ``duplicate_faces`` (copies counted once).
    warnings : list of str
    weights : ndarray, shape (k,), int64, or None
        How many times each face of ``mesh`` counts, when any counts more than once.

    Raises
    ------
    MeshGeometryError
        Every face cancels against its reverse and one copy of each does not
        close: nothing is enclosed.
    """
    checks = {"duplicate_shells": 0, "duplicate_faces": 0}
    repeats = _repeats(mesh.faces)
    if repeats is None:
        return mesh, checks, [], None
    if repeats.faces.shape[0] == 0:
        return _one_side(mesh, repeats.first, path)
    warnings = []
    if repeats.same:
        copies = np.repeat(repeats.faces, repeats.weights - 1, axis=0)
        shells = count_shells(copies, mesh.vertices.shape[0], labels=False)[1]
        checks.update(duplicate_shells=int(shells), duplicate_faces=repeats.same)
        warnings.append(f"{repeats.same} faces are written more than once with the same orientation "
                        f"({shells} shell{'s' if shells != 1 else ''} repeated): each point counted once "
                        "(checks.duplicate_shells)")
    if repeats.cancelled:
        warnings.append(f"{repeats.cancelled} faces cancel against their reverses (two-sided sheets enclose "
                        "no volume): left out")
    weights = repeats.weights if repeats.same else None
    return mesh.with_faces(repeats.faces), checks, warnings, weights


def _one_side(mesh, faces, path):
    """A two-sided export: one copy of each face, wound consistently and outward, if that closes."""
    import trimesh
    n = mesh.vertices.shape[0]
    surface = trimesh.Trimesh(mesh.vertices, faces, process=False, validate=False)
    trimesh.repair.fix_winding(surface)             # as --repair winds a surface (mesh/repair.py)
    oriented = np.asarray(surface.faces, dtype=np.int64)
    if not edge_summary(oriented, n).balanced:
        raise MeshGeometryError("the solid has zero volume: every face is cancelled by its reverse, and one "
                                "copy of each does not close a surface (a two-sided sheet)", path=path,
                                fix="a two-sided sheet needs {shell=THICKNESS}")
    labels, n_shells = count_shells(oriented, n)
    six, _ = shell_six_volumes(mesh.vertices, oriented, labels, n_shells)
    inward = six[labels] < 0
    oriented[inward] = oriented[inward][:, ::-1]
    checks = {"duplicate_shells": 0, "duplicate_faces": int(faces.shape[0])}
    return mesh.with_faces(oriented), checks, [
        f"every face is written twice, once each way (a two-sided export): integrated the solid that one copy of "
        f"each of the {faces.shape[0]} faces encloses"], None


def shell_six_volumes(vertices, faces, labels, n_shells, frame=None):
    """Six times each shell's signed volume and a bound on its error (rigorous).

    The compiled core's determinants (:func:`massprops.core.shell_determinants`:
    exact shift and scale, Shewchuk's bound per face, compensated sums per
    shell), brought back to mesh units by the frame's power of two.  ``frame``
    is ``frame_of(vertices)`` when the caller already has it.

    Returns
    -------
    six_volume, bound : ndarray, shape (n_shells,), mesh units³
    """
    scale_exp = reference_frame(vertices)[1] if frame is None else frame.scale_exp
    sums, bounds = shell_determinants(vertices, faces, labels, n_shells, frame=frame)
    factor = math.ldexp(1.0, 3 * scale_exp)
    return sums * factor, bounds * factor


def swept_volume(points, faces, moved_vertices, moved):
    """A bound on the volume swept when vertices ``moved_vertices`` move by at most ``moved`` each.

    Moving vertex v by δ_v sweeps, across each triangle around it, a
    tetrahedron of volume at most δ_v · area / 3.  Moving the vertices one
    after another, a triangle's area grows by at most δ · perimeter + δ² with
    δ the largest move, so its enlarged area covers every order.

    That holds where the triangles around a moved vertex all move it (a
    closed surface stays closed).  Where they need not (the arrangement's cut
    pieces, whose corners may lie on other pieces' edges), each triangle's
    signed tetrahedra from the frame's reference also change by the cones
    from there over the walls its edges sweep: edge (a, b) sweeps a wall of
    area at most ``(|ab| + δ) (δ_a + δ_b)``, and its cone at most that times
    the wall's farthest distance from the reference, over 3.  Walls of edges
    used once each way cancel; the others are added.  The compiled core
    forms both kinds of terms for the cut pieces in one pass
    (``massprops/core/src/isect/swept.c``, from
    :func:`massprops.mesh.shells._with_pieces`), with the same operations on
    the same doubles as here; :func:`swept_sum` adds them.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        Vertex coordinates after the move (mesh units).
    faces : ndarray, shape (m, 3), int
    moved_vertices : ndarray of int, moved : ndarray of float
        Which vertices moved, and an upper bound on each one's move.

    Returns
    -------
    float, mesh units³
    """
    if moved.size == 0:
        return 0.0
    delta = np.zeros(points.shape[0])
    delta[moved_vertices] = moved
    around = delta[faces]
    # (the ufuncs' reductions called directly: the same sums, without numpy's Python-level wrappers)
    touched = np.flatnonzero(np.maximum.reduce(around, axis=1) > 0)
    faces, around = faces[touched], around[touched]
    a, b, c = (points[faces[:, k]] for k in range(3))
    k = touched.size
    # the edges' lengths in one call (row by row as three); the cross product as np.cross computes it
    sides = np.empty((4 * k, 3))
    np.subtract(b, a, out=sides[:k]), np.subtract(c, b, out=sides[k:2 * k]), np.subtract(a, c, out=sides[2 * k:3 * k])
    u, v, n = sides[:k], c - a, sides[3 * k:]
    np.subtract(u[:, 1] * v[:, 2], u[:, 2] * v[:, 1], out=n[:, 0])
    np.subtract(u[:, 2] * v[:, 0], u[:, 0] * v[:, 2], out=n[:, 1])
    np.subtract(u[:, 0] * v[:, 1], u[:, 1] * v[:, 0], out=n[:, 2])
    lengths = np.linalg.norm(sides, axis=1)
    area = 0.5 * lengths[3 * k:]
    perimeter = lengths[:k] + lengths[k:2 * k] + lengths[2 * k:3 * k]
    largest = float(moved.max())
    enlarged = (area + largest * perimeter + largest * largest) * (1 + 1e-9)     # no OverflowError: inf
    return swept_sum(np.add.reduce(around, axis=1) * enlarged)


def swept_sum(face_terms, wall_terms=None):
    """:func:`swept_volume` from its terms: three times each face's bound, and, for cut pieces, three times
    each unmatched wall's cone (mesh units³), each sum widened."""
    total = float(np.add.reduce(face_terms)) / 3.0
    if wall_terms is not None:
        total += float(np.add.reduce(wall_terms)) / 3.0 * (1 + 1e-9)
    return total * (1 + 1e-9)


def widened(moments, vertices, *, swept=0.0, reach=0.0, dropped=None):
    """``moments`` with bounds that also cover a moved surface and dropped shells.

    Parameters
    ----------
    moments : Moments
        Integrated over ``vertices`` (its frame).
    swept : float
        Bound on the volume between the surface integrated and the one meant (mesh units³),
        see :func:`swept_volume`; the integrands ``1, x, x xᵀ`` are bounded over it by the
        farthest vertex from the reference plus ``reach`` (the largest move).
    dropped : Moments, optional
        Moments of shells left out for zero volume, in the same frame: each
        within its rounding of zero, so its size plus its bound is added.
    """
    from dataclasses import replace
    det_error, first_error, second_error = moments.det_error, moments.first_error, moments.second_error
    if swept:
        scale = math.ldexp(1.0, -moments.scale_exp)
        # (the box in one compiled pass: numpy's min and max along the rows of (n, 3) are ~10x slower)
        low, high = (np.array(x) for x in _core.bounding_box(np.ascontiguousarray(vertices, dtype=np.float64)))
        radius = float(np.linalg.norm(np.maximum(np.abs(low - moments.reference), np.abs(high - moments.reference))))
        r = (radius + reach) * scale * (1 + 1e-9)
        s = swept * scale ** 3 * (1 + 1e-9)
        det_error += 6 * s
        first_error += 24 * s * r
        second_error += 120 * s * r * r
    if dropped is not None:
        det_error += abs(dropped.det_sum) + dropped.det_error
        first_error += float(np.max(np.abs(dropped.first))) + dropped.first_error
        second_error += float(np.max(np.abs(dropped.second))) + dropped.second_error
    return replace(moments, det_error=det_error, first_error=first_error, second_error=second_error)


def overlap_warning(solid, moments):
    """``(overlap, warning or None)``: the volume counted more than once, mesh units³, from the solid's moments.

    Shells that only touch (boxes sharing a face) are united, but count
    nothing twice: an overlap within the rounding bounds of both volumes is
    zero, and nothing is said.
    """
    if not solid.resolved:
        return 0.0, None
    factor = math.ldexp(1.0, 3 * moments.scale_exp)
    naive, naive_bound = solid.naive_six
    overlap = (naive - moments.det_sum * factor) / 6.0
    if abs(overlap) <= (naive_bound + moments.det_error * factor) / 6.0 * (1 + 1e-9):
        return 0.0, None
    if overlap > 0:
        return overlap, (f"{', '.join(solid.resolved)}: the solid is their union, each point counted once "
                         f"(volume counted more than once: {overlap:.6g}, checks.overlap)")
    return overlap, (f"{', '.join(solid.resolved)}: the solid is the region the surface winds around positively, "
                     f"each point counted once (the faces' signed volume leaves out {-overlap:.6g} of it, "
                     "checks.overlap)")
