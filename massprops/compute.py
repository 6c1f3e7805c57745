"""From a file (or a mesh) to :class:`MassProperties`: read, check, integrate.

This is the one pipeline every command uses.
"""

from __future__ import annotations

import os
import time

import numpy as np
from functools import lru_cache

from .model.records import record, replace
from . import core as _core
from .model.errors import ArgumentTypeError, MassPropsError, OpenMeshError, OptionError
from .mesh.arrays import as_mesh, is_path
from .mesh.surface import TriangleMesh, check_shells
from .mesh.shells import solid_of
from .mesh.solid import overlap_warning, swept_volume, widened, without_repeated_faces, without_unused_vertices
from .model.properties import MassProperties, unit_factor
from .model.resolution import annotate
from .result import Result

__all__ = ["mesh_result", "QUANTITIES", "order_for", "quantities", "Checked", "checked_solid"]

# Quantities for --only, and the highest moment each needs.
QUANTITIES = {"volume": 0, "mass": 0, "surface_area": 0, "center_of_mass": 1, "inertia": 2, "principal": 2}


def quantities(only):
    """The set of quantities ``only`` names: None (everything), one name, ``"a,b"``, or an iterable of names."""
    if only is None:
        return None
    if isinstance(only, str):
        only = only.split(",")
    try:
        wanted = {q.strip() if isinstance(q, str) else q for q in only}
    except TypeError:
        raise ArgumentTypeError(f"only: expected a quantity name or a list of them, got {type(only).__name__}",
                                fix=f"pick from {', '.join(QUANTITIES)}") from None
    unknown = [q for q in wanted if q not in QUANTITIES]
    if unknown or not wanted:
        shown = repr(unknown[0]) if unknown else "nothing"
        raise OptionError(f"unknown quantity {shown} for {{only}}", fix=f"pick from {', '.join(QUANTITIES)}")
    return wanted


def order_for(only):
    """Highest moment needed for the quantities in ``only`` (None: everything)."""
    wanted = quantities(only)
    return 2 if not wanted else max(QUANTITIES[q] for q in wanted)


def mesh_result(source, *, density=None, mass=None, unit=None, pose=None, repair=False, only=None,
                density_field=None, density_map=None, shell=None, max_unpacked=None, max_instances=None, max_depth=None,
                self_intersection=None):
    """Mass properties of a closed mesh (or of a volume mesh, or of a surface as a sheet).

    The pipeline behind :func:`massprops.mass_properties` (which also takes
    scenes, and checks the arguments' types); see there for the parameters.  ``source`` is a path or anything
    :func:`massprops.mesh.arrays.as_mesh` accepts.

    Returns
    -------
    Result
    """
    start = time.perf_counter()
    order = order_for(only)
    path = None
    if is_path(source):
        path = os.fsdecode(source)
        from .io import read
        mesh = read(path, max_unpacked=max_unpacked, max_instances=max_instances, max_depth=max_depth)
    else:
        mesh = as_mesh(source)
    unit, unit_note = _length_unit(mesh, unit)
    try:
        if shell is not None or density_field is not None or density_map is not None \
                or not isinstance(mesh, TriangleMesh):
            result = _other_result(mesh, path, start, order, density=density, mass=mass, unit=unit, pose=pose,
                                   repair=repair, density_field=density_field, density_map=density_map,
                                   shell=shell)
        else:
            result = _mesh_result(mesh, path, start, order, density=density, mass=mass, unit=unit, pose=pose,
                                  repair=repair, self_intersection=self_intersection)
    except MassPropsError as exc:
        raise exc if exc.path or path is None else exc.with_path(path)
    if unit_note:
        result = replace(result, warnings=(*result.warnings, unit_note))
    return result


def _length_unit(mesh, unit):
    """The unit to use: the one given, else the one the file declares; and a note when the file declares one."""
    declared = getattr(mesh, "unit", None)
    if declared is None:
        return unit, None
    if unit is None:
        return declared, (f"the file gives its length unit ({declared}): results are in SI units (m, kg), "
                          "density in kg/m³; a unit given overrides it")
    if unit != declared:
        return unit, f"the file gives its length unit as {declared}; the unit given, {unit}, overrides it"
    return unit, None


