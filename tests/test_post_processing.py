"""The integer post-processing of ``MassProperties.from_moments`` against the same formulas in Fractions.

The oracle below is the post-processing written with :class:`fractions.Fraction`
(exact, reduced at every step) and ``float(Fraction)`` (correctly rounded):
every value and every error bound must come out bit for bit the same, on
random raw sums of any sign and exponent, every order, unit and material, and
on the edges (zero first moments, asymmetric second moments, subnormals,
overflow and underflow).
"""

import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.model.errors import MeshGeometryError
from massprops.core import Moments
from massprops.model.properties import MassProperties, unit_factor

_U = 2.0 ** -53


def _round_error(values):
    return _U * max(abs(float(v)) for v in values)


def _fraction_center_and_inertia(moments, length, rho, m0, e0, volume_s, rho_rel_error):
    g = [Fraction(x) / (m0 * 4) for x in moments.first]
    gmax = max(abs(float(x)) for x in g)
    eg = (moments.first_error + 4 * gmax * e0) / (4 * (float(m0) - e0)) * 1.01
    factor = unit_factor(length[1])
    com = [float((Fraction(r) + x * Fraction(2) ** moments.scale_exp) * factor) for r, x in zip(moments.reference, g)]
    error_com = eg * float(length[0]) + _round_error(com)
    if moments.order < 2:
        return com, error_com, None, None
    c = [[Fraction(moments.second[i, j]) / 120 - volume_s * g[i] * g[j] for j in range(3)] for i in range(3)]
    ec = (moments.second_error / 120 + (e0 / 6) * gmax ** 2 + float(volume_s) * (2 * gmax * eg + eg ** 2)) * 1.01
    trace = c[0][0] + c[1][1] + c[2][2]
    scale = rho * length[0] ** 5
    inertia = [[float(((trace - c[i][j]) if i == j else -c[i][j]) * scale) for j in range(3)] for i in range(3)]
    flat = [x for row in inertia for x in row]
    error_inertia = (2 * ec * float(scale) + rho_rel_error * max(map(abs, flat)) * 1.01 + _round_error(flat))
    return com, error_com, inertia, error_inertia


def _exact(value):
    return Fraction(float(value)) if isinstance(value, (float, np.floating)) else Fraction(value)


def fraction_post_processing(moments, *, density=None, mass=None, unit=None):
    """Values and bounds of from_moments, in Fractions; what went wrong when it fails."""
    try:
        length = unit_factor(unit) * Fraction(2) ** moments.scale_exp
        m0, e0 = Fraction(moments.det_sum), moments.det_error
        if moments.det_sum <= 0 or moments.det_sum <= e0:
            return "zero volume"
        volume_s = m0 / 6
        volume = volume_s * length ** 3
        rho = _exact(density if density is not None else 1) if mass is None else _exact(mass) / volume
        total = rho * volume
        rel_volume = (e0 / 6) / float(volume_s)
        rho_rel_error = rel_volume if mass is not None else 0.0
        error_volume = rel_volume * float(volume) * 1.01 + _round_error([volume])
        error_mass = (0.0 if mass is not None else rel_volume * float(total) * 1.01) + _round_error([total])
        surface_area = float(Fraction(moments.area2) / 2 * length ** 2)
        com, error_com, inertia, error_inertia = None, None, None, None
        if moments.order >= 1:
            com, error_com, inertia, error_inertia = _fraction_center_and_inertia(
                moments, (length, unit), rho, m0, e0, volume_s, rho_rel_error)
        values = (float(volume), float(total), float(rho), surface_area)
    except OverflowError:
        return "overflow"
    except ZeroDivisionError:
        return "ZeroDivisionError"       # a subnormal volume sum that rounds to 0 after / 6
    # Below the smallest normal double a result keeps fewer bits than its bound claims: refused.
    tiny = 2.0 ** -1022
    if abs(values[0]) < tiny or abs(values[1]) < tiny or (
            inertia is not None and max(abs(x) for row in inertia for x in row) < tiny):
        return "underflow"
    return values, com, inertia, (error_volume, error_mass, error_com, error_inertia)


def integer_post_processing(moments, **material):
    """The same from :meth:`MassProperties.from_moments`."""
    try:
        p = MassProperties.from_moments(moments, **material)
    except MeshGeometryError as exc:
        return next(word for word in ("zero volume", "overflow", "underflow") if word in exc.problem)
    except ZeroDivisionError:
        return "ZeroDivisionError"
    e = p.error
    return ((p.volume, p.mass, p.density, p.surface_area),
            None if p.center_of_mass is None else p.center_of_mass.tolist(),
            None if p.inertia_com is None else p.inertia_com.tolist(),
            (e.volume, e.mass, e.center_of_mass, e.inertia_com))


