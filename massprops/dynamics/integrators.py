"""Rotational dynamics of a rigid body: H, K, Euler's equations, integrators.

Frames (SPEC): ``ω'`` is in the body's local axes (rad/s); the attitude ``A``
maps local to global (``x = A x' + t``) and is carried as a unit quaternion
``(w, x, y, z)``; ``H' = J' ω'``, ``H = A H'``, ``K = ½ ω'ᵀ J' ω'`` and
Euler's equations read ``J' ω̇' = T' − ω' × (J' ω')`` with ``Ȧ = A ω̃'``.
A constant torque is given in body axes (``T'``) or world axes (``T``).

Internally everything runs in the principal frame (moments ``I1 ≤ I2 ≤ I3``;
moments equal within the SPEC's degeneracy tolerance are made equal, so an
axisymmetric mesh is treated as axisymmetric); results come back in the SPEC
frames.  The torque-free closed form is in :mod:`massprops.dynamics.closed_form`, the splitting
integrators in :mod:`massprops.dynamics.splitting`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..model.errors import OptionError
from ..model.frames import quat_conjugate, quat_from_matrix, quat_multiply, quat_to_matrix
from .body import RigidBody, trajectory_from_principal

__all__ = ["simulate", "trajectory_error", "work_precision",
           "METHODS", "SPLITTING", "DEFAULT_METHOD"]

SPLITTING = {"split2": 2, "split4": 4, "split6": 6}
SCIPY_METHODS = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
METHODS = tuple(SPLITTING) + SCIPY_METHODS
DEFAULT_METHOD = "split6"
_MAX_STEPS = 10 ** 8
# Composition weights of Strang steps: Yoshida's triple jump (order 4) and his
# 7-stage solution A (order 6), Phys. Lett. A 150 (1990) 262.
_CBRT2 = 2.0 ** (1.0 / 3.0)
_W4 = (1 / (2 - _CBRT2), -_CBRT2 / (2 - _CBRT2), 1 / (2 - _CBRT2))
_Y6 = (0.784513610477560, 0.235573213359357, -1.17767998417887)
_W6 = _Y6 + (1 - 2 * sum(_Y6),) + _Y6[::-1]
_WEIGHTS = {2: (1.0,), 4: _W4, 6: _W6}


def simulate(inertia, omega, duration, *, attitude=None, torque=None, torque_frame="body",
             method=DEFAULT_METHOD, rtol=1e-9, steps=None, samples=1001):
    """Integrate Euler's equations and the attitude from ``t = 0`` to ``duration``.

    Parameters
    ----------
    inertia : array_like, shape (3, 3)
        ``J'`` about the center of mass, body axes.
    omega : array_like, shape (3,)
        Initial ``ω'``, body axes, rad/s.
    duration : float
        Seconds, > 0.
    attitude : array_like, shape (3, 3), optional
        Initial ``A`` (body to world); identity by default.
    torque : array_like, shape (3,), optional
        Constant torque, in the axes ``torque_frame`` names (``"body"`` or ``"world"``).
    method : str
        One of :data:`METHODS`; ``split2/4/6`` are the geometric splitting
        integrators, the others scipy's ``solve_ivp``.
    rtol : float
        scipy: the relative tolerance; splitting: the target relative error,
        turned into a step count by an a-priori estimate (``steps`` overrides).
    steps : int, optional
        Splitting methods only: the number of fixed steps (rounded up to a
        multiple of ``samples − 1`` so that every sample falls on a step).
    samples : int
        Number of output times, evenly spaced, both ends included.

    Returns
    -------
    Trajectory
    """
    body = RigidBody.from_inertia(inertia)
    omega_p, quat_p, torque_p, world = _initial_state(body, omega, attitude, torque, torque_frame)
    if not (math.isfinite(duration) and duration > 0):
        raise OptionError(f"the duration must be a positive number of seconds, got {duration!r}")
    if method not in METHODS:
        raise OptionError(f"unknown method {method!r}", fix=f"pick one of {', '.join(METHODS)}")
    if steps is not None and method not in SPLITTING:
        raise OptionError(f"{{steps}} applies to the splitting methods, not {method}", fix="give {rtol} instead")
    if not (rtol > 0):
        raise OptionError(f"rtol must be positive, got {rtol!r}")
    samples = max(2, int(samples))
    start = time.perf_counter()
    if method in SPLITTING:
        from .splitting import integrate_split
        order = SPLITTING[method]
        if steps is None:
            steps = _steps_for(body, omega_p, torque_p, duration, order, rtol)
        if steps < 1:
            raise OptionError(f"steps must be at least 1, got {steps}")
        steps = -(-int(steps) // (samples - 1)) * (samples - 1)     # samples fall on whole steps
        t, w, q = integrate_split(body.moments, omega_p, quat_p, torque_p, world, duration,
                                  _WEIGHTS[order], int(steps), samples)
    else:
        t, w, q, steps = _integrate_scipy(body.moments, omega_p, quat_p, torque_p, world, duration,
                                          method, rtol, samples)
    return trajectory_from_principal(body, t, w, q, method=method, steps=int(steps),
                                     elapsed_s=time.perf_counter() - start)


def _initial_state(body, omega, attitude, torque, torque_frame):
    omega = np.asarray(omega, dtype=float)
    if omega.shape != (3,) or not np.all(np.isfinite(omega)):
        raise OptionError(f"omega needs 3 finite numbers, got {omega.tolist()}")
    rotation = np.eye(3) if attitude is None else np.asarray(attitude, dtype=float)
    quat_p = quat_multiply(quat_from_matrix(rotation), body.axes_quat)
    if torque_frame not in ("body", "world"):
        raise OptionError(f"unknown torque frame {torque_frame!r}", fix="pick body or world")
    torque = np.zeros(3) if torque is None else np.asarray(torque, dtype=float)
    if torque.shape != (3,) or not np.all(np.isfinite(torque)):
        raise OptionError(f"a torque needs 3 finite numbers, got {torque.tolist()}")
    world = torque_frame == "world"
    return body.to_principal(omega), quat_p, torque if world else body.to_principal(torque), world


def _steps_for(body, omega_p, torque_p, duration, order, rtol):
    """A-priori step count for a target relative error ``rtol`` in ω.

    The splitting error over a run is about ``c (ω_slow T) (h ω_fast)^p``, where
    ``ω_fast, ω_slow`` are the larger and smaller rotation rates of the two
    axis flows over the motion; ``c`` was measured on asymmetric, near-
    separatrix and needle-like bodies and rounded up.
    """
    from .closed_form import polhode
    scale = np.abs(body.moments * (1.0 / body.moments - 1.0 / body.moments[1]))[[0, 2]]
    if np.any(torque_p):
        # The torque speeds the body up: take the mean |ω| over the run, and the
        # slow rate a tenth of the fast one (measured: still conservative).
        mean = float(np.linalg.norm(omega_p)) + 0.5 * float(np.linalg.norm(torque_p)) * duration / body.moments[0]
        # (a body with three equal moments has no flow rate of its own: its speed sets the step)
        rates = np.array([0.1, 1.0]) * (float(scale.max()) or 1.0) * mean
    else:
        rates = scale * np.abs(polhode(body.moments, omega_p).amplitude)[[0, 2]]
        if np.count_nonzero(rates) < 2:
            return 1                      # a single flow is the exact solution
    fast, slow = float(rates.max()), float(rates.min())
    c = {2: 0.3, 4: 0.5, 6: 0.2}[order]
    h = (rtol / (c * slow * duration)) ** (1.0 / order) / fast
    steps = math.ceil(duration / h)
    if steps > _MAX_STEPS:
        raise OptionError(f"reaching rtol={rtol:g} would take about {steps:.2g} steps",
                          fix="loosen {rtol}, shorten {duration}, or give {steps}")
    return max(1, steps)


def _integrate_scipy(moments, omega_p, quat_p, torque_p, world, duration, method, rtol, samples):
    from scipy.integrate import solve_ivp

    def rhs(_, y):
        w, q = y[:3], y[3:]
        torque = quat_to_matrix(q).T @ torque_p if world else torque_p
        h = moments * w
        dw = (torque - np.cross(w, h)) / moments
        dq = 0.5 * quat_multiply(q, np.concatenate([[0.0], w]))
        return np.concatenate([dw, dq])

    scale = max(float(np.linalg.norm(omega_p)), 1e-300)
    atol = rtol * np.concatenate([np.full(3, scale), np.ones(4)])
    t_eval = np.linspace(0.0, duration, samples)
    solution = solve_ivp(rhs, (0.0, duration), np.concatenate([omega_p, quat_p]), method=method,
                         t_eval=t_eval, rtol=rtol, atol=atol)
    if not solution.success:
        raise OptionError(f"{method} failed: {solution.message}", fix="try a looser {rtol} or another method")
    return solution.t, solution.y[:3].T, solution.y[3:].T, solution.nfev


def trajectory_error(trajectory, reference):
    """``(ω error, attitude error)`` of ``trajectory`` against ``reference`` (same times).

    The ω error is ``max_t |ω' − ω'_ref| / max_t |ω'_ref|`` (relative); the
    attitude error is the largest rotation angle between the two attitudes (rad).
    """
    scale = float(np.linalg.norm(reference.omega, axis=1).max()) or 1.0
    omega_error = float(np.linalg.norm(trajectory.omega - reference.omega, axis=1).max()) / scale
    relative = quat_multiply(quat_conjugate(trajectory.quat), reference.quat)
    angles = 2.0 * np.arctan2(np.linalg.norm(relative[:, 1:], axis=1), np.abs(relative[:, 0]))
    return omega_error, float(angles.max())


@dataclass(frozen=True)
class WorkPrecision:
    """One run of a work–precision comparison: errors against the closed form and the time taken."""

    method: str
    rtol: float
    steps: int
    elapsed_s: float
    omega_error: float
    attitude_error: float


def work_precision(inertia, omega, duration, *, attitude=None, methods=METHODS,
                   tolerances=(1e-4, 1e-6, 1e-8, 1e-10), samples=201):
    """Each method at each tolerance, torque-free, against :func:`~massprops.dynamics.closed_form.torque_free`.

    Splitting methods turn ``rtol`` into a step count (see :func:`simulate`).

    Returns
    -------
    list of WorkPrecision
    """
    from .closed_form import torque_free
    rows, references = [], {}
    for method in methods:
        # Warm up: the first call of a method pays for imports, not for integration.
        simulate(inertia, omega, duration * 1e-3, method=method, rtol=1e-3, samples=2)
        for rtol in tolerances:
            run = simulate(inertia, omega, duration, attitude=attitude, method=method, rtol=rtol,
                           samples=samples)
            key = run.t.tobytes()
            if key not in references:
                references[key] = torque_free(inertia, omega, run.t, attitude=attitude)
            errors = trajectory_error(run, references[key])
            rows.append(WorkPrecision(method, rtol, run.steps, run.elapsed_s, *errors))
    return rows