def _other_result(mesh, path, start, order, *, shell, density_field, density_map, **material):
    """A surface as a sheet (``shell``), or a volume mesh's cells."""
    if shell is not None:
        if density_field is not None or density_map is not None:
            raise OptionError("{density_field} and {density_map} need a volume mesh, not {shell}")
        from .mesh.sheet import shell_mass_properties
        props, checks, warnings = shell_mass_properties(mesh, shell, order=order, path=path, **material)
        triangles = int(mesh.faces.shape[0])
    else:
        from .mesh.volume import VolumeMesh, volume_mass_properties
        if not isinstance(mesh, VolumeMesh):
            raise OptionError("{density_field} and {density_map} need a volume mesh (cells with cell data or "
                              "groups)", path=path, fix="give a .vtu, .msh, .inp, ... file with volume cells")
        props, triangles, checks, warnings = volume_mass_properties(
            mesh, order=order, density_field=density_field, density_map=density_map, path=path, **material)
    return Result(file=path or "<mesh>", properties=props, triangles=triangles, checks=checks,
                  warnings=tuple(warnings), elapsed_s=time.perf_counter() - start,
                  source_dtype=str(getattr(mesh, "source_dtype", "float64")))


@record(eq=False)
class Checked:
    """A mesh checked, its solid resolved and integrated (:func:`checked_solid`).

    ``resolved`` says what was united, dropped as nested or counted once as
    repeated (:attr:`massprops.mesh.solid.Solid.resolved`): empty when the
    shells neither meet nor nest.  ``overlap_warning`` is the one of
    ``warnings`` that states ``checks["overlap"]`` (None when none does).
    """

    moments: object
    mesh: TriangleMesh
    checks: dict
    warnings: list
    resolved: tuple = ()
    overlap_warning: str | None = None


def checked_moments(mesh, *, path=None, order=2, repair=False, self_intersection=None):
    """Repair (on request), check, resolve the solid and integrate a mesh.

    The solid is the region of positive winding number (:mod:`massprops.mesh.solid`):
    repeated faces, zero-volume, nested and overlapping shells are resolved
    and said so; an inward surface is flipped.

    Returns
    -------
    (Moments, TriangleMesh, dict, list of str)
        Outward moments, the mesh integrated, the checks, and the warnings.
    """
    checked = checked_solid(mesh, path=path, order=order, repair=repair, self_intersection=self_intersection)
    return checked.moments, checked.mesh, checked.checks, checked.warnings


def checked_solid(mesh, *, path=None, order=2, repair=False, self_intersection=None):
    """:func:`checked_moments` as a :class:`Checked`, which also says what was resolved."""
    if not repair:
        return _checked_moments(mesh, path=path, order=order, repair=False, self_intersection=self_intersection)
    from .mesh.repair import after_repair
    try:
        return _checked_moments(mesh, path=path, order=order, repair=True, self_intersection=self_intersection)
    except MassPropsError as exc:
        raise after_repair(exc) from None


def _checked_moments(mesh, *, path, order, repair, self_intersection):
    mesh = without_unused_vertices(mesh)
    warnings = list(mesh.notes)
    if repair:
        from .mesh.repair import repair_mesh
        mesh, changes = repair_mesh(mesh, path=path)
        warnings += changes
    # The compiled core uses every core inside each step, so the steps run one after another.
    mesh, checks, labels, welded, repeated, weights = _closed(mesh, path, warnings)
    solid = solid_of(mesh, labels, checks.shells, path=path, repair=repair,
                     self_intersection=self_intersection, weights=weights)
    moments = _core.integrate(solid.mesh.vertices, solid.mesh.faces, order=order, frame=solid.frame,
                              scaled=solid.scaled)
    warnings += solid.warnings
    moments, orientation = _outward(moments, solid, warnings)
    moments = _widened(moments, solid, welded, order)
    overlap, overlap_note = overlap_warning(solid, moments)
    if overlap_note:
        warnings.append(overlap_note)
    check_dict = checks.as_dict()
    check_dict.update(repeated)
    check_dict.update(solid.checks)
    check_dict["overlap"] = overlap
    check_dict["orientation"] = orientation
    check_dict["refined_faces"] = moments.refined_faces
    if welded is not None:
        check_dict["welded_vertices"] = welded.count
        warnings.append(f"welded {welded.count} vertices that differ from others by at most "
                        f"{float(welded.moved.max()):.2g} (CAD noise) to close the surface; the error bounds "
                        "include the move")
    return Checked(moments, solid.mesh if solid.source is None else solid.source, check_dict, warnings,
                   solid.resolved, overlap_note)


