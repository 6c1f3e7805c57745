"""The exact oracle and how tests measure errors against it.

The oracle itself is :func:`massprops.validation.exact.exact_properties`: the same
integrals in exact integer/rational arithmetic on the coordinates as given,
sharing no code with :mod:`massprops.core.integrate`.
"""

from __future__ import annotations

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
