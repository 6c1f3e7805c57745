"""The immutable :class:`MassProperties` value and its frame transforms.

Frames (see :mod:`massprops.frames`): ``center_of_mass`` and ``inertia_com``
are in the part's local frame; the ``*_global`` quantities apply the pose.
``inertia_com`` is ``J_G' = ∫ (sᵀs I₃ − s sᵀ) dm`` about the center of mass;
off-diagonal elements are the tensor's own (``J_xy = −∫ x y dm``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from fractions import Fraction
from functools import cached_property

import numpy as np

from .errors import MeshGeometryError, OptionError
from .frames import Pose, parallel_axis, rotate_inertia, inertia_about_frame
from .principal import DEFAULT_RTOL, principal

__all__ = ["MassProperties", "ErrorBounds", "UNITS", "unit_factor"]

_U = 2.0 ** -53
UNITS = {"m": Fraction(1), "cm": Fraction(1, 100), "mm": Fraction(1, 1000), "um": Fraction(1, 10 ** 6),
         "in": Fraction(254, 10000), "ft": Fraction(3048, 10000)}


def unit_factor(unit):
    """Metres per mesh unit, exactly; 1 when no unit is declared."""
    if unit is None:
        return Fraction(1)
    try:
        return UNITS[unit]
    except KeyError:
        raise OptionError(f"unknown unit {unit!r}", fix=f"pick one of {', '.join(UNITS)}") from None


@dataclass(frozen=True)
class ErrorBounds:
    """Absolute bounds on the largest element error of each quantity, same units as it.

    They cover rounding in massprops's arithmetic against exact arithmetic on
    the coordinates as given.  ``input_resolution`` (per quantity) is separate:
    how much the result can move when each coordinate moves by half a unit in
    the last place it was stored with.
    """

    volume: float
    mass: float
    center_of_mass: float = 0.0
    inertia_com: float = 0.0
    principal_moments: float = 0.0
    principal_axes_rad: tuple = ()
    input_resolution: dict = field(default_factory=dict)

    def as_dict(self):
        out = {"volume": self.volume, "mass": self.mass, "center_of_mass": self.center_of_mass,
               "inertia_com": self.inertia_com, "principal_moments": self.principal_moments}
        if self.principal_axes_rad:
            out["principal_axes_rad"] = list(self.principal_axes_rad)
        if self.input_resolution:
            out["input_resolution"] = dict(self.input_resolution)
        return out


def _round_error(x):
    """Bound on the error of rounding the exact value behind float array ``x`` once."""
    return _U * float(np.max(np.abs(x))) if np.size(x) else 0.0


class _Ratio:
    """An exact rational ``n / d`` (d > 0) without reduction: the post-processing's arithmetic.

    Like :class:`fractions.Fraction` but without a gcd per operation (the
    values are short-lived, so their integers stay small); ``float()`` is
    Python's correctly rounded integer division, as ``float(Fraction)`` is,
    so every result is bit for bit the same.
    """

    __slots__ = ("n", "d")

    def __init__(self, n, d=1):
        self.n, self.d = (n, d) if d > 0 else (-n, -d)

    @classmethod
    def of(cls, value):
        """The exact value of an int, float (numpy scalars too) or Fraction."""
        if isinstance(value, (float, np.floating)):
            return cls(*float(value).as_integer_ratio())
        return cls(*Fraction(value).as_integer_ratio())

    def times_power_of_two(self, k):
        return _Ratio(self.n << k, self.d) if k >= 0 else _Ratio(self.n, self.d << -k)

    def __add__(self, other):
        return _Ratio(self.n * other.d + other.n * self.d, self.d * other.d)

    def __sub__(self, other):
        return _Ratio(self.n * other.d - other.n * self.d, self.d * other.d)

    def __mul__(self, other):
        if isinstance(other, int):
            return _Ratio(self.n * other, self.d)
        return _Ratio(self.n * other.n, self.d * other.d)

    def __truediv__(self, other):
        if isinstance(other, int):
            return _Ratio(self.n, self.d * other)
        return _Ratio(self.n * other.d, self.d * other.n)

    def __pow__(self, k):
        return _Ratio(self.n ** k, self.d ** k)

    def __neg__(self):
        return _Ratio(-self.n, self.d)

    def __float__(self):
        return self.n / self.d


@dataclass(frozen=True, eq=False)
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

    @classmethod
    def from_moments(cls, moments, *, density=None, mass=None, unit=None, pose=None, path=None):
        """Turn raw integrals into mass properties, exactly, then round once.

        The few operations after integration (division by the volume, the shift
        to the center of mass, units) are done in rational arithmetic on the
        float sums, so their only error is the propagated error of the sums.

        Parameters
        ----------
        moments : massprops.integrate.Moments
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
        """The exact post-processing behind :meth:`from_moments`."""
        if density is not None and mass is not None:
            raise OptionError("give --density or --mass, not both")
        for name, value in (("density", density), ("mass", mass)):
            if value is not None and not (math.isfinite(value) and value > 0):
                raise OptionError(f"{name} must be a positive number, got {value!r}")
        length = _Ratio.of(unit_factor(unit)).times_power_of_two(moments.scale_exp)
        m0, e0 = _Ratio.of(moments.det_sum), moments.det_error      # a NaN or infinite sum raises here
        if moments.det_sum <= 0 or moments.det_sum <= e0:
            raise MeshGeometryError("the solid has zero volume (flat or degenerate: the faces enclose nothing)",
                                    path=path, fix="check the export; a surface needs --shell THICKNESS")
        volume_s = m0 / 6
        volume = volume_s * length ** 3
        rho = _Ratio.of(density if density is not None else 1) if mass is None else _Ratio.of(mass) / volume
        total = rho * volume
        rel_volume = (e0 / 6) / float(volume_s)
        rho_rel_error = rel_volume if mass is not None else 0.0
        error_volume = rel_volume * float(volume) * 1.01 + _round_error(float(volume))
        error_mass = (0.0 if mass is not None else rel_volume * float(total) * 1.01) + _round_error(float(total))
        surface_area = float(_Ratio.of(moments.area2) / 2 * length ** 2)
        com = inertia = None
        error_com = error_inertia = 0.0
        if moments.order >= 1:
            g = [_Ratio.of(x) / (m0 * 4) for x in moments.first]
            gmax = max(abs(float(x)) for x in g)            # rounding is monotone: the float of the max
            eg = (moments.first_error + 4 * gmax * e0) / (4 * (float(m0) - e0)) * 1.01
            factor = _Ratio.of(unit_factor(unit))
            com = np.array([float((_Ratio.of(r) + x.times_power_of_two(moments.scale_exp)) * factor)
                            for r, x in zip(moments.reference, g)])
            error_com = eg * float(length) + _round_error(com)
            if moments.order >= 2:
                c = [[_Ratio.of(moments.second[i, j]) / 120 - volume_s * g[i] * g[j] for j in range(3)]
                     for i in range(3)]
                ec = (moments.second_error / 120 + (e0 / 6) * gmax ** 2
                      + float(volume_s) * (2 * gmax * eg + eg ** 2)) * 1.01
                trace = c[0][0] + c[1][1] + c[2][2]
                scale = rho * length ** 5
                inertia = np.array([[float(((trace - c[i][j]) if i == j else -c[i][j]) * scale)
                                     for j in range(3)] for i in range(3)])
                error_inertia = (2 * ec * float(scale) + rho_rel_error * float(np.abs(inertia).max()) * 1.01
                                 + _round_error(inertia))
        values = (float(volume), float(total), float(rho), surface_area)
        if values[0] == 0.0:
            raise MeshGeometryError("the results underflow double precision", path=path,
                                    fix="give the mesh in a smaller length unit (e.g. --unit) or rescale it")
        if not all(math.isfinite(v) for v in values) or (
                inertia is not None and not np.all(np.isfinite(inertia))) or (
                com is not None and not np.all(np.isfinite(com))):
            raise MeshGeometryError("the results overflow double precision", path=path,
                                    fix="give the mesh in a larger length unit")
        bounds = ErrorBounds(volume=error_volume, mass=error_mass, center_of_mass=error_com,
                             inertia_com=error_inertia)
        if pose is not None and unit is not None:
            # A pose's translation is given in mesh units, like the mesh; outputs are SI.
            pose = Pose(pose.rotation, pose.translation * float(unit_factor(unit)))
        return cls(*values, com, inertia, bounds, pose or Pose(), unit)

    @classmethod
    def from_cell_moments(cls, volume_moments, mass_moments, *, mass=None, unit=None, pose=None, path=None):
        """Mass properties of a body whose density varies from cell to cell.

        ``mass_moments`` are the integrals with every term weighted by its
        cell's density (:func:`massprops.integrate.integrate` ``weights=``):
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
    def principal(self):
        """:class:`massprops.principal.Principal` of ``inertia_com`` (local axes)."""
        self._need_inertia()
        # input_resolution["principal_moments"] already bounds the spectral norm (Weyl), no factor 3.
        resolution = self.error.input_resolution.get("principal_moments", 0.0)
        return principal(self.inertia_com, error=self.error.inertia_com, rtol=self.degenerate_rtol,
                         extra_tolerance=resolution)

    @property
    def center_of_mass_global(self):
        """ndarray (3,): ``A c' + t``."""
        return self.pose.apply(self.center_of_mass)

    @property
    def inertia_com_global(self):
        """ndarray (3, 3): ``A J_G' Aᵀ``, about the center of mass, global axes."""
        self._need_inertia()
        return rotate_inertia(self.inertia_com, self.pose.rotation)

    @property
    def inertia_origin(self):
        """ndarray (3, 3): about the global origin, global axes (parallel axis)."""
        return self.about((0.0, 0.0, 0.0))

    def about(self, point):
        """Inertia about a global point, in global axes."""
        offset = self.center_of_mass_global - np.asarray(point, dtype=float)
        return self.inertia_com_global + parallel_axis(self.mass, offset)

    def in_frame(self, frame):
        """Inertia about the origin of ``frame`` (a Pose), in that frame's axes."""
        self._need_inertia()
        return inertia_about_frame(self.inertia_com_global, self.mass, self.center_of_mass_global, frame)

    def with_pose(self, pose):
        """The same part placed at ``pose``."""
        return replace(self, pose=pose)

    def rotated(self, rotation):
        """The properties of the part's geometry rotated by ``rotation`` about the local origin."""
        a = np.asarray(rotation, dtype=float)
        return replace(self, center_of_mass=a @ self.center_of_mass,
                       inertia_com=None if self.inertia_com is None else rotate_inertia(self.inertia_com, a))

    def translated(self, offset):
        """The properties of the part's geometry moved by ``offset`` in its local frame."""
        return replace(self, center_of_mass=self.center_of_mass + np.asarray(offset, dtype=float))

    def angular_momentum(self, omega):
        """``(H', H)``: angular momentum about the COM, local and global axes, for ω' in local axes."""
        self._need_inertia()
        local = self.inertia_com @ np.asarray(omega, dtype=float)
        return local, self.pose.rotation @ local

    def kinetic_energy(self, omega):
        """``½ ω'ᵀ J_G' ω'``: rotational kinetic energy for ω' in local axes."""
        self._need_inertia()
        w = np.asarray(omega, dtype=float)
        return 0.5 * float(w @ self.inertia_com @ w)

    def _need_inertia(self):
        if self.inertia_com is None:
            raise ValueError("the inertia tensor was not computed (only= left it out)")
