"""Quantities in a robotics engineer's words: SI values written with the unit that reads best (3.1 cm³, 12 g).

Shared by every robot message that states a volume or a mass (the overlap
warnings of :mod:`massprops.robot.overlap` and :mod:`massprops.robot.geometry`),
so they all read alike.  Values are SI (m³, kg) after the file's ``scale``.
"""

from __future__ import annotations

import math

__all__ = ["volume_text", "mass_text", "mesh_overlap_in_si"]

# (from, unit, its size): a volume from 1e-3 m³ up is in m³ (0.375 m³), from 1 cm³ in cm³, below in mm³.
_VOLUMES = ((1e-3, "m³", 1.0), (1e-6, "cm³", 1e-6), (0.0, "mm³", 1e-9))
_MASSES = ((1.0, "kg", 1.0), (1e-3, "g", 1e-3), (0.0, "mg", 1e-6))


def _text(value, units, digits):
    if value == 0 or not math.isfinite(value):
        return f"{value:g} {units[0][1]}"
    for start, unit, size in units:
        if abs(value) >= start:
            break
    number = value / size
    return (f"{number:.0f}" if abs(number) >= 10 ** digits else f"{number:.{digits}g}") + f" {unit}"


def volume_text(cubic_metres, digits=3):
    """``3.12 cm³``: a volume in m³ written in m³ (from 1 litre up), cm³ or mm³."""
    return _text(float(cubic_metres), _VOLUMES, digits)


def mass_text(kilograms, digits=3):
    """``12 g``: a mass in kg written in kg, g or mg."""
    return _text(float(kilograms), _MASSES, digits)


def mesh_overlap_in_si(warnings, checks, volume_factor, where="", said=None):
    """A mesh file's own overlap (shells counted once) in SI after its scale: ``(warnings, checks)``.

    The mesh reader states it in the file's units³ (``volume counted more than
    once: 658.522``); a robot geometry scales the file by a map of determinant
    ``volume_factor``, so the volume becomes ``overlap · |volume_factor|`` m³
    and the warning says so in the link's words (after ``where``, a prefix such as ``"collision[0]: "``;
    the robot's link table adds the link and the geometry itself).  ``said`` is the mesh's own warning
    of it (:attr:`massprops.compute.Checked.overlap_warning`), which ours replaces.
    """
    checks = dict(checks or {})
    overlap = float(checks.get("overlap") or 0.0)
    if not overlap:
        return tuple(warnings), checks
    si = overlap * abs(float(volume_factor))
    checks["overlap"] = si
    if si > 0:
        ours = f"{where}the mesh's shells overlap by {volume_text(si)}; counted once (checks.overlap)"
    else:
        ours = (f"{where}the mesh's faces wind around {volume_text(-si)} more than their signed volume says; "
                "the region they wind around is counted (checks.overlap)")
    return tuple(ours if warning == said else warning for warning in warnings), checks
