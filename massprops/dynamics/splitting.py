"""Geometric splitting integrators for the rigid body (principal frame).

The kinetic energy in body momentum ``m = I ω`` is split as
``K = a |m|²/2 + b₁ m₁²/2 + b₃ m₃²/2`` with ``a = 1/I₂`` and
``b_i = 1/I_i − a`` (so ``b₂ = 0``).  Each piece's flow is exact: the ``b_i``
pieces rotate ``m`` and the body about principal axis ``i``; the Casimir
piece ``a |m|²/2`` leaves ``m`` alone and turns the body about ``H``, which
(torque-free) commutes with everything and is applied once, in closed form.
Strang steps of these flows, composed by Yoshida's weights, give orders 2, 4
and 6; every sub-step is a rotation, so ``|H|`` is kept to rounding and the
quaternion stays unit by construction.  A constant torque adds one more exact
flow (``m += T' τ`` at fixed attitude).

The inner loop is plain Python floats: per sub-step a few multiplications and
two trig calls, cheaper than one numpy call.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.frames import axis_angle_quat, quat_multiply, quat_to_matrix

__all__ = ["integrate_split"]


def integrate_split(moments, omega, quat, torque, world, duration, weights, steps, samples):
    """Integrate with ``steps`` fixed steps of the composition ``weights``.

    Parameters
    ----------
    moments : ndarray, shape (3,)
        Principal moments, ascending.
    omega : ndarray, shape (3,)
        Initial ω, principal axes, rad/s.
    quat : ndarray, shape (4,)
        Initial attitude of the principal frame (principal to world), scalar first.
    torque : ndarray, shape (3,)
        Constant torque, principal axes (``world=False``) or world axes.
    duration : float
    weights : tuple of float
        Strang step fractions (sum 1).
    steps : int
    samples : int
        Output times, evenly spaced (rounded to whole steps).

    Returns
    -------
    t (n,), omega (n, 3) principal axes, quat (n, 4) principal to world.
    """
    h = duration / steps
    b = 1.0 / np.asarray(moments, dtype=float) - 1.0 / moments[1]
    outer, inner = (0, 2) if abs(b[0]) >= abs(b[2]) else (2, 0)
    plan = []
    for g in weights:
        plan += [(outer, 0.5 * g * h * b[outer]), (inner, g * h * b[inner]), (outer, 0.5 * g * h * b[outer])]
    plan = _merge(plan)
    forced = bool(np.any(np.asarray(torque) != 0))
    if forced:
        step = _forced_step(weights, h, b, outer, inner, 1.0 / moments[1], np.asarray(torque, float), world)
    else:
        step = _free_step(plan)
    marks = np.unique(np.round(np.linspace(0, steps, max(2, samples))).astype(np.int64))
    state = tuple(float(v) for v in np.asarray(moments) * omega) + tuple(float(v) for v in quat)
    records = [state]
    for count in np.diff(marks):
        for _ in range(int(count)):
            state = step(state)
        records.append(state)
    records = np.array(records)
    t = marks * h
    m = records[:, :3]
    q = records[:, 3:]
    if not forced:
        q = _casimir_turn(q, m[0], quat, t / moments[1])
    return t, m / np.asarray(moments), q


def _merge(plan):
    """Join neighbouring flows about the same axis (their rotations add exactly)."""
    merged = []
    for axis, k in plan:
        if merged and merged[-1][0] == axis:
            merged[-1] = (axis, merged[-1][1] + k)
        elif k != 0.0:
            merged.append((axis, k))
    return [(axis, k) for axis, k in merged if k != 0.0]


def _casimir_turn(q, m0, quat0, angle_per_momentum):
    """Apply the Casimir flow: turn by ``|m|·t/I₂`` about the fixed world ``H``."""
    size = float(np.linalg.norm(m0))
    if size == 0.0:
        return q
    axis = quat_to_matrix(quat0) @ (m0 / size)
    turn = axis_angle_quat(np.broadcast_to(axis, (len(q), 3)), size * angle_per_momentum)
    return quat_multiply(turn, q)


def _free_step(plan):
    """One torque-free step: the merged axis rotations (axes 0 and 2 only)."""
    def step(state):
        m0, m1, m2, w, x, y, z = state
        for axis, k in plan:
            if axis == 0:
                half = 0.5 * k * m0
                cc, ss = math.cos(half), math.sin(half)
                c, s = cc * cc - ss * ss, 2.0 * cc * ss
                m1, m2 = c * m1 + s * m2, c * m2 - s * m1
                w, x, y, z = w * cc - x * ss, x * cc + w * ss, y * cc + z * ss, z * cc - y * ss
            else:
                half = 0.5 * k * m2
                cc, ss = math.cos(half), math.sin(half)
                c, s = cc * cc - ss * ss, 2.0 * cc * ss
                m0, m1 = c * m0 + s * m1, c * m1 - s * m0
                w, x, y, z = w * cc - z * ss, x * cc + y * ss, y * cc - x * ss, z * cc + w * ss
        return m0, m1, m2, w, x, y, z
    return step


def _forced_step(weights, h, b, outer, inner, casimir, torque, world):
    """One step with a constant torque: T(τ/2) C(τ/2) X(τ/2) Y(τ) X(τ/2) C(τ/2) T(τ/2) per stage."""
    tx, ty, tz = (float(v) for v in torque)

    def kick(state, tau):
        m0, m1, m2, w, x, y, z = state
        if world:                       # the world torque in body axes: Aᵀ T, with A from q
            bx = (1 - 2 * (y * y + z * z)) * tx + 2 * (x * y + w * z) * ty + 2 * (x * z - w * y) * tz
            by = 2 * (x * y - w * z) * tx + (1 - 2 * (x * x + z * z)) * ty + 2 * (y * z + w * x) * tz
            bz = 2 * (x * z + w * y) * tx + 2 * (y * z - w * x) * ty + (1 - 2 * (x * x + y * y)) * tz
        else:
            bx, by, bz = tx, ty, tz
        return m0 + tau * bx, m1 + tau * by, m2 + tau * bz, w, x, y, z

    def turn(state, tau):
        m0, m1, m2, w, x, y, z = state
        size = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        if size == 0.0:
            return state
        half = 0.5 * casimir * size * tau
        cc, ss = math.cos(half), math.sin(half) / size
        a, bb, c = ss * m0, ss * m1, ss * m2
        return (m0, m1, m2, w * cc - x * a - y * bb - z * c, w * a + x * cc + y * c - z * bb,
                w * bb + y * cc + z * a - x * c, w * c + z * cc + x * bb - y * a)

    stages = []
    for g in weights:
        stages.append((g * h, _free_step(_merge([(outer, 0.5 * g * h * b[outer]), (inner, g * h * b[inner]),
                                                 (outer, 0.5 * g * h * b[outer])]))))

    def step(state):
        for tau, rotate in stages:
            state = turn(kick(state, 0.5 * tau), 0.5 * tau)
            state = kick(turn(rotate(state), 0.5 * tau), 0.5 * tau)
        return state
    return step