def _bits(result):
    """Floats as their bit patterns, so that -0.0 ≠ 0.0 and the comparison is exact."""
    if isinstance(result, float):
        return result.hex() if math.isfinite(result) else repr(result)
    if isinstance(result, (list, tuple)):
        return [_bits(x) for x in result]
    return result


def _float(rng, low, high):
    """A random float of either sign with a random exponent in [low, high), sometimes zero or tiny."""
    kind = rng.integers(0, 12)
    if kind == 0:
        return 0.0
    if kind == 1:
        return float(rng.choice([5e-324, -5e-324, 2.2250738585072014e-308]))
    return float(rng.choice([-1, 1]) * math.ldexp(rng.uniform(0.5, 1.0), int(rng.integers(low, high))))


def random_moments(rng, order, *, exponents=(-40, 40), symmetric=True):
    det_sum = abs(_float(rng, *exponents)) or 1.0
    second = np.array([[_float(rng, *exponents) for _ in range(3)] for _ in range(3)])
    if symmetric:
        second = np.triu(second) + np.triu(second, 1).T
    reference = np.array([_float(rng, -30, 30) for _ in range(3)])
    return Moments(reference, int(rng.integers(-80, 80)), order, det_sum, det_sum * float(rng.choice([0.0, 1e-15])),
                   np.array([_float(rng, *exponents) for _ in range(3)]), abs(_float(rng, -60, 0)) * det_sum,
                   second, abs(_float(rng, -60, 0)), abs(_float(rng, *exponents)), 12, 0, 0)


materials = st.sampled_from([{}, {"density": 7850.0}, {"density": 3}, {"density": Fraction(1, 3)}, {"mass": 2.5},
                             {"mass": 1e-300}, {"mass": 1e300}, {"density": 1e-300}, {"density": 1e300},
                             {"mass": np.float64(0.1)}, {"density": np.float32(0.1)}])


@settings(max_examples=400, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([0, 1, 2]), st.sampled_from([None, "m", "mm", "um", "in", "ft"]),
       materials, st.booleans())
def test_integer_path_matches_fractions_bit_for_bit(seed, order, unit, material, symmetric):
    moments = random_moments(np.random.default_rng(seed), order, symmetric=symmetric)
    expected = fraction_post_processing(moments, unit=unit, **material)
    assert _bits(integer_post_processing(moments, unit=unit, **material)) == _bits(expected)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([None, "mm", "in"]), materials,
       st.sampled_from([(-1074, -900), (900, 1024), (-1074, 1024)]))
def test_extreme_exponents_fail_or_match_alike(seed, unit, material, exponents):
    # Sums near the ends of the float range: overflow, underflow and subnormal results must agree too.
    moments = random_moments(np.random.default_rng(seed), 2, exponents=exponents)
    expected = fraction_post_processing(moments, unit=unit, **material)
    assert _bits(integer_post_processing(moments, unit=unit, **material)) == _bits(expected)


@pytest.mark.parametrize("first", [(0.0, 0.0, 0.0), (-0.0, 1.5, -2.0 ** -60)])
def test_centred_sums_match(first):
    rng = np.random.default_rng(7)
    base = random_moments(rng, 2)
    moments = Moments(base.reference * 0.0, base.scale_exp, 2, 3.0, 0.0, np.array(first), 0.0, base.second,
                      base.second_error, base.area2, 12, 0, 0)
    for material in ({}, {"mass": 3.0}):
        expected = fraction_post_processing(moments, unit="mm", **material)
        assert _bits(integer_post_processing(moments, unit="mm", **material)) == _bits(expected)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.sampled_from([None, "in"]), materials)
def test_rational_reference_points_match(seed, unit, material):
    # A stretched part's reference point is exact rationals (massprops.model.stretch.stretched_moments).
    rng = np.random.default_rng(seed)
    base = random_moments(rng, 2)
    reference = tuple(Fraction(int(rng.integers(-10 ** 9, 10 ** 9)), int(rng.integers(1, 10 ** 6))) for _ in range(3))
    moments = Moments(reference, base.scale_exp, 2, base.det_sum, base.det_error, base.first, base.first_error,
                      base.second, base.second_error, base.area2, 12, 0, 0)
    expected = fraction_post_processing(moments, unit=unit, **material)
    assert _bits(integer_post_processing(moments, unit=unit, **material)) == _bits(expected)


def test_zero_volume_is_refused_alike():
    moments = random_moments(np.random.default_rng(3), 2)
    flat = Moments(moments.reference, 0, 2, 1e-20, 1e-19, moments.first, 0.0, moments.second, 0.0, 1.0, 12, 0, 0)
    assert integer_post_processing(flat) == fraction_post_processing(flat) == "zero volume"
