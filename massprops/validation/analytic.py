"""Closed-form mass properties of the reference solids (density 1).

Two kinds of values live here:

* **smooth**: the ideal solid (sphere, cylinder, torus, ...), from the
  textbook formulas;
* **polyhedral**: the ideal tessellation that :mod:`massprops.validation.solids` builds,
  before its coordinates are rounded to floats.  A solid of revolution with
  ``n`` sections has regular n-gon cross-sections; a regular n-gon of
  circumradius ρ has area ``k_n π ρ²`` and polar moment
  ``k_n (2 + cos(2π/n))/3 · π ρ⁴/2``, with ``k_n = n sin(2π/n) / (2π)``.  So
  its volume and axial moments are the smooth solid of revolution's of the
  same polygonal profile, times those factors (:func:`revolved_values`).

Every function returns an :class:`Analytic` in the solid's own frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.frames import parallel_axis, rotate_inertia

__all__ = ["Analytic", "box_values", "sphere_values", "hollow_sphere_values", "cylinder_values", "cone_values",
           "torus_values", "ellipsoid_values", "regular_tetrahedron_values", "octahedron_values",
           "icosahedron_values", "l_bracket_values", "revolved_values", "section_factors"]


@dataclass(frozen=True)
class Analytic:
    """Volume (length³), center of mass (3,) and inertia about it (3, 3), density 1, the solid's frame."""

    volume: float
    center_of_mass: np.ndarray
    inertia_com: np.ndarray

    @classmethod
    def axisymmetric(cls, volume, z_center, axial, transverse):
        """A solid symmetric about the z axis: ``J = diag(transverse, transverse, axial)``."""
        return cls(float(volume), np.array([0.0, 0.0, float(z_center)]), np.diag([transverse, transverse, axial]))

    @classmethod
    def union(cls, *parts):
        """Disjoint parts as one solid (a part of negative volume is a cavity)."""
        volume = sum(p.volume for p in parts)
        center = sum(p.volume * p.center_of_mass for p in parts) / volume
        inertia = sum(p.inertia_com + parallel_axis(p.volume, p.center_of_mass - center) for p in parts)
        return cls(volume, center, inertia)

    def posed(self, pose):
        """The values of the solid moved to ``x = A x' + t`` (a :class:`massprops.model.frames.Pose`)."""
        return Analytic(self.volume, pose.apply(self.center_of_mass), rotate_inertia(self.inertia_com, pose.rotation))

    def scaled(self, factors):
        """The values of the solid's image under ``diag(factors)`` (an affine map, not a similarity)."""
        d = np.asarray(factors, dtype=float)
        jacobian = float(np.prod(d))
        second = 0.5 * np.trace(self.inertia_com) * np.eye(3) - self.inertia_com      # ∫ s sᵀ dV
        second = second * np.outer(d, d) * jacobian
        return Analytic(self.volume * jacobian, self.center_of_mass * d, np.trace(second) * np.eye(3) - second)


def box_values(size=(1.0, 1.0, 1.0), center=(0.0, 0.0, 0.0)):
    """A box of sides (a, b, c): ``V = abc``, ``J = V/12 diag(b²+c², a²+c², a²+b²)``."""
    a, b, c = (float(x) for x in size)
    volume = a * b * c
    return Analytic(volume, np.asarray(center, dtype=float),
                    volume / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b]))


def sphere_values(radius=1.0):
    """``V = 4/3 π r³``, ``J = 2/5 V r² I``."""
    volume = 4 / 3 * math.pi * radius ** 3
    return Analytic(volume, np.zeros(3), 0.4 * volume * radius ** 2 * np.eye(3))


def hollow_sphere_values(outer=1.0, inner=0.5):
    """A thick shell: ``V = 4/3 π (R³ − r³)``, ``J = 8π/15 (R⁵ − r⁵) I``."""
    return Analytic(4 / 3 * math.pi * (outer ** 3 - inner ** 3), np.zeros(3),
                    8 * math.pi / 15 * (outer ** 5 - inner ** 5) * np.eye(3))


def cylinder_values(radius=1.0, height=1.0, z0=None):
    """About z, from ``z0`` (default centred): ``J_zz = V r²/2``, ``J_xx = V (3r² + h²)/12``."""
    volume = math.pi * radius ** 2 * height
    z_center = 0.0 if z0 is None else z0 + height / 2
    return Analytic.axisymmetric(volume, z_center, volume * radius ** 2 / 2,
                                 volume * (3 * radius ** 2 + height ** 2) / 12)


def cone_values(radius=1.0, height=1.0):
    """Base on z = 0, apex at z = h: COM at h/4, ``J_zz = 3/10 V r²``, ``J_xx = V (3r²/20 + 3h²/80)``."""
    volume = math.pi * radius ** 2 * height / 3
    return Analytic.axisymmetric(volume, height / 4, 0.3 * volume * radius ** 2,
                                 volume * (3 * radius ** 2 / 20 + 3 * height ** 2 / 80))


