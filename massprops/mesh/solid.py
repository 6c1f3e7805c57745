"""What solid a closed mesh describes: the points of positive winding number.

The SPEC ("What solid a mesh describes") fixes the semantics; this module
decides (with :func:`massprops.mesh.shells.solid_of`, the entry point), for
a mesh that passed :func:`massprops.mesh.surface.check_shells`, which faces
bound that region, and says what it resolved on the way:

* **Repeated faces** (the same three vertices after welding): copies with
  the same orientation count once (a body written twice), a face and its
  reverse cancel (a two-sided sheet encloses nothing).  Detected always,
  even where the edges balance.
* **Shells** (connected components): each one's signed volume with a bound;
  a shell whose volume is zero within its bound contributes nothing and is
  dropped, its moments added to the error bound (its orientation is never
  read from a rounded sign).
* **Between shells** (only with more than one): shells whose boxes are
  disjoint cannot overlap; for the others :mod:`massprops.core.intersect`
  decides exactly whether any of their triangles meet.  Shells that meet are
  united through manifold3d (:mod:`massprops.mesh.union`).  The rest nest:
  an exact point-in-solid test gives the winding number just outside each
  one, and a shell (or a united group) contributes exactly when it bounds
  ``{w > 0}``: outward with ``w = 0`` outside, or inward (a cavity) with
  ``w = 1`` outside.  Shells nested in the same orientation, or repeated,
  are dropped; the volume counted more than once is reported as the overlap.
* **Within a shell**: the same exact machinery finds faces that cross or
  fold onto each other (faces sharing an edge or vertex are not an
  intersection unless they do).  A self-intersecting shell is refused: the
  region it bounds is not what its signed integral measures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import MeshGeometryError, OpenMeshError, WindingError
from ..core import edge_summary, face_groups, reference_frame, shell_determinants
from ..core import shells as count_shells

__all__ = ["Solid", "SELF_INTERSECTION_UP_TO", "without_unused_vertices", "without_repeated_faces",
           "shell_six_volumes", "swept_volume", "widened", "overlap_warning"]

# By default the self-intersection check runs on meshes up to this many faces: there it costs at most about
# a fifth of `massprops props` end to end on a torus (no shell or star certified whole; about 330 ns a
# face); at 300k faces a quarter, at 1.2M over 40% (benchmarks/bench_solid.py, docs/speed.md).
# ``self_intersection=True`` forces it at any size.
SELF_INTERSECTION_UP_TO = 200_000


@dataclass(frozen=True)
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


def without_unused_vertices(mesh):
    """``mesh`` without the vertices no face uses (non-finite ones noted), or ``mesh`` itself."""
    n = mesh.vertices.shape[0]
    faces = mesh.faces
    if faces.size == 0 or faces.min() < 0 or faces.max() >= n:
        return mesh
    used = np.zeros(n, dtype=bool)
    used[faces.ravel()] = True
    if used.all():
        return mesh
    notes = mesh.notes
    bad = int(np.count_nonzero(~used & ~np.isfinite(mesh.vertices).all(axis=1)))
    if bad:
        notes = (*notes, f"ignored {bad} vertices with NaN or infinite coordinates that no face uses")
    kept = np.flatnonzero(used)
    relabel = np.zeros(n, dtype=np.int64)
    relabel[kept] = np.arange(kept.size)
    return type(mesh)(mesh.vertices[kept], relabel[faces], mesh.source_dtype, notes, mesh.unit)


@dataclass(frozen=True)
class _Repeats:
    faces: np.ndarray            # faces kept, in input order
    same: int                    # copies dropped that repeat a face in the same orientation
    cancelled: int               # faces dropped in face-and-reverse pairs
    copies: np.ndarray           # those same-orientation copies (their shells and volume are reported)


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
    extra = np.abs(net[labels[kept]]) - 1
    return _Repeats(faces[kept], int(extra.sum()), int(np.sum(count - np.abs(net))),
                    np.repeat(faces[kept], extra, axis=0))


def without_repeated_faces(mesh, *, path=None):
    """Count faces written twice once, and cancel a face against its reverse.

    Returns
    -------
    mesh : TriangleMesh
    checks : dict
        ``duplicate_shells`` (shells written more than once) and ``duplicate_faces`` (copies dropped).
    warnings : list of str
    copies : ndarray, shape (k, 3)
        The dropped copies (their volume is counted in the overlap).

    Raises
    ------
    OpenMeshError
        Repeated faces that are not whole bodies or sheets (the rest of the
        surface does not close without them).
    """
    checks = {"duplicate_shells": 0, "duplicate_faces": 0}
    repeats = _repeats(mesh.faces)
    if repeats is None:
        return mesh, checks, [], np.zeros((0, 3), dtype=np.int64)
    # Only whole bodies or sheets written more than once are resolved: the surface as given must be
    # closed (each edge as often each way), and stay closed without the copies.
    if not all(edge_summary(f, mesh.vertices.shape[0]).balanced for f in (mesh.faces, repeats.faces)):
        raise OpenMeshError(f"{repeats.same + repeats.cancelled} faces are duplicated (the same triangle twice)",
                            path=path, fix="remove the duplicates, or pass {repair}")
    warnings = []
    if repeats.same:
        shells = count_shells(repeats.copies, mesh.vertices.shape[0], labels=False)[1]
        checks.update(duplicate_shells=int(shells), duplicate_faces=repeats.same)
        warnings.append(f"{repeats.same} faces are written more than once with the same orientation "
                        f"({shells} shell{'s' if shells != 1 else ''} repeated): each point counted once "
                        "(checks.duplicate_shells)")
    if repeats.cancelled:
        warnings.append(f"{repeats.cancelled} faces cancel against their reverses (two-sided sheets enclose "
                        "no volume): left out")
    if repeats.faces.shape[0] == 0:
        raise MeshGeometryError("the solid has zero volume: every face is cancelled by its reverse",
                                path=path, fix="a two-sided sheet needs {shell=THICKNESS}")
    return mesh.with_faces(repeats.faces), checks, warnings, repeats.copies


def shell_six_volumes(vertices, faces, labels, n_shells):
    """Six times each shell's signed volume and a bound on its error (rigorous).

    The compiled core's determinants (:func:`massprops.core.shell_determinants`:
    exact shift and scale, Shewchuk's bound per face, compensated sums per
    shell), brought back to mesh units by the frame's power of two.

    Returns
    -------
    six_volume, bound : ndarray, shape (n_shells,), mesh units³
    """
    _, scale_exp = reference_frame(vertices)
    sums, bounds = shell_determinants(vertices, faces, labels, n_shells)
    factor = math.ldexp(1.0, 3 * scale_exp)
    return sums * factor, bounds * factor


def swept_volume(points, faces, moved_vertices, moved):
    """A bound on the volume swept when vertices ``moved_vertices`` move by at most ``moved`` each.

    Moving vertex v by δ_v sweeps, across each triangle around it, a
    tetrahedron of volume at most δ_v · area / 3.  Moving the vertices one
    after another, a triangle's area grows by at most δ · perimeter + δ² with
    δ the largest move, so its enlarged area covers every order.

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
    touched = np.flatnonzero(delta[faces].max(axis=1) > 0)
    a, b, c = (points[faces[touched, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    perimeter = np.linalg.norm(b - a, axis=1) + np.linalg.norm(c - b, axis=1) + np.linalg.norm(a - c, axis=1)
    largest = float(moved.max())
    enlarged = (area + largest * perimeter + largest * largest) * (1 + 1e-9)     # no OverflowError: inf
    return float(np.sum(delta[faces[touched]].sum(axis=1) * enlarged)) / 3.0 * (1 + 1e-9)


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
        low, high = vertices.min(axis=0), vertices.max(axis=0)
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
    return overlap, (f"{', '.join(solid.resolved)}: the solid is their union, each point counted once "
                     f"(volume counted more than once: {overlap:.6g}, checks.overlap)")


def refuse_self_intersection(examples, path):
    """Raise for a shell whose faces cross (one line naming two of them)."""
    a, b = (int(v) for v in examples[0])
    more = ", and others" if len(examples) > 1 else ""
    raise MeshGeometryError(f"the surface intersects itself (faces {a} and {b} cross{more}): its signed volume is "
                            "not the volume it encloses, and manifold3d cannot unite a shell with itself",
                            path=path,
                            fix="remove the crossing in a modeller (or unite the bodies it joins) and export again; "
                                "{self_intersection=False} integrates the signed volume as it is")


def refuse_inside_out(count, n_shells, path):
    raise WindingError(f"{count} of {n_shells} shells are wound inward but lie outside every other shell "
                       "(a separate body turned inside out)", path=path,
                       fix="pass {repair} to orient every shell outward")
