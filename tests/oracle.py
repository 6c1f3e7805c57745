"""The exact oracle and how tests measure errors against it.

The oracle itself is :func:`massprops.validation.exact.exact_properties`: the same
integrals in exact integer/rational arithmetic on the coordinates as given,
sharing no code with :mod:`massprops.core`.
"""

from __future__ import annotations

from fractions import Fraction

from massprops.validation.accuracy import relative_errors
from massprops.validation.exact import exact_properties  # noqa: F401  (re-exported for tests)


def errors_against(props, exact, size):
    """Absolute and relative errors of MassProperties ``props`` against the oracle.

    Relative errors are normwise (see :func:`massprops.validation.accuracy.relative_errors`):
    volume against the volume, the center of mass against the larger of the
    part's ``size`` and its distance from the origin (a float cannot hold it
    closer), the tensor against its largest element.
    """
    values = {"volume": props.volume, "center_of_mass": props.center_of_mass, "inertia_com": props.inertia_com}
    return relative_errors(values, exact, size)


def rational_moments(signed_triangles):
    """Exact volume, center of mass and inertia about it of signed sets of triangles, one at a time.

    ``signed_triangles``: ``(sign, triangles)`` pairs, corners given as floats
    or Fractions (so polytopes whose corners no float holds can be added and
    subtracted: A ∪ B = A + B − A ∩ B).  Slow; small meshes.
    """
    volume, first, second = Fraction(0), [Fraction(0)] * 3, [[Fraction(0)] * 3 for _ in range(3)]
    for sign, triangles in signed_triangles:
        for corners in triangles:
            a, b, c = ([Fraction(x) for x in p] for p in corners)
            det = sign * (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
                          + a[2] * (b[0] * c[1] - b[1] * c[0]))
            s = [a[i] + b[i] + c[i] for i in range(3)]
            volume += det / 6
            first = [first[i] + det * s[i] / 24 for i in range(3)]
            second = [[second[i][j] + det * (s[i] * s[j] + a[i] * a[j] + b[i] * b[j] + c[i] * c[j]) / 120
                       for j in range(3)] for i in range(3)]
    center = [f / volume for f in first]
    central = [[second[i][j] - volume * center[i] * center[j] for j in range(3)] for i in range(3)]
    trace = sum(central[i][i] for i in range(3))
    return volume, center, [[(trace if i == j else 0) - central[i][j] for j in range(3)] for i in range(3)]


def within_bounds(props, exact):
    """Every quantity within its stated error bound of the exact value (the bounds are rigorous)."""
    error = props.error
    assert abs(Fraction(props.volume) - exact["volume"]) <= Fraction(error.volume), "volume"
    for got, want in zip(props.center_of_mass.tolist(), exact["center_of_mass"]):
        assert abs(Fraction(got) - want) <= Fraction(error.center_of_mass), "center of mass"
    for got_row, want_row in zip(props.inertia_com.tolist(), exact["inertia_com"]):
        for got, want in zip(got_row, want_row):
            assert abs(Fraction(got) - want) <= Fraction(error.inertia_com), "inertia"
