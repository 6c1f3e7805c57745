"""Mesh repair on request (``--repair``), through trimesh; never applied silently.

Repair runs to a fixed point: duplicate faces removed, winding made
consistent, holes filled, and again (hole filling can add faces that repeat
existing ones) until a round changes nothing.  Every change is described in
the returned list, which the caller reports as warnings; shells left inside
out are turned outward later, by :mod:`massprops.mesh.shells`, which says so
too.  trimesh is imported here only, and only when repair is asked for.
"""

from __future__ import annotations

import re

import numpy as np

from .surface import TriangleMesh, distinct_faces

__all__ = ["repair_mesh", "after_repair"]

_ROUNDS = 8


def repair_mesh(mesh, *, path=None):
    """Remove duplicate faces, make winding consistent, fill holes; repeat until nothing changes.

    Returns
    -------
    (TriangleMesh, list of str)
        The repaired mesh and one sentence per kind of change made (counts summed over the rounds).
    """
    import trimesh

    removed = flipped = added = 0
    vertices, faces = mesh.vertices, mesh.faces
    for _ in range(_ROUNDS):
        keep = distinct_faces(faces)
        removed_now = faces.shape[0] - keep.size
        faces = faces[keep]
        tm = trimesh.Trimesh(vertices, faces, process=False, validate=False)
        before = tm.faces.copy()
        trimesh.repair.fix_winding(tm)
        flipped_now = int(np.count_nonzero(np.any(tm.faces != before, axis=1)))
        added_now = 0
        if not tm.is_watertight:
            n_before = len(tm.faces)
            trimesh.repair.fill_holes(tm)
            added_now = len(tm.faces) - n_before
        vertices, faces = np.asarray(tm.vertices, dtype=np.float64), np.asarray(tm.faces, dtype=np.int64)
        removed, flipped, added = removed + removed_now, flipped + flipped_now, added + added_now
        if not (removed_now or flipped_now or added_now):
            break
    else:
        # No fixed point (hole filling keeps adding faces that repeat others): the repeats go, at least.
        keep = distinct_faces(faces)
        removed += faces.shape[0] - keep.size
        faces = faces[keep]
    changes = []
    if removed:
        changes.append(f"removed {_faces(removed, 'duplicated ')}")
    if flipped:
        changes.append(f"re-oriented {_faces(flipped)} for consistent winding")
    if added:
        changes.append(f"closed holes with {_faces(added, 'new ')}")
    return TriangleMesh(vertices, faces, mesh.source_dtype, mesh.notes, mesh.unit), changes


def _faces(n, adjective=""):
    """``1 new face``, ``3 new faces``."""
    return f"{n} {adjective}face{'' if n == 1 else 's'}"


_ADVICE = (re.compile(r",? (or )?pass \{repair\}(?=[,)]|$)"), re.compile(r"^pass \{repair\} to (.*)$"),
           re.compile(r" \(\{repair\} [^)]*\)"))


def after_repair(error):
    """``error`` as it reads after repair was asked for: the same problem, advice that does not repeat it."""
    fix = error.fix or ""
    fix = _ADVICE[0].sub("", fix)
    fix = _ADVICE[1].sub(r"\1 by hand", fix)
    fix = _ADVICE[2].sub("", fix).strip(" ,")
    return type(error)(f"{error.problem} (left after {{repair}})", path=error.path, fix=fix or None)