def _outward(moments, solid, warnings):
    """Moments of the outward surface, and the orientation found (a warning when it was flipped)."""
    if not (solid.flipped or moments.det_sum < 0):
        return moments, "outward"
    warnings.append("faces are wound inward (normals point into the solid); flipped them")
    return (moments if solid.flipped else moments.negated()), "inward, flipped"


def _closed(mesh, path, warnings):
    """Check the mesh is closed and merge repeated faces; a surface open only along seams of noise is welded closed.

    Returns the mesh, its checks and shell labels, the :class:`Welded` (None
    when not welded), the repeated-face checks and how many times each face
    counts (None: once each).
    """
    welded = None
    try:
        checks, labels, two_faces_an_edge = check_shells(mesh, path=path)
    except OpenMeshError as refusal:
        from .mesh.near_weld import weld_noise          # open, unless only noise separates its seams
        welded = weld_noise(mesh, path=path, refusal=refusal)
        mesh = welded.mesh
        checks, labels, two_faces_an_edge = check_shells(mesh, path=path)
    if two_faces_an_edge and not (np.any(np.bincount(labels) == 2) if checks.shells > 1
                                  else mesh.faces.shape[0] == 2):
        return mesh, checks, labels, welded, {"duplicate_shells": 0, "duplicate_faces": 0}, None
    # Faces may repeat (a body written twice, a face and its reverse): one face each, counted as often as it repeats.
    reduced, repeated, repeat_warnings, weights = without_repeated_faces(mesh, path=path)
    warnings += repeat_warnings
    if reduced is not mesh:
        from .core import shells
        mesh = reduced
        labels, n_shells = shells(mesh.faces, mesh.vertices.shape[0])
        checks = replace(checks, shells=n_shells)
    return mesh, checks, labels, welded, repeated, weights


def _widened(moments, solid, welded, order):
    """The moments' bounds widened for rounded union vertices, noise welds and dropped zero-volume shells."""
    swept, reach = solid.swept_volume, 0.0
    if welded is not None:
        swept += swept_volume(solid.mesh.vertices, solid.mesh.faces, welded.moved_vertices, welded.moved)
        reach = float(welded.moved.max())
    dropped = None
    if solid.zero_shell_faces.size:
        dropped = _core.integrate(solid.mesh.vertices, solid.zero_shell_faces, order=order)
    if not swept and dropped is None:
        return moments
    return widened(moments, solid.mesh.vertices, swept=swept, reach=reach, dropped=dropped)


def _mesh_result(mesh, path, start, order, *, density, mass, unit, pose, repair, self_intersection):
    triangles = int(mesh.faces.shape[0])
    moments, mesh, check_dict, warnings = checked_moments(mesh, path=path, order=order, repair=repair,
                                                          self_intersection=self_intersection)
    props = MassProperties.from_moments(moments, density=density, mass=mass, unit=unit, pose=pose, path=path)
    props, validity, trust_warnings = annotate(props, mesh, mass_given=mass is not None)
    check_dict.update(validity)
    if check_dict.get("overlap"):
        check_dict["overlap"] *= float(unit_factor(unit)) ** 3
    warnings += trust_warnings
    # file, properties, triangles, checks, warnings, elapsed_s, source_dtype, extra: every field by position,
    # the record's quickest construction (once a part in a batch)
    return Result(path or "<mesh>", props, triangles, check_dict, tuple(warnings), time.perf_counter() - start,
                  _dtype_text(mesh.source_dtype), {})


@lru_cache(maxsize=None)
def _dtype_text(dtype):
    # str() of a numpy dtype takes microseconds, and a batch asks it of the same one or two dtypes every file
    return str(dtype)
