"""A rigid body's state and its motion's bookkeeping: H, K, Euler's right-hand side, trajectories.

Frames (SPEC): ``ω'`` is in the body's local axes (rad/s); the attitude ``A``
maps local to global and is carried as a unit quaternion ``(w, x, y, z)``;
``H' = J' ω'``, ``H = A H'``, ``K = ½ ω'ᵀ J' ω'``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.errors import OptionError
from ..model.frames import quat_conjugate, quat_from_matrix, quat_multiply, quat_to_matrix
from ..model.principal import principal

__all__ = ["RigidBody", "Trajectory", "trajectory_from_principal", "angular_momentum", "kinetic_energy",
           "euler_rhs"]


def angular_momentum(inertia, omega, rotation=None):
    """``(H', H)``: angular momentum about the COM in body and world axes.

    Parameters
    ----------
    inertia : array_like, shape (3, 3)
        ``J'`` about the center of mass, body axes.
    omega : array_like, shape (3,) or (n, 3)
        ``ω'``, body axes, rad/s.
    rotation : array_like, shape (3, 3) or (n, 3, 3), optional
        Attitude ``A`` (body to world); identity by default.
    """
    local = np.asarray(omega, dtype=float) @ np.asarray(inertia, dtype=float).T
    if rotation is None:
        return local, local.copy()
    return local, np.einsum("...ij,...j->...i", np.asarray(rotation, dtype=float), local)


def kinetic_energy(inertia, omega):
    """``½ ω'ᵀ J' ω'`` (float, or shape (n,) for ``omega`` of shape (n, 3))."""
    w = np.asarray(omega, dtype=float)
    return 0.5 * np.einsum("...i,ij,...j->...", w, np.asarray(inertia, dtype=float), w)


def euler_rhs(inertia, omega, torque=(0.0, 0.0, 0.0)):
    """``ω̇' = J'⁻¹ (T' − ω' × J' ω')``: Euler's equations in body axes."""
    j = np.asarray(inertia, dtype=float)
    w = np.asarray(omega, dtype=float)
    return np.linalg.solve(j, np.asarray(torque, dtype=float) - np.cross(w, j @ w))


@dataclass(frozen=True)
class RigidBody:
    """A body's principal moments (3,) ascending and principal axes (3, 3) as rows, body axes.

    Build with :meth:`from_inertia`; ``axes.T`` maps principal to body
    coordinates.
    """

    moments: np.ndarray
    axes: np.ndarray

    @classmethod
    def from_inertia(cls, inertia):
        """From ``J'`` (3, 3); moments in a degenerate group (SPEC tolerance) are averaged."""
        j = np.asarray(inertia, dtype=float)
        if j.shape != (3, 3) or not np.all(np.isfinite(j)):
            raise OptionError(f"an inertia tensor needs 3×3 finite numbers, got shape {j.shape}")
        found = principal(j)
        moments = np.array(found.moments, dtype=float)
        for group in found.degenerate:
            moments[list(group)] = moments[list(group)].mean()
        if not moments[0] > 0:
            raise OptionError(f"the inertia tensor is not positive definite (moments {moments})",
                              fix="check the mesh: a rigid body has positive principal moments")
        return cls(moments, np.array(found.axes, dtype=float))

    @property
    def inertia(self):
        """``J'`` rebuilt from moments and axes (3, 3), body axes."""
        return self.axes.T @ np.diag(self.moments) @ self.axes

    def to_principal(self, vectors):
        """Body-axes vectors (..., 3) in principal axes."""
        return np.asarray(vectors, dtype=float) @ self.axes.T

    def to_body(self, vectors):
        """Principal-axes vectors (..., 3) in body axes."""
        return np.asarray(vectors, dtype=float) @ self.axes

    @property
    def axes_quat(self):
        """Quaternion (4,) of the rotation principal → body (the matrix ``axes.T``)."""
        return quat_from_matrix(self.axes.T)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A sampled motion, SPEC frames.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Seconds from the start.
    omega : ndarray, shape (n, 3)
        ``ω'``, body axes, rad/s.
    quat : ndarray, shape (n, 4)
        Attitude ``A`` (body to world), scalar first.
    momentum : ndarray, shape (n, 3)
        ``H = A J' ω'``, world axes.
    energy : ndarray, shape (n,)
        ``K = ½ ω'ᵀ J' ω'``.
    method : str
    steps : int
        Work done: splitting, the fixed steps; scipy, right-hand-side evaluations.
    elapsed_s : float
    """

    t: np.ndarray
    omega: np.ndarray
    quat: np.ndarray
    momentum: np.ndarray
    energy: np.ndarray
    method: str = "exact"
    steps: int = 0
    elapsed_s: float = 0.0


def trajectory_from_principal(body, t, omega_p, quat_p, *, method, steps, elapsed_s):
    """Turn principal-frame samples (ω_p, quaternion of ``A V``) into a :class:`Trajectory`."""
    omega = body.to_body(omega_p)
    quat = quat_multiply(quat_p, np.broadcast_to(quat_conjugate(body.axes_quat), quat_p.shape))
    h_principal = omega_p * body.moments
    momentum = np.einsum("nij,nj->ni", quat_to_matrix(quat_p), h_principal)
    energy = 0.5 * np.sum(omega_p * h_principal, axis=1)
    return Trajectory(np.asarray(t, dtype=float), omega, quat, momentum, energy, method, steps, elapsed_s)
