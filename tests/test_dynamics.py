"""Rotational dynamics against exact arithmetic, closed forms and invariants."""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import random_rotation
from massprops import dynamics
from massprops.model import frames
from massprops.dynamics.closed_form import jacobi, period, polhode, torque_free
from massprops.model.errors import OptionError

SPLIT = ("split2", "split4", "split6")


def rotated(moments, seed):
    """``(J', V)``: a body whose principal axes are the columns of a random rotation V."""
    v = random_rotation(seed)
    return v @ np.diag(moments) @ v.T, v


def test_momentum_energy_and_euler_equations_exact():
    inertia = [[5, -1, 2], [-1, 7, -3], [2, -3, 9]]
    omega = [3, -2, 5]
    torque = [1, 4, -2]
    jw = [sum(Fraction(inertia[i][k]) * omega[k] for k in range(3)) for i in range(3)]
    h_local, h_world = dynamics.angular_momentum(inertia, omega, np.diag([1.0, -1.0, -1.0]))
    assert h_local.tolist() == [float(x) for x in jw]
    assert h_world.tolist() == [float(jw[0]), -float(jw[1]), -float(jw[2])]
    assert dynamics.kinetic_energy(inertia, omega) == float(sum(Fraction(w) * x for w, x in zip(omega, jw)) / 2)
    # J ω̇ = T − ω × Jω, checked in exact arithmetic on the float result.
    rhs = [Fraction(torque[0]) - (omega[1] * jw[2] - omega[2] * jw[1]),
           Fraction(torque[1]) - (omega[2] * jw[0] - omega[0] * jw[2]),
           Fraction(torque[2]) - (omega[0] * jw[1] - omega[1] * jw[0])]
    wdot = [Fraction(x) for x in dynamics.euler_rhs(inertia, omega, torque)]
    for i in range(3):
        residual = sum(inertia[i][k] * wdot[k] for k in range(3)) - rhs[i]
        assert abs(residual) <= 1e-13 * max(abs(r) for r in rhs)


def _agm_jacobi(u, m1):
    """sn, cn, dn by the arithmetic-geometric mean (Abramowitz & Stegun 16.4), from m₁ exactly."""
    a, b, c = 1.0, math.sqrt(m1), math.sqrt(1.0 - m1)
    levels = [(c, a)]
    while abs(c) > 1e-17:
        a, b, c = (a + b) / 2, math.sqrt(a * b), (a - b) / 2
        levels.append((c, a))
    phi = 2.0 ** (len(levels) - 1) * a * u
    previous = phi
    for c_k, a_k in reversed(levels[1:]):
        previous, phi = phi, (phi + math.asin(c_k / a_k * math.sin(phi))) / 2
    return math.sin(phi), math.cos(phi), math.cos(phi) / math.cos(previous - phi)


@pytest.mark.parametrize("m1", [1e-10, 1e-12, 0.25])
def test_jacobi_reduction_near_m_one(m1):
    from scipy.special import ellipkm1
    quarter = float(ellipkm1(m1))
    u = np.linspace(-4.3 * quarter, 4.3 * quarter, 97)
    sn, cn, dn = jacobi(u, 1.0 - m1, m1)
    reference = np.array([_agm_jacobi(x, m1) for x in u])
    # scipy's own ellipj is good to ~1e-11 below K/2 this close to m = 1.
    assert np.abs(sn - reference[:, 0]).max() < 5e-11
    assert np.abs(cn - reference[:, 1]).max() < 5e-11
    assert np.abs(dn - reference[:, 2]).max() < 5e-11
    assert np.abs(sn ** 2 + cn ** 2 - 1).max() < 5e-11


CASES = [((1.0, 2.0, 3.0), (0.3, 1.0, 0.2)),       # near the separatrix, major-axis side
         ((1.0, 2.0, 3.0), (1.0, 0.3, 0.2)),       # about the minor axis
         ((1.0, 1.5, 10.0), (0.1, 0.2, 1.0)),      # about the major axis
         ((2.0, 2.0, 3.0), (0.3, 1.0, 0.2)),       # oblate, axisymmetric
         ((1.0, 3.0, 3.0), (0.3, 1.0, -0.2)),      # prolate, axisymmetric
         ((2.0, 2.0, 2.0), (0.3, 1.0, 0.2))]       # sphere


@pytest.mark.parametrize("moments, omega", CASES)
def test_closed_form_matches_tight_dop853(moments, omega):
    inertia, v = rotated(moments, 3)
    omega = v @ np.array(omega)
    attitude = random_rotation(5)
    exact = torque_free(inertia, omega, np.linspace(0, 12, 61), attitude=attitude)
    reference = dynamics.simulate(inertia, omega, 12, attitude=attitude, method="DOP853", rtol=1e-13,
                                  samples=61)
    omega_error, attitude_error = dynamics.trajectory_error(exact, reference)
    assert omega_error < 1e-10 and attitude_error < 1e-10


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(0.2, 5.0), min_size=3, max_size=3),
       st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3).filter(lambda w: np.linalg.norm(w) > 0.1),
       st.integers(0, 1000))
