"""Mesh repair on request (``--repair``), through trimesh; never applied silently.

Every change is described in the returned list, which the caller reports as
warnings.  trimesh is imported here only, and only when repair is asked for.
"""

from __future__ import annotations

import numpy as np

from .surface import TriangleMesh, distinct_faces

__all__ = ["repair_mesh"]


def repair_mesh(mesh, *, path=None):
    """Remove duplicate faces, make winding consistent and outward, fill small holes.

    Returns
    -------
    (TriangleMesh, list of str)
        The repaired mesh and one sentence per change made.
    """
    import trimesh

    changes = []
    faces = mesh.faces
    keep = distinct_faces(faces)
    if keep.size < faces.shape[0]:
        changes.append(f"removed {faces.shape[0] - keep.size} duplicated faces")
        faces = faces[keep]
    tm = trimesh.Trimesh(mesh.vertices, faces, process=False, validate=False)
    before = tm.faces.copy()
    trimesh.repair.fix_winding(tm)
    flipped = int(np.count_nonzero(np.any(tm.faces != before, axis=1)))
    if flipped:
        changes.append(f"re-oriented {flipped} faces for consistent winding")
    n_before = len(tm.faces)
    if not tm.is_watertight:
        trimesh.repair.fill_holes(tm)
        added = len(tm.faces) - n_before
        if added:
            changes.append(f"closed holes with {added} new faces")
    return TriangleMesh(np.asarray(tm.vertices, dtype=np.float64), np.asarray(tm.faces, dtype=np.int64),
                        mesh.source_dtype), changes
