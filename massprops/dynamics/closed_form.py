"""The torque-free rigid body in closed form (principal frame, ``I1 ≤ I2 ≤ I3``).

ω follows Jacobi elliptic functions (Landau & Lifshitz §37): nearer the major
axis (``H² > 2 K I2``) ``ω = (A1 cn u, A2 sn u, A3 dn u)``, nearer the minor
axis ``ω = (A1 dn u, A2 sn u, A3 cn u)``, ``u = p t + u0``; an axisymmetric body
precesses at a constant rate, a sphere keeps ω.  All differences such as
``2 K I3 − H²`` are formed from positive terms, so nothing cancels.

The attitude is ``A(t) = A0 R(h0)ᵀ R_z(φ(t)) R(h(t))`` where ``R(h)`` takes the
body direction of ``H`` to world z about a reference axis ``e_k`` and
``φ̇ = |H| (I_i ω_i² + I_j ω_j²)/(I_i² ω_i² + I_j² ω_j²)`` (``i, j ≠ k``) is
periodic; it is integrated by Gauss–Legendre panels over one period, so the
attitude is exact to rounding at any time.

``scipy.special.ellipj`` is wrong for ``m`` within 1e-9 of 1 once ``u > K``
(scipy issue 8480); :func:`jacobi` reduces ``u`` to ``|u| ≤ K/2`` by the
half- and quarter-period identities first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.frames import axis_angle_quat, quat_conjugate, quat_from_matrix, quat_multiply
from .body import RigidBody, trajectory_from_principal

__all__ = ["jacobi", "Polhode", "polhode", "torque_free", "period"]

_GAUSS_NODES = 16
_PANEL_WIDTH = 0.25     # in u; sn, cn, dn are analytic in a strip of half-width K' ≥ π/2


def jacobi(u, m, m1=None):
    """``(sn, cn, dn)(u | m)`` for ``0 ≤ m ≤ 1``, accurate for ``m`` near 1 and any ``u``.

    Parameters
    ----------
    u : array_like
    m : float
        Parameter.
    m1 : float, optional
        ``1 − m`` if known more precisely than ``1 − m`` rounds.
    """
    from scipy.special import ellipj, ellipkm1
    m1 = 1.0 - m if m1 is None else float(m1)
    quarter = float(ellipkm1(m1))
    u = np.asarray(u, dtype=float)
    if math.isinf(quarter):
        sn, cn, dn, _ = ellipj(u, m)
        return sn, cn, dn
    # sn, cn change sign over a half period 2K; dn does not.
    half = np.round(u / (2.0 * quarter))
    r = u - 2.0 * quarter * half
    flip = 1.0 - 2.0 * (np.abs(half) % 2)
    a = np.abs(r)
    far = a > 0.5 * quarter
    s = np.where(far, quarter - a, a)
    sn_s, cn_s, dn_s, _ = ellipj(s, m)
    root = math.sqrt(m1)
    # u = K − s:  sn = cd s,  cn = √m₁ sd s,  dn = √m₁ nd s.
    sn = np.where(far, cn_s / dn_s, sn_s) * np.sign(r)
    cn = np.where(far, root * sn_s / dn_s, cn_s)
    dn = np.where(far, root / dn_s, dn_s)
    return sn * flip, cn * flip, dn


@dataclass(frozen=True)
class Polhode:
    """Parameters of one torque-free motion (principal axes).

    ``kind`` is ``"elliptic"``, ``"axisymmetric"`` or ``"constant"``.  Elliptic:
    ``omega[k] = amplitude[k] * f_k(rate * t + u0)`` with ``f`` = (dn, sn, cn)
    on the axes ``order``; axisymmetric: the pair ``order[1:]`` turns at
    ``rate`` about the odd axis ``order[0]``.
    """

    kind: str
    moments: np.ndarray
    omega0: np.ndarray
    amplitude: np.ndarray
    order: tuple
    rate: float = 0.0
    m: float = 0.0
    m1: float = 1.0
    u0: float = 0.0

    @property
    def quarter(self):
        from scipy.special import ellipkm1
        return float(ellipkm1(self.m1))

    @property
    def square_period(self):
        """Period of ``ω_i²`` (s): ``2K/p``, ``π/|rate|``, or inf when ω is constant."""
        if self.kind == "elliptic" and self.rate > 0 and self.m1 > 0:
            return 2.0 * self.quarter / self.rate
        if self.kind == "axisymmetric" and self.rate != 0:
            return math.pi / abs(self.rate)
        return math.inf

    def omega(self, t):
        """ω (…, 3) at times ``t`` (…), principal axes, rad/s."""
        t = np.asarray(t, dtype=float)
        out = np.empty(t.shape + (3,))
        if self.kind == "constant":
            out[...] = self.omega0
        elif self.kind == "axisymmetric":
            odd, j, k = self.order
            c, s = np.cos(self.rate * t), np.sin(self.rate * t)
            out[..., odd] = self.omega0[odd]
            out[..., j] = c * self.omega0[j] - s * self.omega0[k]
            out[..., k] = s * self.omega0[j] + c * self.omega0[k]
        else:
            sn, cn, dn = jacobi(self.rate * t + self.u0, self.m, self.m1)
            for axis, f in zip(self.order, (dn, sn, cn)):
                out[..., axis] = self.amplitude[axis] * f
        return out


def polhode(moments, omega):
    """The :class:`Polhode` through ``omega`` (3,) for principal ``moments`` (3,) ascending."""
    i1, i2, i3 = (float(v) for v in moments)
    w = np.asarray(omega, dtype=float)
    if i1 == i3 or not np.any(w):
        return Polhode("constant", np.asarray(moments, float), w, np.abs(w), (0, 1, 2))
    if i1 == i2 or i2 == i3:
        odd = 2 if i1 == i2 else 0
        j, k = (odd + 1) % 3, (odd + 2) % 3
        rate = (moments[odd] - moments[j]) / moments[j] * w[odd]
        ring = math.hypot(w[j], w[k])
        return Polhode("axisymmetric", np.asarray(moments, float), w,
                       np.array([ring if a != odd else abs(w[odd]) for a in range(3)]), (odd, j, k), rate)
    if w[0] == 0.0 and w[2] == 0.0:
        return Polhode("constant", np.asarray(moments, float), w, np.abs(w), (0, 1, 2))
    e1, e2, e3 = i1 * w[0] ** 2, i2 * w[1] ** 2, i3 * w[2] ** 2     # 2K = e1 + e2 + e3
    d1 = e1 * (i3 - i1) + e2 * (i3 - i2)                          # 2K I3 − H²
    d3 = e2 * (i2 - i1) + e3 * (i3 - i1)                          # H² − 2K I1
    g = e3 * (i3 - i2) - e1 * (i2 - i1)                           # H² − 2K I2
    a1 = math.sqrt(d1 / (i1 * (i3 - i1)))
    a3 = math.sqrt(d3 / (i3 * (i3 - i1)))
    if g >= 0:                                                    # about the major axis
        order, a2 = (2, 1, 0), math.sqrt(d1 / (i2 * (i3 - i2)))
        rate = math.sqrt((i3 - i2) * d3 / (i1 * i2 * i3))
        m, m1 = (i2 - i1) * d1 / ((i3 - i2) * d3), (i3 - i1) * g / ((i3 - i2) * d3)
    else:                                                         # about the minor axis
        order, a2 = (0, 1, 2), math.sqrt(d3 / (i2 * (i2 - i1)))
        rate = math.sqrt((i2 - i1) * d1 / (i1 * i2 * i3))
        m, m1 = (i3 - i2) * d3 / ((i2 - i1) * d1), (i3 - i1) * -g / ((i2 - i1) * d1)
    amplitude = np.array([a1, a2, a3])
    u0, signs = _phase(w, amplitude, order, min(m, 1.0), max(m1, 0.0))
    if u0 is None:
        return Polhode("constant", np.asarray(moments, float), w, np.abs(w), (0, 1, 2))
    return Polhode("elliptic", np.asarray(moments, float), w, amplitude * signs, order, rate,
                   min(m, 1.0), max(m1, 0.0), u0)


def _phase(w, amplitude, order, m, m1):
    """Signs on the axes and ``u0`` with ``(dn, sn, cn)(u0)`` matching ω(0); None on an equilibrium."""
    from scipy.special import ellipkinc, ellipkm1
    i_dn, i_sn, i_cn = order
    s_dn = 1.0 if w[i_dn] >= 0 else -1.0
    s_cn = 1.0 if w[i_cn] >= 0 else -1.0
    signs = np.ones(3)
    signs[i_dn], signs[i_cn], signs[i_sn] = s_dn, s_cn, s_dn * s_cn
    sn0 = float(np.clip(w[i_sn] * signs[i_sn] / amplitude[i_sn], -1, 1)) if amplitude[i_sn] else 0.0
    cn0 = float(np.clip(abs(w[i_cn]) / amplitude[i_cn], 0, 1)) if amplitude[i_cn] else 1.0
    if m1 == 0.0:
        return (None, signs) if abs(sn0) == 1.0 else (math.atanh(sn0), signs)
    if abs(sn0) <= 0.7:
        return float(ellipkinc(math.asin(sn0), m)), signs
    # Near sn = ±1, F(φ|m) loses m₁; use u0 = ±(K − s) with sn s = cn0/dn0 instead.
    dn0 = abs(w[i_dn]) / amplitude[i_dn]
    s = float(ellipkinc(math.asin(min(1.0, cn0 / dn0)), m))
    return math.copysign(float(ellipkm1(m1)) - s, sn0), signs


def period(moments, omega):
    """Period (s) of ω for the torque-free body: ``4K/p``, ``2π/|rate|``, or inf."""
    found = polhode(moments, omega)
    if found.kind == "elliptic":
        return 2.0 * found.square_period
    return 2.0 * found.square_period if found.kind == "axisymmetric" else math.inf


def torque_free(inertia, omega, times, *, attitude=None):
    """The exact torque-free motion sampled at ``times``, as a :class:`~massprops.dynamics.body.Trajectory`.

    Parameters
    ----------
    inertia : array_like, shape (3, 3)
        ``J'`` about the center of mass, body axes.
    omega : array_like, shape (3,)
        Initial ``ω'``, body axes, rad/s.
    times : array_like, shape (n,)
        Seconds, ≥ 0.
    attitude : array_like, shape (3, 3), optional
        Initial ``A`` (body to world).
    """
    body = RigidBody.from_inertia(inertia)
    times = np.asarray(times, dtype=float)
    motion = polhode(body.moments, body.to_principal(omega))
    omega_p = motion.omega(times)
    rotation = np.eye(3) if attitude is None else np.asarray(attitude, dtype=float)
    quat0 = quat_multiply(quat_from_matrix(rotation), body.axes_quat)
    quat_p = _attitude(motion, omega_p, times, quat0)
    return trajectory_from_principal(body, times, omega_p, quat_p, method="exact", steps=0, elapsed_s=0.0)


def _reference(h, k):
    """Rotations (n, 3, 3) taking body ``h`` (n, 3) to world z, built around body axis ``k``."""
    size = np.linalg.norm(h, axis=-1, keepdims=True)
    hat = h / size
    axis = np.zeros(3)
    axis[k] = 1.0
    c = hat[..., k:k + 1]
    s = np.sqrt(np.sum(np.delete(hat, k, axis=-1) ** 2, axis=-1, keepdims=True))
    rows = [(axis - c * hat) / s, np.cross(hat, axis) / s, hat]
    return np.stack(rows, axis=-2)


def _attitude(motion, omega_p, times, quat0):
    moments = motion.moments
    if not np.any(motion.omega0):
        return np.broadcast_to(quat0, (len(times), 4)).copy()
    k = int(np.argmin(moments * np.abs(motion.amplitude)))
    h = omega_p * moments
    h0 = motion.omega0 * moments
    ref0 = quat_from_matrix(_reference(h0[None], k))[0]
    refs = quat_from_matrix(_reference(h, k))
    spin = axis_angle_quat(np.broadcast_to([0.0, 0.0, 1.0], (len(times), 3)), _phi(motion, k, times))
    fixed = quat_multiply(quat0, quat_conjugate(ref0))
    return quat_multiply(quat_multiply(np.broadcast_to(fixed, spin.shape), spin), refs)


def _phi_rate(motion, k, t):
    moments = motion.moments
    size = float(np.linalg.norm(moments * motion.omega0))
    w = motion.omega(t)
    i, j = [a for a in range(3) if a != k]
    ei, ej = moments[i] * w[..., i] ** 2, moments[j] * w[..., j] ** 2
    return size * (ei + ej) / (moments[i] * ei + moments[j] * ej)


def _phi(motion, k, times):
    """``φ(t) = ∫₀ᵗ φ̇``: whole periods plus Gauss–Legendre panels over the rest."""
    period_ = motion.square_period
    if math.isinf(period_):
        return _phi_rate(motion, k, np.zeros(1))[0] * times
    panels = _GAUSS_NODES if motion.kind != "elliptic" else max(8, math.ceil(
        2.0 * motion.quarter / _PANEL_WIDTH))
    width = period_ / panels
    nodes, weights = np.polynomial.legendre.leggauss(_GAUSS_NODES)

    def integral(start, stop):
        mid, half = 0.5 * (start + stop), 0.5 * (stop - start)
        values = _phi_rate(motion, k, mid[:, None] + half[:, None] * nodes)
        return half * (values @ weights)

    edges = np.arange(panels) * width
    whole = np.concatenate([[0.0], np.cumsum(integral(edges, edges + width))])
    cycles = np.floor(times / period_)
    rest = times - cycles * period_
    # t/P can round up to a whole number, leaving rest a hair below zero.
    panel = np.clip((rest // width).astype(np.int64), 0, panels - 1)
    return cycles * whole[-1] + whole[panel] + integral(panel * width, rest)
