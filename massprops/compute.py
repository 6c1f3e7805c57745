"""From a file (or a mesh) to :class:`MassProperties`: read, check, integrate.

This is the one pipeline every command uses.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from functools import lru_cache

from . import core as _core
from .frames import Pose
from .errors import ArgumentTypeError, MassPropsError, OptionError
from .mesh.arrays import as_mesh, is_path
from .mesh.surface import TriangleMesh, check_mesh
from .properties import MassProperties
from .resolution import annotate

__all__ = ["mass_properties", "Result", "QUANTITIES", "order_for", "quantities"]

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


def check_pose(pose):
    """Refuse a ``pose`` that is not a :class:`Pose` (a 4×4 matrix, a tuple...) with what to do instead."""
    if pose is not None and not isinstance(pose, Pose):
        raise ArgumentTypeError(f"pose: expected a massprops.Pose, got {type(pose).__name__}",
                                fix="build one, e.g. Pose.from_matrix(R, translation=t) or Pose.from_quat(q)")


def order_for(only):
    """Highest moment needed for the quantities in ``only`` (None: everything)."""
    wanted = quantities(only)
    return 2 if not wanted else max(QUANTITIES[q] for q in wanted)


@dataclass(frozen=True, eq=False)
class Result:
    """One input's outcome: its properties plus what was checked and said on the way."""

    file: str
    properties: MassProperties
    triangles: int
    checks: dict
    warnings: tuple = ()
    elapsed_s: float = 0.0
    source_dtype: str = "float64"
    extra: dict = field(default_factory=dict)


def mass_properties(source, *, density=None, mass=None, unit=None, pose=None, repair=False, only=None,
                    density_field=None, density_map=None, shell=None, max_unpacked=None):
    """Mass properties of a closed mesh (or of a volume mesh, or of a surface as a sheet).

    The pipeline behind :func:`massprops.mass_properties` (which also takes
    scenes); see there for the parameters.  ``source`` is a path or anything
    :func:`massprops.mesh.arrays.as_mesh` accepts.

    Returns
    -------
    Result
    """
    start = time.perf_counter()
    order = order_for(only)
    check_pose(pose)
    path = None
    if is_path(source):
        path = os.fsdecode(source)
        from .io import read
        mesh = read(path, max_unpacked=max_unpacked)
    else:
        mesh = as_mesh(source)
    try:
        if shell is not None or density_field is not None or density_map is not None \
                or not isinstance(mesh, TriangleMesh):
            return _other_result(mesh, path, start, order, density=density, mass=mass, unit=unit, pose=pose,
                                 repair=repair, density_field=density_field, density_map=density_map,
                                 shell=shell)
        return _mesh_result(mesh, path, start, order, density=density, mass=mass, unit=unit, pose=pose,
                            repair=repair)
    except MassPropsError as exc:
        raise exc if exc.path or path is None else exc.with_path(path)


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


def checked_moments(mesh, *, path=None, order=2, repair=False):
    """Repair (on request), check and integrate a mesh; an inward surface is flipped.

    Returns
    -------
    (Moments, TriangleMesh, dict, list of str)
        Outward moments, the mesh integrated, the checks, and the warnings.
    """
    warnings = []
    if repair:
        from .mesh.repair import repair_mesh
        mesh, changes = repair_mesh(mesh)
        warnings += changes
    checks = check_mesh(mesh, path=path)
    moments = _core.integrate(mesh.vertices, mesh.faces, order=order)
    orientation = "outward"
    if moments.det_sum < 0:
        moments = moments.negated()
        orientation = "inward, flipped"
        warnings.append("faces are wound inward (normals point into the solid); flipped them")
    check_dict = checks.as_dict()
    check_dict["orientation"] = orientation
    check_dict["refined_faces"] = moments.refined_faces
    return moments, mesh, check_dict, warnings


def _mesh_result(mesh, path, start, order, *, density, mass, unit, pose, repair):
    moments, mesh, check_dict, warnings = checked_moments(mesh, path=path, order=order, repair=repair)
    props = MassProperties.from_moments(moments, density=density, mass=mass, unit=unit, pose=pose, path=path)
    props, validity, trust_warnings = annotate(props, mesh, mass_given=mass is not None)
    check_dict.update(validity)
    warnings += trust_warnings
    return Result(file=path or "<mesh>", properties=props, triangles=int(mesh.faces.shape[0]),
                  checks=check_dict, warnings=tuple(warnings), elapsed_s=time.perf_counter() - start,
                  source_dtype=_dtype_text(mesh.source_dtype))


@lru_cache(maxsize=None)
def _dtype_text(dtype):
    # str() of a numpy dtype takes microseconds, and a batch asks it of the same one or two dtypes every file
    return str(dtype)
