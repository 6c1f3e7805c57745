"""Arguments for the compiled core: C-contiguous arrays of the types it reads, checked once."""

from __future__ import annotations

import numpy as np

__all__ = ["as_points", "as_indices"]


def as_points(values, name="vertices"):
    """``values`` as a C-contiguous float64 array of shape (n, 3) (a view when it already is one)."""
    points = np.ascontiguousarray(values, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"{name}: expected an array of shape (n, 3), got shape {points.shape}")
    return points


def as_indices(values, columns=3, name="faces"):
    """``values`` as a C-contiguous int32 or int64 array of shape (m, columns)."""
    indices = np.asarray(values)
    if indices.dtype not in (np.int32, np.int64):
        if indices.size and indices.dtype.kind not in "iu":
            raise TypeError(f"{name}: expected integer vertex indices, got dtype {indices.dtype}")
        indices = indices.astype(np.int64)
    indices = np.ascontiguousarray(indices)
    if indices.ndim != 2 or indices.shape[1] != columns:
        if indices.size == 0:
            return np.zeros((0, columns), dtype=np.int64)
        raise ValueError(f"{name}: expected an array of shape (m, {columns}), got shape {indices.shape}")
    return indices