def test_splitting_converges_to_closed_form(moments, omega, seed):
    moments = sorted(moments)
    if moments[0] + moments[1] < moments[2]:        # not a rigid body (triangle inequality)
        moments[2] = moments[0] + moments[1]
    inertia, _ = rotated(moments, seed)
    duration = 3.0
    run = dynamics.simulate(inertia, omega, duration, method="split6", steps=3000, samples=31)
    exact = torque_free(inertia, omega, run.t)
    assert max(dynamics.trajectory_error(run, exact)) < 1e-8


@pytest.mark.parametrize("omega", [(1e-3, 1.0, 1e-3),       # H² > 2K I2: about the major axis
                                   (3e-3, 1.0, 1e-3)])      # H² < 2K I2: about the minor axis
def test_intermediate_axis_flip_period(omega):
    moments = (1.0, 2.0, 3.0)
    omega = np.array(omega)
    i1, i2, i3 = (Fraction(m) for m in moments)
    w = [Fraction(x) for x in omega]
    two_k = i1 * w[0] ** 2 + i2 * w[1] ** 2 + i3 * w[2] ** 2
    h2 = (i1 * w[0]) ** 2 + (i2 * w[1]) ** 2 + (i3 * w[2]) ** 2
    if h2 > two_k * i2:
        m1 = float((i3 - i1) * (h2 - two_k * i2) / ((i3 - i2) * (h2 - two_k * i1)))
    else:
        m1 = float((i3 - i1) * (two_k * i2 - h2) / ((i2 - i1) * (two_k * i3 - h2)))
    sigma = math.sqrt(float((i2 - i1) * (i3 - i2) / (i1 * i3)))
    expected = 2.0 / sigma * math.log(16.0 / m1)
    assert period(moments, omega) == pytest.approx(expected, rel=1e-5)
    # The integrator flips: ω₂ changes sign, and each return takes the period.
    # (σ assumes ω₂ = 1: the flip's growth rate is σ ω₂.)
    run = dynamics.simulate(np.diag(moments), omega, 2.6 * expected, method="split6", steps=40000,
                            samples=20001)
    w2 = run.omega[:, 1]
    down = np.nonzero((w2[:-1] > 0) & (w2[1:] <= 0))[0]
    crossings = run.t[down] + w2[down] / (w2[down] - w2[down + 1]) * (run.t[down + 1] - run.t[down])
    assert len(crossings) >= 2
    assert np.diff(crossings) == pytest.approx(np.full(len(crossings) - 1, expected), rel=1e-5)


@pytest.mark.parametrize("method", ["exact", "split4", "DOP853"])
def test_sphere_keeps_omega_and_turns_uniformly(method):
    omega = np.array([0.3, -1.2, 0.5])
    times = np.linspace(0, 10, 11)
    if method == "exact":
        run = torque_free(np.eye(3) * 2.5, omega, times)
    else:
        run = dynamics.simulate(np.eye(3) * 2.5, omega, 10, method=method, rtol=1e-12, samples=11)
    assert np.abs(run.omega - omega).max() < 1e-12
    turn = frames.axis_angle_quat(np.broadcast_to(omega / np.linalg.norm(omega), (11, 3)),
                                    np.linalg.norm(omega) * times)
    assert np.abs(run.quat - turn).max() < 1e-9


@pytest.mark.parametrize("method", ["exact", "split6", "DOP853"])
def test_axisymmetric_steady_precession(method):
    # Oblate I1 = I2 = 1, I3 = 2: in the body ω₃ is fixed and (ω₁, ω₂) turns at
    # λ = (I3 − I1)/I1 ω₃; in space the symmetry axis cones about H at |H|/I1.
    inertia, v = rotated((1.0, 1.0, 2.0), 11)
    omega_p = np.array([0.4, 0.1, 0.7])
    times = np.linspace(0, 15, 31)
    if method == "exact":
        run = torque_free(inertia, v @ omega_p, times)
    else:
        run = dynamics.simulate(inertia, v @ omega_p, 15, method=method, rtol=1e-12, samples=31)
    lam = (2.0 - 1.0) / 1.0 * omega_p[2]
    c, s = np.cos(lam * times), np.sin(lam * times)
    expected = np.column_stack([c * omega_p[0] - s * omega_p[1], s * omega_p[0] + c * omega_p[1],
                                np.full_like(times, omega_p[2])])
    assert np.abs(run.omega @ v - expected).max() < 1e-9
    h = v @ (np.array([1.0, 1.0, 2.0]) * omega_p)
    axis0 = v[:, 2]
    cone = frames.axis_angle_quat(np.broadcast_to(h / np.linalg.norm(h), (31, 3)), np.linalg.norm(h) * times)
    expected_axis = np.einsum("nij,j->ni", frames.quat_to_matrix(cone), axis0)
    axis = np.einsum("nij,j->ni", frames.quat_to_matrix(run.quat), axis0)
    assert np.abs(axis - expected_axis).max() < 1e-9


