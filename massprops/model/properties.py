"""The immutable :class:`MassProperties` value and its frame transforms.

Frames (see :mod:`massprops.model.frames`): ``center_of_mass`` and ``inertia_com``
are in the part's local frame; the ``*_global`` quantities apply the pose.
``inertia_com`` is ``J_G' = ∫ (sᵀs I₃ − s sᵀ) dm`` about the center of mass;
off-diagonal elements are the tensor's own (``J_xy = −∫ x y dm``).
"""

from __future__ import annotations

import math
import sys
from dataclasses import field
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:                       # numpy.typing costs 0.4 ms at start-up
    from numpy.typing import ArrayLike

from .records import record, replace
from ..core.rounding import U as _U
from .errors import MeshGeometryError, OptionError
from .frames import Pose, frozen_array, inertia_about_frame, matvec, parallel_axis, rotate_inertia
from .principal import DEFAULT_RTOL, Principal, principal

__all__ = ["MassProperties", "ErrorBounds", "UNITS", "unit_factor", "unit_ratio", "unit_length"]

# Metres per unit, exactly, as a reduced (numerator, denominator); UNITS gives them as Fractions
# (fractions and decimal are imported when first asked for: not on the props path).
_RATIOS = {"m": (1, 1), "cm": (1, 100), "mm": (1, 1000), "um": (1, 10 ** 6), "in": (127, 5000), "ft": (381, 1250)}
# One shared identity pose: making a Pose costs more than the rest of a small part's result.
_NO_POSE = Pose()


def unit_ratio(unit):
    """Metres per mesh unit as a reduced ``(numerator, denominator)``; ``(1, 1)`` when no unit is declared."""
    if unit is None:
        return 1, 1
    try:
        return _RATIOS[unit]
    except KeyError:
        raise OptionError(f"unknown unit {unit!r}", fix=f"pick one of {', '.join(_RATIOS)}") from None


def unit_length(unit):
    """Metres per mesh unit, the float nearest :func:`unit_ratio` (``float(unit_factor(unit))``)."""
    num, den = unit_ratio(unit)
    return num / den


def unit_factor(unit):
    """Metres per mesh unit, exactly (a :class:`fractions.Fraction`); 1 when no unit is declared."""
    from fractions import Fraction
    return Fraction(*unit_ratio(unit))


def __getattr__(name):
    if name == "UNITS":                 # {unit: metres per unit, a Fraction}
        from fractions import Fraction
        return {unit: Fraction(*ratio) for unit, ratio in _RATIOS.items()}
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


@record
class ErrorBounds:
    """Absolute bounds on the largest element error of each quantity, same units as it.

    They cover rounding in massprops's arithmetic against exact arithmetic on
    the coordinates as given.  ``input_resolution`` (per quantity) is separate:
    how much the result can move when each coordinate moves by half a unit in
    the last place it was stored with.
    """

    volume: float
    mass: float
    center_of_mass: float | None = None
    inertia_com: float | None = None
    input_resolution: dict = field(default_factory=dict)
    principal_source: object = field(default=None, repr=False, compare=False)

    # A quantity that was not computed has no bound (None), never a bound of zero.  The principal
    # bounds belong to the eigen-decomposition, found on demand: ``principal_source`` is a callable
    # returning the :class:`massprops.model.principal.Principal` (set by MassProperties) or None.

    def _principal(self):
        return None if self.principal_source is None else self.principal_source()

    @property
    def principal_moments(self) -> float | None:
        """Bound on each principal moment's error (None when the inertia was not computed)."""
        found = self._principal()
        return None if found is None else found.moments_error

    @property
    def principal_axes_rad(self) -> tuple | None:
        """Bound on each principal axis's angle error, radians (None when the inertia was not computed)."""
        found = self._principal()
        return None if found is None else tuple(found.axes_error)

    def as_dict(self, *, principal=True):
        """The bounds by name; the principal ones too when ``principal`` (found on demand when first asked)."""
        found = self._principal() if principal else None
        out = {"volume": self.volume, "mass": self.mass}
        if self.center_of_mass is not None:
            out["center_of_mass"] = self.center_of_mass
        if self.inertia_com is not None:
            out["inertia_com"] = self.inertia_com
        if found is not None:
            out["principal_moments"] = found.moments_error
            if found.axes_error:
                out["principal_axes_rad"] = list(found.axes_error)
        if self.input_resolution:
            out["input_resolution"] = dict(self.input_resolution)
        return out


