"""The exact oracle: the same integrals in rational arithmetic, on the coordinates as given.

Every float is m·2**e, so after multiplying all coordinates by one power of two
they are Python integers; the sums are then exact integers and the final
divisions exact Fractions.  Use it on small meshes (up to a few thousand faces).
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np


def _to_integers(values):
    """Integers n and a common exponent e with values == n * 2**e exactly."""
    flat = [float(v) for v in np.asarray(values, dtype=np.float64).ravel()]
    exponents = [math.frexp(v)[1] - 53 for v in flat if v != 0.0]
    e = min(exponents) if exponents else 0
    ints = [int(Fraction(v) / Fraction(2) ** e) for v in flat]
    return np.array(ints, dtype=object).reshape(np.shape(values)), e


def exact_properties(triangles):
    """Exact volume, center of mass and inertia about the COM of a closed surface (density 1).

    Parameters
    ----------
    triangles : array_like, shape (m, 3, 3)
        Float coordinates, outward winding.

    Returns
    -------
    dict with Fraction values: volume, center_of_mass (3,), inertia_com (3, 3)
    """
    ints, e = _to_integers(triangles)
    det_sum = 0
    first = [0, 0, 0]
    second = [[0] * 3 for _ in range(3)]
    for a, b, c in ints:
        det = (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
               + a[2] * (b[0] * c[1] - b[1] * c[0]))
        s = [a[i] + b[i] + c[i] for i in range(3)]
        det_sum += det
        for i in range(3):
            first[i] += det * s[i]
            for j in range(i, 3):
                second[i][j] += det * (s[i] * s[j] + a[i] * a[j] + b[i] * b[j] + c[i] * c[j])
    unit = Fraction(2) ** e
    volume_i = Fraction(det_sum, 6)
    g = [Fraction(first[i], 4 * det_sum) for i in range(3)]
    c = [[Fraction(second[min(i, j)][max(i, j)], 120) - volume_i * g[i] * g[j] for j in range(3)] for i in range(3)]
    trace = c[0][0] + c[1][1] + c[2][2]
    inertia = [[((trace if i == j else 0) - c[i][j]) * unit ** 5 for j in range(3)] for i in range(3)]
    return {"volume": volume_i * unit ** 3, "center_of_mass": [x * unit for x in g], "inertia_com": inertia}


def errors_against(props, exact, size):
    """Absolute and relative errors of MassProperties ``props`` against the oracle.

    Relative errors are normwise: volume against the volume, the center of mass
    against the larger of the part's ``size`` and its distance from the origin
    (a float cannot hold it closer), the tensor against its largest element.
    """
    vol = abs(Fraction(props.volume) - exact["volume"])
    com = max(abs(Fraction(float(x)) - y) for x, y in zip(props.center_of_mass, exact["center_of_mass"]))
    jmax = max(abs(x) for row in exact["inertia_com"] for x in row)
    com_scale = max(Fraction(size), max(abs(y) for y in exact["center_of_mass"]))
    ine = max(abs(Fraction(float(props.inertia_com[i, j])) - exact["inertia_com"][i][j])
              for i in range(3) for j in range(3))
    return {"volume": float(vol), "center_of_mass": float(com), "inertia_com": float(ine),
            "rel_volume": float(vol / abs(exact["volume"])), "rel_center_of_mass": float(com / com_scale),
            "rel_inertia_com": float(ine / jmax)}
