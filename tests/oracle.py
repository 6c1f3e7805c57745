"""The exact oracle and how tests measure errors against it.

The oracle itself is :func:`massprops.exact.exact_properties`: the same
integrals in exact integer/rational arithmetic on the coordinates as given,
sharing no code with :mod:`massprops.integrate`.
"""

from __future__ import annotations

from fractions import Fraction

from massprops.exact import exact_properties  # noqa: F401  (re-exported for tests)


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
