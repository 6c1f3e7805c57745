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

import math
from functools import lru_cache

import numpy as np

from .records import record
from ..core import _core
from ..core.rounding import U as _U

__all__ = ["Principal", "principal", "axis_angle_bounds", "physical_checks", "DEFAULT_RTOL", "AXIS_ANGLE_TOLERANCE"]

DEFAULT_RTOL = 1e-9
# An axis whose angle bound exceeds this (radians) is not determined by the
# tensor: its moment joins its nearest neighbour's degenerate group.
AXIS_ANGLE_TOLERANCE = 1e-3
# Below this length a local axis is taken to lie in the subspace's complement.
_PROJECTION_FLOOR = 1e-6


@record
class Principal:
    """Principal moments (3,), axes (3, 3) as rows, degenerate index groups,
    the moments' absolute error bound, the tolerance used for grouping, and
    per axis a bound on its angle error in radians (:func:`axis_angle_bounds`)."""

    moments: np.ndarray
    axes: np.ndarray
    degenerate: tuple
    moments_error: float
    tolerance: float
    axes_error: tuple = ()

    def __post_init__(self):
        self.moments.setflags(write=False)        # principal() made them; read-only like every result
        self.axes.setflags(write=False)


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


def axis_angle_bounds(moments, norm_error, groups=()):
    """Davis–Kahan bound on the angle of each principal axis, radians.

    If the tensor is off by ``E`` with ``‖E‖₂ ≤ norm_error``, an axis whose
    moment is ``gap`` away from the others' moments turns by at most
    ``θ = asin(‖E‖ / (gap − ‖E‖))`` (the gap of the exact tensor is at least
    ``gap − ‖E‖`` by Weyl); ``π/2`` when the gap does not exceed ``2‖E‖``.  For
    an axis in a degenerate group the bound is that of the group's subspace
    (the gap to the moments outside it; 0 when all three are equal): within
    the subspace the axes are fixed by convention.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Ascending principal moments.
    norm_error : float
        Bound on the spectral norm of the tensor's error (≤ 3 × the
        elementwise bound).
    groups : sequence of index groups
        Degenerate groups, as :func:`degenerate_groups` returns them.

    Returns
    -------
    tuple of 3 floats
    """
    values = np.asarray(moments, dtype=float).tolist()
    bounds = []
    for k in range(3):
        inside = (k,)
        for g in groups:
            if k in g:
                inside = g
                break
        nearest = None                  # min() of the gaps to the moments outside: the first of equal ones
        for j in range(3):
            if j not in inside:
                gap = abs(values[k] - values[j])
                if nearest is None or gap < nearest:
                    nearest = gap
        if nearest is None:
            bounds.append(0.0)
            continue
        gap = nearest - norm_error
        ratio = norm_error / gap if gap > 0 else math.inf
        bounds.append(float(np.arcsin(ratio)) + 4 * _U if ratio < 1 else math.pi / 2)
    return tuple(bounds)


def physical_checks(moments, moments_error):
    """Whether principal moments can belong to a rigid body, within their error bound.

    Every real mass distribution has ``I1 > 0`` and ``I1 + I2 ≥ I3`` (equality
    only for a flat lamina); physics engines reject tensors that break either.

    Parameters
    ----------
    moments : array_like, shape (3,)
        Ascending principal moments.
    moments_error : float
        Absolute bound on each moment's error.

    Returns
    -------
    dict: ``positive_definite`` and ``triangle_inequality`` (bool), and
    ``triangle_margin`` ``(I1 + I2 − I3) / I3``.
    """
    i1, i2, i3 = (float(m) for m in moments)
    return {"positive_definite": bool(i1 > -moments_error),
            "triangle_inequality": bool(i1 + i2 - i3 >= -3.0 * moments_error),
            "triangle_margin": (i1 + i2 - i3) / i3 if i3 > 0 else None}


def _canonical_sign(axis):
    """``±axis`` (a list of 3 floats) with its component of largest magnitude positive, first index on ties."""
    k, largest = 0, abs(axis[0])                          # as max(): the first of ties
    if abs(axis[1]) > largest:
        k, largest = 1, abs(axis[1])
    if abs(axis[2]) > largest:
        k = 2
    return axis if axis[k] > 0 else [-x for x in axis]


