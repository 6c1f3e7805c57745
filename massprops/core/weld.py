"""Welding by exact coordinates: corners or indexed vertices to one vertex per distinct point.

Points weld when their coordinates are equal as numbers: float32 values on
their own bits (widened to float64 exactly), ``-0.0`` with ``+0.0``, NaNs only
with the same bits; never points that are merely close.  Vertices are
numbered in order of first use, and vertices no face uses are dropped.
"""

from __future__ import annotations

import numpy as np

from . import _core
from .arrays import as_indices, as_points
from .threads import thread_count

__all__ = ["weld_corners", "weld_indexed"]


def weld_corners(corners):
    """Weld triangle corners.

    Parameters
    ----------
    corners : array_like, shape (m, 3, 3) or (3m, 3), float32 or float64
        Corner k of triangle f at ``[f, k]`` (or row ``3f + k``).

    Returns
    -------
    vertices : ndarray, shape (n, 3), float64
    faces : ndarray, shape (m, 3), int64
    """
    corners = np.asarray(corners)
    dtype = np.float32 if corners.dtype == np.float32 else np.float64
    corners = np.ascontiguousarray(corners, dtype=dtype)
    if corners.shape[-1:] != (3,) or corners.size % 9:
        raise ValueError(f"corners: expected shape (m, 3, 3) or (3m, 3), got {corners.shape}")
    vertices, faces, _ = _core.weld_corners(corners, thread_count())
    return np.asarray(vertices), np.asarray(faces)


def weld_indexed(vertices, faces):
    """Weld the vertices that ``faces`` use.

    Parameters
    ----------
    vertices : array_like, shape (n, 3), float
    faces : array_like, shape (m, 3), int

    Returns
    -------
    vertices : ndarray, shape (k, 3), float64
        The distinct points faces use, in order of first use.
    faces : ndarray, shape (m, 3), int64
    ignored : int
        Vertices no face uses whose coordinates are NaN or infinite (left out like every unused one).

    Raises
    ------
    IndexError
        A face refers to a vertex that does not exist.
    """
    welded, renumbered, ignored = _core.weld_indexed(as_points(vertices), as_indices(faces), thread_count())
    return np.asarray(welded), np.asarray(renumbered), ignored
