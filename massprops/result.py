"""What :func:`massprops.mass_properties` returns: one input's :class:`Result`.

Its :class:`~massprops.model.properties.MassProperties`, the checks and warnings,
and the quantities under flat read-only names (with trimesh's as aliases), a
one-line ``repr`` and a notebook table.
"""

from __future__ import annotations

import math
from dataclasses import field

import numpy as np

from .model.properties import MassProperties
from .model.records import record
from .report.digits import bound_text, significant

__all__ = ["Result"]


@record(eq=False)
class Result:
    """One input's outcome: its properties plus what was checked and said on the way.

    The quantities are also flat read-only attributes, with trimesh's names as
    aliases: ``mass``, ``volume``, ``density``, ``surface_area``,
    ``center_of_mass`` (``center_mass``), ``inertia`` about the center of mass
    in local axes (``moment_inertia``), ``inertia_origin`` (about the global
    origin, global axes), ``principal_moments``
    (``principal_inertia_components``), ``principal_axes``, one axis a row
    (``principal_inertia_vectors``), and ``error``, the bounds.  A quantity
    left out by ``only`` is None.  :meth:`to_dict` is the JSON object
    ``massprops props --format json`` prints.
    """

    file: str
    properties: MassProperties
    triangles: int
    checks: dict
    warnings: tuple = ()
    elapsed_s: float = 0.0
    source_dtype: str = "float64"
    extra: dict = field(default_factory=dict)

    # -- flat, read-only views of ``properties``

    @property
    def mass(self) -> float:
        return self.properties.mass

    @property
    def volume(self) -> float:
        return self.properties.volume

    @property
    def density(self) -> float:
        return self.properties.density

    @property
    def surface_area(self) -> float:
        return self.properties.surface_area

    @property
    def center_of_mass(self) -> np.ndarray | None:
        """(3,), local frame (read-only); None when not computed."""
        return self.properties.center_of_mass

    @property
    def inertia(self) -> np.ndarray | None:
        """(3, 3), about the center of mass, local axes (read-only); None when not computed."""
        return self.properties.inertia_com

    @property
    def inertia_origin(self) -> np.ndarray | None:
        """(3, 3), about the global origin, global axes; None when not computed."""
        return None if self.properties.inertia_com is None else self.properties.inertia_origin

    @property
    def principal_moments(self) -> np.ndarray | None:
        """(3,), ascending; None when the inertia was not computed."""
        return None if self.properties.inertia_com is None else self.properties.principal.moments

    @property
    def principal_axes(self) -> np.ndarray | None:
        """(3, 3), row k the unit axis of ``principal_moments[k]`` in local axes; None when not computed."""
        return None if self.properties.inertia_com is None else self.properties.principal.axes

    @property
    def error(self):
        """:class:`massprops.ErrorBounds`: absolute bounds, same units as each quantity."""
        return self.properties.error

    # trimesh's names for the same values
    center_mass = center_of_mass
    moment_inertia = inertia
    principal_inertia_components = principal_moments
    principal_inertia_vectors = principal_axes

    def to_dict(self) -> dict:
        """The JSON object ``massprops props --format json`` prints for this result (plain Python values)."""
        from .report.objects import result_dict
        return result_dict(self)

    def largest_relative_bound(self) -> float:
        """The largest of each computed quantity's bound over its size (the center of mass against the
        part's radius of gyration, so a centred part is not judged against zero)."""
        p, e = self.properties, self.properties.error
        ratios = [e.volume / abs(p.volume) if p.volume else math.inf, e.mass / abs(p.mass) if p.mass else math.inf]
        if p.inertia_com is not None:
            scale = float(np.abs(p.inertia_com).max())
            ratios.append(e.inertia_com / scale if scale else math.inf)
            ratios.append(e.principal_moments / float(np.abs(p.principal.moments).max()) if scale else math.inf)
        if p.center_of_mass is not None:
            size = float(np.abs(p.center_of_mass).max())
            if p.inertia_com is not None and p.mass:
                size = max(size, math.sqrt(abs(float(np.trace(p.inertia_com))) / (2 * abs(p.mass))))
            ratios.append(e.center_of_mass / size if size else (0.0 if e.center_of_mass == 0 else math.inf))
        return max(ratios)

    def __repr__(self):
        def numbers(values):
            return "[" + ", ".join(significant(float(v), digits=6) for v in values) + "]"
        parts = [f"file={self.file!r}", f"mass={significant(self.mass, digits=6)}"]
        if self.center_of_mass is not None:
            parts.append(f"center_of_mass={numbers(self.center_of_mass)}")
        if self.properties.inertia_com is not None:
            parts.append(f"principal_moments={numbers(self.principal_moments)}")
        parts.append(f"relative_bound={self.largest_relative_bound():.1e}")
        return f"Result({', '.join(parts)})"

    def _repr_html_(self):
        from html import escape
        p, e = self.properties, self.properties.error
        rows = [("volume", f"{p.volume:.15g}", e.volume), ("mass", f"{p.mass:.15g}", e.mass),
                ("density", f"{p.density:.15g}", None)]
        if p.center_of_mass is not None:
            rows.append(("center of mass", _vector(p.center_of_mass), e.center_of_mass))
        if p.inertia_com is not None:
            rows.append(("inertia about COM", "<br>".join(_vector(r) for r in p.inertia_com), e.inertia_com))
            rows.append(("principal moments", _vector(self.principal_moments), e.principal_moments))
            rows.append(("principal axes", "<br>".join(_vector(r) for r in self.principal_axes), None))
        body = "".join(f"<tr><th style='text-align:left'>{name}</th><td style='font-family:monospace'>{value}</td>"
                       f"<td>{'' if bound is None else '± ' + bound_text(bound)}</td></tr>" for name, value, bound in rows)
        unit = f", SI units (mesh unit {escape(p.unit)})" if p.unit else ""
        return (f"<table><caption>{escape(str(self.file))}: {self.triangles} triangles{unit}</caption>"
                f"{body}</table>")


def _vector(values):
    return "[" + ", ".join(significant(float(v)) for v in values) + "]"