def _cross(a, b):
    """``a × b`` of two lists of 3 floats, each element rounded as numpy.cross rounds it."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _length(a):
    return math.sqrt(_dot(a, a))


def _subspace_axes(basis):
    """The frame's axes projected into span(basis), Gram–Schmidt, in x, y, z order (lists of 3 floats)."""
    chosen = []
    for unit in range(3):
        v = [sum(b[unit] * b[i] for b in basis) for i in range(3)]
        for w in chosen:
            projection = _dot(w, v)
            v = [x - projection * y for x, y in zip(v, w)]
        length = _length(v)
        if length > _PROJECTION_FLOOR:
            chosen.append([x / length for x in v])
        if len(chosen) == len(basis):
            break
    return chosen


def _jacobi(a):
    """Eigenvalues (ascending), eigenvectors (columns) and a bound on the backward error of a symmetric 3×3.

    Cyclic Jacobi rotations (at most 32 sweeps; a 3×3 converges quadratically,
    in 3 to 5), compiled (``massprops/core/src/post.c``): only +, −, ×, ÷
    and sqrt, each correctly rounded, so the result is the same on every
    machine (LAPACK's differs in the last bits with the CPU's kernels).  The
    matrix is scaled by a power of two first (exact), so no square underflows
    or overflows.  A matrix with a non-finite element, or zero, gives its
    diagonal, the identity and a bound of 0.

    Returns
    -------
    moments : list of 3 floats
    vectors : list of 3 rows of 3 floats; column k is the unit axis of moments[k]
    backward_error : float
        ‖E‖₂ bound such that the moments are exactly those of ``a + E``: the
        rounding of every rotation (32 u‖J‖_F each: forming c and s and the
        two-sided update) and the off-diagonal entries dropped (below a quarter
        ulp of both diagonal entries, or u² of the norm) or left.
    """
    return _core.jacobi(*a)


def _symmetric(inertia):
    """``(J + Jᵀ) / 2`` as a float array; ``J`` itself when it is symmetric (then that is exactly J)."""
    inertia = np.asarray(inertia, dtype=float)
    (a, b, c), (d, e, f), (g, h, i) = inertia.tolist()
    if b == d and c == g and f == h and max(abs(a), abs(b), abs(c), abs(e), abs(f), abs(i)) < 2.0 ** 1023:
        return inertia              # below 2**1023, x + x does not overflow: the halving gives x exactly
    return 0.5 * (inertia + inertia.T)


@lru_cache(maxsize=8)
def _sine(angle):
    return math.sin(angle)


def principal(inertia, *, error=0.0, rtol=DEFAULT_RTOL, extra_tolerance=0.0,
              angle_tolerance=AXIS_ANGLE_TOLERANCE):
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
    angle_tolerance : float
        Radians: moments closer than the gap at which the Davis–Kahan bound
        on their axes reaches this angle are degenerate too.

    Returns
    -------
    Principal
    """
    inertia = _symmetric(inertia)
    moments, vectors, backward_error = _jacobi(inertia.tolist())
    scale = max(map(abs, moments))
    # Weyl: |Δλ| ≤ ‖ΔJ‖₂ ≤ 3·max|ΔJ_ij|; plus the eigensolver's backward error.
    moments_error = 3.0 * error + backward_error
    # sin θ ≤ E / (gap − E) stays below sin(angle_tolerance) iff gap ≥ E (1 + 1/sin(angle_tolerance)).
    axis_gap = moments_error * (1.0 + 1.0 / _sine(angle_tolerance))
    tolerance = max(rtol * scale, moments_error, extra_tolerance, axis_gap)
    groups = degenerate_groups(moments, tolerance)
    axes = [[vectors[r][k] for r in range(3)] for k in range(3)]
    for group in groups:
        for k, axis in zip(group, _subspace_axes([axes[k] for k in group])):
            axes[k] = axis
    a1 = _canonical_sign(axes[0])
    projection = _dot(a1, axes[1])
    a2 = _canonical_sign([b - projection * a for a, b in zip(a1, axes[1])])
    length = _length(a2)
    a2 = [x / length for x in a2]
    axes = [[x + 0.0 for x in a] for a in (a1, a2, _cross(a1, a2))]       # + 0.0: no negative zeros
    moments = np.array(moments)
    return Principal(moments, np.array(axes), tuple(tuple(g) for g in groups),
                     moments_error, tolerance, axis_angle_bounds(moments, moments_error, groups))
