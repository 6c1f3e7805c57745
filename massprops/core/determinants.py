"""Signed volumes with certified bounds, for decisions (signs, zero volume), not for sums.

Both functions evaluate determinants as the moment kernel does (Shewchuk's
a-priori bound, coordinates in the exact frame of :mod:`.frame`), so a value
whose magnitude exceeds its bound has a certain sign.  Values are in the
frame's scaled units (lengths divided by ``2**scale_exp``): compare them with
their bounds and with each other, not with mesh-unit volumes.
"""

from __future__ import annotations

import numpy as np

from . import _core
from .arrays import as_indices, as_points
from .frame import frame_of

__all__ = ["tetra_determinants", "shell_determinants"]


def tetra_determinants(points, tets):
    """Six times each tetrahedron's signed volume, and a bound on its error.

    Parameters
    ----------
    points : array_like, shape (n, 3), float
    tets : array_like, shape (t, 4), int
        Nodes p0..p3; the value is det[p1 − p0, p2 − p0, p3 − p0].

    Returns
    -------
    det, bound : ndarray, shape (t,), float64
        Scaled units (see the module note).
    """
    points = as_points(points, "points")
    frame = frame_of(points)
    det, bound = _core.tetra_determinants(points, as_indices(tets, 4, "tets"), frame.reference, frame.scale_exp)
    return np.asarray(det), np.asarray(bound)


def shell_determinants(vertices, faces, labels, count, frame=None):
    """Σ det (six times the signed volume enclosed) of each shell, and a bound on its error.

    Parameters
    ----------
    vertices : array_like, shape (n, 3), float
    faces : array_like, shape (m, 3), int
    labels : array_like, shape (m,), int
        Each face's shell, 0 .. count − 1 (:func:`massprops.core.shells`).
    count : int
    frame : Frame, optional
        ``frame_of(vertices)``, when the caller already has it.

    Returns
    -------
    det_sum, det_error : ndarray, shape (count,), float64
        Scaled units (see the module note).
    """
    vertices = as_points(vertices)
    if frame is None:
        frame = frame_of(vertices)
    labels = np.ascontiguousarray(labels, dtype=np.int64)
    det_sum, det_error = _core.shell_determinants(vertices, as_indices(faces), labels, int(count), frame.reference,
                                                  frame.scale_exp)
    return np.asarray(det_sum), np.asarray(det_error)
