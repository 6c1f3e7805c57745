"""Density and length unit given together: the unit mistakes a run is warned about (never corrected).

A mesh with no length unit makes mass = density × volume in mesh units, so a
kg/m³ density on a millimetre mesh is a part 10⁹ times too heavy; with a
unit, the density is kg/m³, and a g/cm³ value reads as a thousandth of a
solid.  :func:`density_warnings` says so in words; the numbers stay as given.
"""

from __future__ import annotations

__all__ = ["density_warnings", "mixed_units_warning", "LIGHTEST_SOLID", "DENSEST_SOLID"]

# kg/m³: below, lighter than cork and foams (only aerogels are); above, denser than osmium (22,590 kg/m³).
LIGHTEST_SOLID = 50.0
DENSEST_SOLID = 25_000.0


def density_warnings(density, unit, declared):
    """Warnings (option placeholders, see :func:`massprops.model.errors.render_options`) for a run's density.

    Parameters
    ----------
    density : float or None
        The density given (None: the default, or a mass given instead).
    unit : str or None
        The length unit given for every file.
    declared : iterable of (str or None)
        The length unit each file declares (None for a file that declares none).
    """
    if density is None:
        return []
    declared = list(declared) or [None]
    warnings = []
    if unit is None and density > LIGHTEST_SOLID and any(d is None for d in declared):
        warnings.append(f"mesh units unknown: mass is density × mesh-unit³ (density {density:g} per cubic "
                        "mesh unit); if the density is in kg/m³ and the mesh in millimetres, pass {unit=mm}")
    if unit is not None or any(d is not None for d in declared):
        if density < LIGHTEST_SOLID:
            warnings.append(f"{density:g} kg/m³ is lighter than cork; if it is in g/cm³, pass "
                            f"{{density={density * 1000:g}}}")
        elif density > DENSEST_SOLID:
            warnings.append(f"{density:g} kg/m³ is denser than osmium (22,590 kg/m³); with a length unit the "
                            "density is in kg/m³")
    return warnings


def mixed_units_warning(unit, declared):
    """The warning for files of one report of which some declare a length unit and some do not, else None."""
    declared = list(declared)
    if unit is not None or not declared:
        return None
    with_unit = sorted({d for d in declared if d is not None})
    without = sum(1 for d in declared if d is None)
    if not with_unit or not without:
        return None
    return (f"{len(declared) - without} file(s) declare their length unit ({', '.join(with_unit)}) and are "
            f"reported in SI units, {without} declare none and are reported in mesh units: one report mixes "
            "units; pass {unit=mm} (or the unit of the others) to report them all in SI units")
