"""Volume cells whose quadrilateral faces are not flat: how far, and what it can change.

massprops splits every quadrilateral face along the diagonal through its
smallest node (:mod:`massprops.mesh.volume`), so a cell is integrated as the
polyhedron with those flat triangles.  A finite-element hexahedron (and a
wedge's or pyramid's quadrilateral) is trilinear: its faces are bilinear
patches, which lie between a face's two diagonal splits.  Between the split
and the patch lies a volume of ``|det[b − a, c − a, d − a]| / 12`` per face
(a, b, c, d its corners), so the two volumes differ by at most the sum of
that over the faces on the body's boundary (faces two cells share cancel:
both use the same split).  massprops keeps the flat split and says so with a
warning naming the largest non-planarity, rather than integrate the
trilinear cells.
"""

from __future__ import annotations

import numpy as np

from ..core import group_rows

__all__ = ["nonplanar_quads"]

# Non-planarity below this fraction of a face's size is rounding, not geometry.
_NOISE = 1e-9


def nonplanar_quads(points, blocks, cell_faces):
    """A warning about non-planar quadrilateral faces, or None, and their count.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    blocks : sequence of (cell type, ndarray (k, nodes))
    cell_faces : dict
        Outward faces of each cell type (:data:`massprops.mesh.volume.CELL_FACES`).

    Returns
    -------
    warning : str or None
    count : int
        Quadrilateral faces (counted once where two cells share one) that are not flat.
    """
    quads, kinds = [], []
    for cell_type, cells in blocks:
        for face in cell_faces[cell_type]:
            if len(face) == 4:
                quads.append(cells[:, list(face)])
                kinds.append(np.full(cells.shape[0], cell_type, dtype=object))
    if not quads:
        return None, 0
    quads, kinds = np.vstack(quads), np.concatenate(kinds)
    a, b, c, d = (points[quads[:, k]] for k in range(4))
    twist = np.cross(c - a, d - b)
    det = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))
    span = np.maximum(np.linalg.norm(c - a, axis=1), np.linalg.norm(d - b, axis=1))
    apart = np.abs(det) / np.maximum(np.linalg.norm(twist, axis=1), np.finfo(float).tiny)
    bent = apart > _NOISE * span
    if not bent.any():
        return None, 0
    labels, first = group_rows(quads)
    on_boundary = np.bincount(labels, minlength=first.size)[labels] == 1
    count = int(np.unique(labels[bent]).size)
    worst = int(np.argmax(np.where(bent, apart / span, 0.0)))
    difference = float(np.sum(np.abs(det[on_boundary & bent]))) / 12.0
    cells = ", ".join(sorted(set(kinds[bent].tolist())))
    return (f"{count} quadrilateral faces of the {cells} cells are not flat (largest: diagonals "
            f"{apart[worst]:.3g} apart, {apart[worst] / span[worst]:.1e} of the face); each is split into two "
            f"flat triangles, so the volume may differ from trilinear finite-element cells by up to "
            f"{difference:.3g}"), count
