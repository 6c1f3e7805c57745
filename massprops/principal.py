"""Principal moments and axes, with the SPEC's order, sign and degeneracy rules.

``J = V D Vᵀ``: moments ascending; ``axes[k]`` is the unit axis of
``moments[k]`` (a row), in the frame ``J`` is expressed in.  The rows form a
proper rotation (``a3 = a1 × a2``); in ``a1`` and ``a2`` the component of
largest magnitude is positive (the first index wins a tie).  Moments equal
within the tolerance form a degenerate group whose axes are not unique: the
frame's x, y, z axes projected into that subspace, in that order
(Gram–Schmidt), are used instead, so the answer does not depend on rounding
noise or on face order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Principal", "principal", "DEFAULT_RTOL"]

DEFAULT_RTOL = 1e-9
_U = 2.0 ** -53
# Below this length a local axis is taken to lie in the subspace's complement.
_PROJECTION_FLOOR = 1e-6


@dataclass(frozen=True)
class Principal:
    """Principal moments (3,), axes (3, 3) as rows, degenerate index groups,
    the moments' absolute error bound, and the tolerance used for grouping."""

    moments: np.ndarray
    axes: np.ndarray
    degenerate: tuple
    moments_error: float
    tolerance: float


def degenerate_groups(moments, tolerance):
    """Index groups of consecutive ascending moments closer than ``tolerance``."""
    groups, current = [], [0]
    for k in (1, 2):
        if moments[k] - moments[k - 1] <= tolerance:
            current.append(k)
        else:
            if len(current) > 1:
                groups.append(current)
            current = [k]
    if len(current) > 1:
        groups.append(current)
    return groups


def _canonical_sign(axis):
    k = int(np.argmax(np.abs(axis)))          # argmax returns the first of ties
    return axis if axis[k] > 0 else -axis


def _subspace_axes(basis):
    """The frame's axes projected into span(basis rows), Gram–Schmidt, in x, y, z order."""
    chosen = []
    for unit in np.eye(3):
        v = basis.T @ (basis @ unit)
        for w in chosen:
            v = v - (w @ v) * w
        length = np.linalg.norm(v)
        if length > _PROJECTION_FLOOR:
            chosen.append(v / length)
        if len(chosen) == basis.shape[0]:
            break
    return chosen


def principal(inertia, *, error=0.0, rtol=DEFAULT_RTOL, extra_tolerance=0.0):
    """Diagonalise an inertia tensor with the SPEC's conventions.

    Parameters
    ----------
    inertia : array_like, shape (3, 3)
        Symmetric inertia tensor, any consistent units.
    error : float
        Absolute bound on the largest element error of ``inertia``.
    rtol : float
        Relative gap below which moments count as equal (default 1e-9).
    extra_tolerance : float
        Further absolute tolerance folded into the degeneracy test (e.g. the
        change the input's own resolution allows).

    Returns
    -------
    Principal
    """
    inertia = np.asarray(inertia, dtype=float)
    inertia = 0.5 * (inertia + inertia.T)
    moments, vectors = np.linalg.eigh(inertia)
    scale = float(np.abs(moments).max())
    # Weyl: |Δλ| ≤ ‖ΔJ‖₂ ≤ 3·max|ΔJ_ij|; plus LAPACK's backward error.
    moments_error = 3.0 * error + 64.0 * _U * float(np.linalg.norm(inertia))
    tolerance = max(rtol * scale, moments_error, extra_tolerance)
    groups = degenerate_groups(moments, tolerance)
    axes = [vectors[:, k] for k in range(3)]
    for group in groups:
        basis = np.array([vectors[:, k] for k in group])
        for k, axis in zip(group, _subspace_axes(basis)):
            axes[k] = axis
    a1 = _canonical_sign(axes[0])
    a2 = _canonical_sign(axes[1] - (a1 @ axes[1]) * a1)
    a2 /= np.linalg.norm(a2)
    a3 = np.cross(a1, a2)
    return Principal(moments, np.array([a1, a2, a3]), tuple(tuple(g) for g in groups),
                     moments_error, tolerance)
