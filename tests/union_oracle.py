"""Closed forms for unions of a link's geometries: raw moments ``(V, ∫x, ∫x xᵀ)`` of textbook pieces (cylinder
slabs, spherical caps, boxes) in rationals times π, and the check that a link's computed values hold them.

Shared by tests/test_robot_union.py (primitives with primitives) and tests/test_robot_mixed.py (with meshes)."""

import math
from fractions import Fraction as F

from massprops.robot.links import MassSettings, link_properties
from massprops.robot.model import Link, RobotModel

U = 2.0 ** -53
PI = F(math.pi)            # math.pi is within 1.3e-16 relative of π: the comparisons allow 4u more


def link(*geometries, tolerance=1e-9):
    """The computed properties of one link of ``geometries`` at density 1."""
    one = Link("l", geometries)
    return link_properties(RobotModel("m.urdf", "urdf", "m", (one,)), one,
                           MassSettings(density=1.0, tolerance=tolerance), None)


def shifted(raw, offset):
    """Raw moments of a region moved by ``offset``."""
    v, f, s = raw
    f2 = [f[k] + v * offset[k] for k in range(3)]
    s2 = [[s[a][b] + f[a] * offset[b] + offset[a] * f[b] + v * offset[a] * offset[b] for b in range(3)]
          for a in range(3)]
    return v, f2, s2


def disk_slab(r, lo, hi, x=F(0), y=F(0)):
    """Raw moments of the cylinder of radius ``r`` on ``lo ≤ z ≤ hi`` about the vertical through ``(x, y)``."""
    r2 = F(r) ** 2
    sxx = PI * r2 * r2 * (hi - lo) / 4
    raw = (PI * r2 * (hi - lo), [F(0), F(0), PI * r2 * (hi ** 2 - lo ** 2) / 2],
           [[sxx, 0, 0], [0, sxx, 0], [0, 0, PI * r2 * (hi ** 3 - lo ** 3) / 3]])
    return shifted(raw, (x, y, F(0)))


def cap(r, centre, lo, hi, x=F(0), y=F(0)):
    """Raw moments of the part ``lo ≤ z ≤ hi`` of the ball of radius ``r`` at ``(x, y, centre)``:
    ``R(z)² = r² − (z − c)²``, integrated term by term."""
    r = F(r)
    a, b = lo - centre, hi - centre                      # in the ball's own z

    def integral(n):       # ∫ w^n (r² − w²) dw over [a, b]
        return r * r * (b ** (n + 1) - a ** (n + 1)) / (n + 1) - (b ** (n + 3) - a ** (n + 3)) / (n + 3)

    sxx = PI * (r ** 4 * (b - a) - 2 * r * r * (b ** 3 - a ** 3) / 3 + (b ** 5 - a ** 5) / 5) / 4
    raw = (PI * integral(0), [F(0), F(0), PI * integral(1)], [[sxx, 0, 0], [0, sxx, 0], [0, 0, PI * integral(2)]])
    return shifted(raw, (x, y, F(centre)))


def box(low, high):
    """Raw moments of the box ``low ≤ x ≤ high``."""
    v = F(1)
    for lo, hi in zip(low, high):
        v *= hi - lo
    first = [v * (lo + hi) / 2 for lo, hi in zip(low, high)]
    second = [[v * (low[a] + high[a]) * (low[b] + high[b]) / 4 if a != b else
               v * (low[a] ** 2 + low[a] * high[a] + high[a] ** 2) / 3 for b in range(3)] for a in range(3)]
    return v, first, second


def central(*signed):
    """``(V, centre of mass, inertia about it)`` of a signed sum ``(sign, raw moments), ...`` of pieces."""
    v = sum(s * r[0] for s, r in signed)
    f = [sum(s * r[1][k] for s, r in signed) for k in range(3)]
    m = [[sum(s * r[2][a][b] for s, r in signed) for b in range(3)] for a in range(3)]
    c = [x / v for x in f]
    centred = [[m[a][b] - v * c[a] * c[b] for b in range(3)] for a in range(3)]
    trace = sum(centred[k][k] for k in range(3))
    return v, c, [[(trace if a == b else 0) - centred[a][b] for b in range(3)] for a in range(3)]


def within(props, exact):
    """Every value within its bound of the closed form ``exact`` (:func:`central`); returns the relative bound
    of mass and inertia."""
    volume, c, j = exact
    scale_j = max(abs(float(x)) for row in j for x in row)
    assert abs(F(props.volume) - volume) <= F(props.error.volume) + F(4 * U) * abs(volume)
    for got, want in zip(props.center_of_mass.tolist(), c):
        assert abs(F(got) - want) <= F(props.error.center_of_mass) + F(4 * U) * max(abs(x) for x in c)
    for got_row, want_row in zip(props.inertia_com.tolist(), j):
        for got, want in zip(got_row, want_row):
            assert abs(F(got) - want) <= F(props.error.inertia_com) + F(4 * U) * F(scale_j)
    return max(props.error.mass / props.mass, props.error.inertia_com / scale_j)