def torus_values(major=2.0, minor=0.5):
    """About z: ``V = 2π² R r²``, ``J_zz = V (R² + 3r²/4)``, ``J_xx = V (R²/2 + 5r²/8)``."""
    volume = 2 * math.pi ** 2 * major * minor ** 2
    return Analytic.axisymmetric(volume, 0.0, volume * (major ** 2 + 0.75 * minor ** 2),
                                 volume * (major ** 2 / 2 + 5 * minor ** 2 / 8))


def ellipsoid_values(semi_axes=(3.0, 2.0, 1.0)):
    """``V = 4/3 π abc``, ``J = V/5 diag(b²+c², a²+c², a²+b²)``."""
    return sphere_values(1.0).scaled(semi_axes)


def regular_tetrahedron_values(half_edge=1.0):
    """Edge ``a = 2√2 h``: ``V = a³/(6√2) = 8h³/3``, ``J = V a²/20 I``."""
    volume = 8 / 3 * half_edge ** 3
    return Analytic(volume, np.zeros(3), volume * 8 * half_edge ** 2 / 20 * np.eye(3))


def octahedron_values(radius=1.0):
    """Vertices ±r on the axes: ``V = 4r³/3``, ``J = V r²/5 I``."""
    volume = 4 / 3 * radius ** 3
    return Analytic(volume, np.zeros(3), volume * radius ** 2 / 5 * np.eye(3))


def icosahedron_values(half_edge=1.0):
    """Edge ``a = 2h``: ``V = 5(3 + √5)/12 a³``, ``J = V φ² a²/10 I``."""
    a = 2 * half_edge
    phi = (1 + math.sqrt(5)) / 2
    volume = 5 * (3 + math.sqrt(5)) / 12 * a ** 3
    return Analytic(volume, np.zeros(3), volume * phi ** 2 * a ** 2 / 10 * np.eye(3))


def l_bracket_values(long=3.0, short=1.0, height=1.0):
    """The L of :func:`massprops.validation.solids.l_bracket` as two boxes."""
    leg_x = box_values((long, short, height), (long / 2, short / 2, height / 2))
    leg_y = box_values((short, long - short, height), (short / 2, (long + short) / 2, height / 2))
    return Analytic.union(leg_x, leg_y)


def section_factors(n):
    """``(k_n, k_n (2 + cos(2π/n))/3)``: what n sections do to areas and to polar moments."""
    theta = 2 * math.pi / n
    k = n * math.sin(theta) / (2 * math.pi)
    return k, k * (2 + math.cos(theta)) / 3


# 3-point Gauss–Legendre on [0, 1]: exact for polynomials up to degree 5.
_NODES = np.array([0.5 - 0.5 * math.sqrt(0.6), 0.5, 0.5 + 0.5 * math.sqrt(0.6)])
_WEIGHTS = np.array([5 / 18, 8 / 18, 5 / 18])


def _profile_integral(profile, closed, a, b):
    """∬ ρ^a z^b dρ dz over the region the profile bounds (Green: ∮ ρ^(a+1)/(a+1) z^b dz)."""
    start = np.asarray(profile, dtype=float)
    end = np.roll(start, -1, axis=0)
    if not closed:
        start, end = start[:-1], end[:-1]     # the closing segment on the axis adds nothing (ρ = 0)
    rho = start[:, :1] + _NODES * (end[:, :1] - start[:, :1])
    z = start[:, 1:] + _NODES * (end[:, 1:] - start[:, 1:])
    return float(np.sum((rho ** (a + 1) * z ** b) @ _WEIGHTS * (end[:, 1] - start[:, 1])) / (a + 1))


def revolved_values(profile, n=None, *, closed=False):
    """Values of :func:`massprops.validation.solids.revolve` (profile, n) in closed form.

    Parameters
    ----------
    profile : array_like, shape (k, 2)
        ``(ρ, z)`` points as given to ``revolve``.
    n : int, optional
        Sections; None gives the smooth solid of revolution of the same
        polygonal profile.
    """
    area_factor, polar_factor = (1.0, 1.0) if n is None else section_factors(n)
    volume = area_factor * 2 * math.pi * _profile_integral(profile, closed, 1, 0)
    z_first = area_factor * 2 * math.pi * _profile_integral(profile, closed, 1, 1)
    z_second = area_factor * 2 * math.pi * _profile_integral(profile, closed, 1, 2)
    axial = polar_factor * 2 * math.pi * _profile_integral(profile, closed, 3, 0)
    z_center = z_first / volume
    return Analytic.axisymmetric(volume, z_center, axial, axial / 2 + z_second - volume * z_center ** 2)