def _round_error(values):
    """Bound on the error of rounding the exact values behind the floats ``values`` once each."""
    return _U * max(map(abs, values))


def _quotient(num, den, exp=0):
    """The float nearest ``num · 2**exp / den`` (``den > 0``).

    Python's integer true division is correctly rounded (to nearest, ties to
    even, subnormals included; OverflowError beyond the float range), as
    ``float(Fraction)`` is: every value is that of exact arithmetic, rounded once.
    """
    return (num << exp) / den if exp >= 0 else num / (den << -exp)


def _ratio(value):
    """``(n, d)``, ``d > 0``, with ``value == n / d`` exactly (floats, numpy floats, ints, Fractions)."""
    if isinstance(value, (float, np.floating)):
        return float(value).as_integer_ratio()
    if type(value) is int:
        return value, 1
    from fractions import Fraction
    return Fraction(value).as_integer_ratio()


def _on_common_scale(values):
    """Python ints ``n_k`` and one exponent ``e`` with ``values[k] == n_k · 2**e`` exactly.

    Every finite float is an integer times a power of two; on the smallest
    exponent of the set, sums and products of the values are integer sums and
    products, with no Fraction and no gcd.  A NaN or infinity raises here.
    """
    ratios = [float(v).as_integer_ratio() for v in values]
    bits = max(d.bit_length() for _, d in ratios)          # each d is a power of two
    return [n << (bits - d.bit_length()) for n, d in ratios], 1 - bits