@pytest.mark.parametrize("method", ["split2", "split6", "RK45", "LSODA"])
def test_torque_about_principal_axis_grows_omega_linearly(method):
    inertia, v = rotated((1.0, 2.0, 3.0), 7)
    torque = 0.6 * v[:, 1]
    omega0 = 0.5 * v[:, 1]
    run = dynamics.simulate(inertia, omega0, 4.0, torque=torque, method=method, rtol=1e-10, samples=9)
    expected = np.outer(0.5 + 0.6 / 2.0 * run.t, v[:, 1])
    assert np.abs(run.omega - expected).max() < 1e-8


@pytest.mark.parametrize("method", SPLIT)
def test_world_torque_adds_momentum_exactly(method):
    inertia, _ = rotated((1.0, 2.0, 3.0), 17)
    torque = np.array([0.2, -0.1, 0.3])
    run = dynamics.simulate(inertia, [0.3, 1.0, -0.4], 10.0, attitude=random_rotation(4), torque=torque,
                            torque_frame="world", method=method, steps=2000, samples=11)
    expected = run.momentum[0] + np.outer(run.t, torque)
    assert np.abs(run.momentum - expected).max() < 1e-12 * np.abs(expected).max()


@pytest.mark.parametrize("method", SPLIT)
def test_splitting_conserves_momentum_over_1000_periods(method):
    moments, omega = (1.0, 2.0, 3.0), np.array([1.0, 0.3, 0.2])
    inertia, v = rotated(moments, 2)
    duration = 1000 * period(moments, omega)
    run = dynamics.simulate(inertia, v @ omega, duration, method=method, steps=20000, samples=201)
    size = np.linalg.norm(run.omega @ inertia, axis=1)
    assert np.abs(size / size[0] - 1).max() <= 1e-12
    assert np.abs(np.linalg.norm(run.momentum - run.momentum[0], axis=1)).max() <= 1e-12 * size[0]
    assert np.abs(np.linalg.norm(run.quat, axis=1) - 1).max() <= 1e-12


def test_polhode_regimes_and_period():
    major = polhode(np.array([1.0, 2.0, 3.0]), np.array([0.1, 0.2, 1.0]))
    minor = polhode(np.array([1.0, 2.0, 3.0]), np.array([1.0, 0.2, 0.1]))
    assert major.order[0] == 2 and minor.order[0] == 0          # the dn (never-zero) axis
    assert math.isinf(period((2.0, 2.0, 2.0), (1.0, 2.0, 3.0)))
    assert period((1.0, 1.0, 3.0), (0.5, 0.0, 2.0)) == pytest.approx(2 * math.pi / (2.0 * 2.0))


@pytest.mark.parametrize("kwargs, fragment", [
    ({"method": "Euler"}, "unknown method"),
    ({"method": "RK45", "steps": 10}, "steps applies"),
    ({"torque_frame": "inertial", "torque": (1, 0, 0)}, "unknown torque frame"),
])
def test_simulate_refuses_bad_options(kwargs, fragment):
    with pytest.raises(OptionError, match=fragment):
        dynamics.simulate(np.eye(3), [1, 0, 0], 1.0, **kwargs)


def test_simulate_refuses_bad_duration_and_inertia():
    with pytest.raises(OptionError, match="duration"):
        dynamics.simulate(np.eye(3), [1, 0, 0], -1.0)
    with pytest.raises(OptionError, match="positive definite"):
        dynamics.simulate(np.diag([-1.0, 1.0, 1.0]), [1, 0, 0], 1.0)


@pytest.mark.parametrize("method, order", [("split2", 2), ("split4", 4), ("split6", 6)])
def test_splitting_order(method, order):
    inertia, _ = rotated((1.0, 2.0, 3.0), 9)
    omega = [0.8, -0.5, 0.4]
    exact = torque_free(inertia, omega, np.linspace(0.0, 8.0, 5))
    errors = []
    for steps in (40, 80):
        run = dynamics.simulate(inertia, omega, 8.0, method=method, steps=steps, samples=5)
        errors.append(dynamics.trajectory_error(run, exact)[0])
    assert math.log2(errors[0] / errors[1]) == pytest.approx(order, abs=0.4)


def test_needle_closed_form_matches_splitting():
    # Nearly axisymmetric and spinning fast about the minor axis: m is tiny.
    moments, omega = (1e-3, 1.0, 1.0005), (200.0, 1.0, 0.3)
    inertia, v = rotated(moments, 21)
    duration = 50 * period(moments, omega)
    run = dynamics.simulate(inertia, v @ omega, duration, method="split6", steps=2000, samples=101)
    exact = torque_free(inertia, v @ omega, run.t)
    omega_error, attitude_error = dynamics.trajectory_error(run, exact)
    assert omega_error < 1e-11 and attitude_error < 1e-9