def _check_material(density, mass):
    if density is not None and mass is not None:
        raise OptionError("give {density} or {mass}, not both")
    for name, value in (("density", density), ("mass", mass)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise OptionError(f"{name} must be a positive number, got {value!r}")


def _density_of_mass(mass, volume_n, volume_d, s):
    """``(n, d, e)``: the density ``n · 2**e / d`` that gives the total ``mass`` to the exact volume."""
    mass_n, mass_d = _ratio(mass)
    return mass_n * volume_d, mass_d * volume_n, -3 * s


def _center_and_inertia(moments, length, rho, volume_s, rel_rho):
    """Center of mass, ``J_G'`` (order 2, else None) and their bounds, exactly, then rounded once.

    Parameters
    ----------
    length : (int, int, int)
        ``(n, d, s)``: a scaled unit is ``n · 2**s / d`` output lengths.
    rho : (int, int, int)
        ``(n, d, e)``: the density is ``n · 2**e / d``.
    volume_s : float
        ``det_sum / 6``, correctly rounded.
    rel_rho : float
        Relative error bound of the density (non-zero when derived from a mass).
    """
    unit_n, unit_d, s = length
    e0, det_sum = moments.det_error, float(moments.det_sum)
    sums = [det_sum, *np.ravel(moments.first).tolist()]
    if moments.order >= 2:
        sums += np.ravel(moments.second).tolist()
    ints, exp = _on_common_scale(sums)
    m0, first = ints[0], ints[1:4]
    g = [_quotient(f, 4 * m0) for f in first]                    # g = first / (4 det_sum), scaled units
    gmax = max(abs(x) for x in g)                                # rounding is monotone: the float of the max
    eg = (moments.first_error + 4 * gmax * e0) / (4 * (det_sum - e0)) * 1.01
    com, low = [], min(0, s)
    for r, f in zip(moments.reference, first):
        # r + g · 2**s on the scale 2**low, times the unit; r is a float or, for a stretched part, a Fraction
        r_n, r_d = _ratio(r)
        num = ((r_n * 4 * m0) << -low) + ((f * r_d) << (s - low))
        com.append(_quotient(num * unit_n, r_d * 4 * m0 * unit_d, low))
    error_com = eg * _quotient(unit_n, unit_d, s) + _round_error(com)
    if moments.order < 2:
        return np.array(com), error_com, None, None
    ec = (moments.second_error / 120 + (e0 / 6) * gmax ** 2 + volume_s * (2 * gmax * eg + eg ** 2)) * 1.01
    inertia = _inertia(m0, first, ints[4:], exp, length, rho)
    scale = _quotient(rho[0] * unit_n ** 5, rho[1] * unit_d ** 5, rho[2] + 5 * s)
    error_inertia = 2 * ec * scale + rel_rho * max(map(abs, inertia)) * 1.01 + _round_error(inertia)
    return np.array(com), error_com, np.array(inertia).reshape(3, 3), error_inertia


def _inertia(m0, first, second, exp, length, rho):
    """The nine elements of ``J_G'`` (row-major floats) from the sums on one scale ``2**exp``.

    ``C = second / 120 − (det_sum / 6) g gᵀ`` with ``g = first / (4 det_sum)``
    is ``(4 m0 second − 5 first firstᵀ) · 2**exp / (480 m0)``, and
    ``J = (tr C · I − C) · rho · length⁵``.
    """
    unit_n, unit_d, s = length
    central = [4 * m0 * second[3 * i + j] - 5 * first[i] * first[j] for i in range(3) for j in range(3)]
    trace = central[0] + central[4] + central[8]
    num, den = rho[0] * unit_n ** 5, 480 * m0 * rho[1] * unit_d ** 5
    exp += rho[2] + 5 * s
    inertia = []
    for k, c in enumerate(central):
        i, j = divmod(k, 3)
        if i > j and c == central[3 * j + i]:
            inertia.append(inertia[3 * j + i])                   # symmetric sums: the same rational
        else:
            inertia.append(_quotient(((trace if i == j else 0) - c) * num, den, exp))
    return inertia


@record(eq=False)
class MassProperties:
    """Mass properties of one solid.

    Attributes
    ----------
    volume, mass, density, surface_area : float
        Mesh units (or SI with a declared unit): length³, mass, mass/length³, length².
    center_of_mass : ndarray, shape (3,) or None
        Local frame.  None when not computed (``only=volume``).
    inertia_com : ndarray, shape (3, 3) or None
        ``J_G'``, about the center of mass, local axes.
    error : ErrorBounds
    pose : Pose
        Where the part sits in the global frame.
    """

    volume: float
    mass: float
    density: float
    surface_area: float
    center_of_mass: np.ndarray | None
    inertia_com: np.ndarray | None
    error: ErrorBounds
    pose: Pose = field(default_factory=Pose)
    unit: str | None = None
    degenerate_rtol: float = DEFAULT_RTOL

    def __post_init__(self):
        # Read-only arrays: the cached derived values (principal axes, global tensors) cannot go stale.
        if self.center_of_mass is not None:
            object.__setattr__(self, "center_of_mass", frozen_array(self.center_of_mass, (3,), name="center_of_mass"))
        if self.inertia_com is not None:
            object.__setattr__(self, "inertia_com", frozen_array(self.inertia_com, (3, 3), name="inertia_com"))
        # The principal bounds are this result's, found when first asked for (replace() rebinds them).
        source = None if self.inertia_com is None else (lambda: self.principal)
        object.__setattr__(self, "error", replace(self.error, principal_source=source))

    @classmethod
    def from_moments(cls, moments, *, density=None, mass=None, unit=None, pose=None, path=None):
        """Turn raw integrals into mass properties, exactly, then round once.

        The few operations after integration (division by the volume, the shift
        to the center of mass, units) are done in rational arithmetic on the
        float sums, so their only error is the propagated error of the sums.

        Parameters
        ----------
        moments : massprops.core.Moments
            Of an outward-wound surface (positive volume).
        density : float, optional
            Mass per volume (kg/m³ with a unit); default 1.
        mass : float, optional
            Total mass instead of density.
        unit : {"m", "cm", "mm", "um", "in", "ft"}, optional
            The mesh's length unit; outputs are then SI.
        pose : Pose, optional
            Rotation and translation of the part; the translation is in mesh units.
        """
        try:
            return cls._from_moments(moments, density=density, mass=mass, unit=unit, pose=pose, path=path)
        except OverflowError:
            raise MeshGeometryError("the results overflow double precision", path=path,
                                    fix="give the mesh in a larger length unit") from None

    @classmethod
    def _from_moments(cls, moments, *, density, mass, unit, pose, path):
        """The exact post-processing behind :meth:`from_moments`.

        Rationals are carried as Python integers, ``num · 2**exp / den``: the
        sums' floats on one power-of-two scale, the unit's and the density's
        exact ratios.  Each output is one correctly rounded :func:`_quotient`,
        bit for bit ``float`` of the same formulas in :class:`fractions.Fraction`,
        without Fraction's gcd at every step.
        """
        _check_material(density, mass)
        length = (*unit_ratio(unit), moments.scale_exp)                         # unit_n / unit_d · 2**s
        unit_n, unit_d, s = length
        e0 = moments.det_error
        m_n, m_d = float(moments.det_sum).as_integer_ratio()                    # a NaN or infinite sum raises here
        if moments.det_sum <= 0 or moments.det_sum <= e0:
            raise MeshGeometryError("the solid has zero volume (flat or degenerate: the faces enclose nothing)",
                                    path=path, fix="check the export; a surface needs {shell=THICKNESS}")
        volume_n, volume_d = m_n * unit_n ** 3, 6 * m_d * unit_d ** 3           # volume = det_sum / 6 · length³
        rho = ((*_ratio(density if density is not None else 1), 0) if mass is None
               else _density_of_mass(mass, volume_n, volume_d, s))
        volume_s = _quotient(m_n, 6 * m_d)
        rel_volume = (e0 / 6) / volume_s
        volume = _quotient(volume_n, volume_d, 3 * s)
        total = _quotient(rho[0] * volume_n, rho[1] * volume_d, rho[2] + 3 * s)
        error_volume = rel_volume * volume * 1.01 + _round_error((volume,))
        error_mass = (0.0 if mass is not None else rel_volume * total * 1.01) + _round_error((total,))
        area_n, area_d = float(moments.area2).as_integer_ratio()
        surface_area = _quotient(area_n * unit_n ** 2, 2 * area_d * unit_d ** 2, 2 * s)
        com = inertia = None
        error_com = error_inertia = None
        if moments.order >= 1:
            com, error_com, inertia, error_inertia = _center_and_inertia(
                moments, length, rho, volume_s, rel_volume if mass is not None else 0.0)
        # Every value is a quotient of integers: finite, or an OverflowError (reported by from_moments).
        values = (volume, total, _quotient(*rho), surface_area)
        # Below the smallest normal double a value keeps fewer bits than its bound says (1e-319 has 9): refused.
        small = [name for name, value in (("volume", volume), ("mass", total)) if abs(value) < sys.float_info.min]
        if inertia is not None and max(map(abs, inertia.ravel().tolist())) < sys.float_info.min:   # finite
            small.append("inertia")
        if small:
            said = small[0] if len(small) == 1 else f"{', '.join(small[:-1])} and {small[-1]}"
            raise MeshGeometryError(f"the results underflow double precision: the {said} "
                                    f"{'is' if len(small) == 1 else 'are'} below 2.2e-308, the smallest normal "
                                    "double", path=path,
                                    fix="give the mesh in a smaller length unit (e.g. {unit}) or rescale it")
        # volume, mass, center_of_mass, inertia_com, input_resolution, principal_source: every field by
        # position, the record's quickest construction (once a part in a batch)
        bounds = ErrorBounds(error_volume, error_mass, error_com, error_inertia, {}, None)
        if pose is not None and unit is not None:
            # A pose's translation is given in mesh units, like the mesh; outputs are SI.
            pose = Pose(pose.rotation, pose.translation * unit_length(unit))
        return cls(*values, com, inertia, bounds, pose or _NO_POSE, unit, DEFAULT_RTOL)

    @classmethod
    def from_cell_moments(cls, volume_moments, mass_moments, *, mass=None, unit=None, pose=None, path=None):
        """Mass properties of a body whose density varies from cell to cell.

        ``mass_moments`` are the integrals with every term weighted by its
        cell's density (:func:`massprops.core.integrate` ``weights=``):
        :meth:`from_moments` with density 1 turns them into mass, center of
        mass and inertia by the same exact post-processing.  Volume, surface
        area and their bounds come from the unweighted ``volume_moments`` (of
        the same vertices); ``density`` is then the mean density.

        Parameters
        ----------
        mass : float, optional
            Total mass: the cell densities are scaled to it (they give the
            proportions only).
        """
        weighted = cls.from_moments(mass_moments, density=None if mass is not None else 1.0, mass=mass,
                                    unit=unit, pose=pose, path=path)
        geometry = cls.from_moments(volume_moments, unit=unit, path=path)
        error = replace(weighted.error, volume=geometry.error.volume)
        return replace(weighted, volume=geometry.volume, density=weighted.mass / geometry.volume,
                       surface_area=geometry.surface_area, error=error)

    # -- derived quantities -------------------------------------------------

    @cached_property
    def principal(self) -> Principal:
        """:class:`massprops.model.principal.Principal` of ``inertia_com`` (local axes)."""
        self._need_inertia()
        # input_resolution["principal_moments"] already bounds the spectral norm (Weyl), no factor 3.
        resolution = self.error.input_resolution.get("principal_moments", 0.0)
        return principal(self.inertia_com, error=self.error.inertia_com, rtol=self.degenerate_rtol,
                         extra_tolerance=resolution)

    # Cached (the value is immutable; replace() makes a new one): a report asks for them more than once.
    @cached_property
    def center_of_mass_global(self) -> np.ndarray | None:
        """ndarray (3,): ``A c' + t`` (read-only)."""
        return frozen_array(self.pose.apply(self.center_of_mass))

    @cached_property
    def inertia_com_global(self) -> np.ndarray | None:
        """ndarray (3, 3): ``A J_G' Aᵀ``, about the center of mass, global axes (read-only)."""
        self._need_inertia()
        return frozen_array(rotate_inertia(self.inertia_com, self.pose.rotation))

    @property
    def inertia_origin(self) -> np.ndarray | None:
        """ndarray (3, 3): about the global origin, global axes (parallel axis)."""
        return self.about((0.0, 0.0, 0.0))

    def about(self, point: ArrayLike) -> np.ndarray:
        """Inertia about a global point, in global axes."""
        offset = self.center_of_mass_global - np.asarray(point, dtype=float)
        return self.inertia_com_global + parallel_axis(self.mass, offset)

    def in_frame(self, frame: Pose) -> np.ndarray:
        """Inertia about the origin of ``frame`` (a Pose), in that frame's axes."""
        self._need_inertia()
        return inertia_about_frame(self.inertia_com_global, self.mass, self.center_of_mass_global, frame)

    def with_pose(self, pose: Pose) -> MassProperties:
        """The same part placed at ``pose``."""
        return replace(self, pose=pose)

    def rotated(self, rotation: ArrayLike) -> MassProperties:
        """The properties of the part's geometry rotated by ``rotation`` about the local origin."""
        a = np.asarray(rotation, dtype=float)
        return replace(self, center_of_mass=matvec(a, self.center_of_mass),
                       inertia_com=None if self.inertia_com is None else rotate_inertia(self.inertia_com, a))

    def translated(self, offset: ArrayLike) -> MassProperties:
        """The properties of the part's geometry moved by ``offset`` in its local frame."""
        return replace(self, center_of_mass=self.center_of_mass + np.asarray(offset, dtype=float))

    def angular_momentum(self, omega: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """``(H', H)``: angular momentum about the COM, local and global axes, for ω' in local axes."""
        self._need_inertia()
        local = matvec(self.inertia_com, omega)
        return local, matvec(self.pose.rotation, local)

    def kinetic_energy(self, omega: ArrayLike) -> float:
        """``½ ω'ᵀ J_G' ω'``: rotational kinetic energy for ω' in local axes."""
        self._need_inertia()
        w = np.asarray(omega, dtype=float)
        h = matvec(self.inertia_com, w)
        return 0.5 * float((w[0] * h[0] + w[1] * h[1]) + w[2] * h[2])

    def _need_inertia(self):
        if self.inertia_com is None:
            raise ValueError("the inertia tensor was not computed (only= left it out)")
