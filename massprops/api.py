"""The Python entry point: :func:`mass_properties` of whatever a trimesh, Open3D or meshio user holds.

Meshes go through :mod:`massprops.compute`; a ``trimesh.Scene`` is computed as
an assembly by :mod:`massprops.scene` (every node with geometry a part at its
world transform).  Documented with run examples in ``docs/api.md``.
"""

from __future__ import annotations

import time
from dataclasses import replace

import os
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any, Union

if TYPE_CHECKING:                       # numpy.typing costs ~7M instructions at start-up
    from numpy.typing import ArrayLike

from . import compute
from .result import Result
from .model.errors import ArgumentTypeError, OptionError, option
from .model.frames import Pose
from .mesh.arrays import is_path

__all__ = ["mass_properties", "Source"]

# What mass_properties takes: a file, a TriangleMesh, a trimesh mesh or scene, an object with vertices and
# faces (or triangles), a (vertices, faces) pair, vertices (with faces as the second argument), or an
# (m, 3, 3) array of triangles.
# (numpy.typing.ArrayLike among them: named for type checkers only.)
if TYPE_CHECKING:
    Source = Union[str, bytes, os.PathLike, ArrayLike, tuple, Any]
else:
    Source = Union[str, bytes, os.PathLike, tuple, Any]


def mass_properties(source: Source, faces: ArrayLike | None = None, *, density: float | None = None,
                    mass: float | None = None, unit: str | None = None, pose: Pose | None = None, repair: bool = False,
                    only: str | Iterable[str] | None = None, density_field: str | None = None,
                    density_map: Mapping[str, float] | None = None, shell: float | None = None,
                    max_unpacked: int | None = None, max_instances: int | None = None,
                    max_depth: int | None = None, self_intersection: bool | None = None) -> Result:
    """Mass properties of a solid, with a rigorous error bound on every number.

    Parameters
    ----------
    source : path, TriangleMesh, trimesh.Trimesh, trimesh.Scene, object, (vertices, faces), vertices or triangles
        A mesh file of any registered format (``str``, ``bytes`` or
        ``os.PathLike``); a :class:`massprops.TriangleMesh`; any object with
        ``vertices`` (n, 3) and ``faces`` (m, 3) (a ``trimesh.Trimesh``) or
        ``vertices`` and ``triangles`` (Open3D, as numpy arrays); a
        ``(vertices, faces)`` pair of arrays or lists (faces of any integer
        type), or the vertices with the faces as the second argument,
        ``mass_properties(V, F)``; an ``(m, 3, 3)`` array of triangle corners
        (numpy-stl's ``mesh.vectors``, or its ``mesh.Mesh`` itself); or a
        ``trimesh.Scene``, computed as an assembly.  Coordinates
        are in the mesh's own (local) frame; vertices are welded by exact
        coordinates.  One source per call: for many files, call it per file
        or use :func:`massprops.batch.run.run_batch`.
    density : float, optional
        Mass per volume (kg/m³ with ``unit``); default 1, so mass = volume.
    mass : float, optional
        Total mass instead of a density.
    unit : {"m", "cm", "mm", "um", "in", "ft"}, optional
        The mesh's length unit; every output is then SI (m, kg, kg·m²).  A
        file that declares its unit (3MF, COLLADA) gives it by default.
    pose : Pose, optional
        Where the part sits: a local point ``x'`` is at ``x = A x' + t``.
    repair : bool
        Re-orient faces, remove duplicates, close holes and turn inside-out
        shells outward instead of refusing the mesh; what changed is listed
        in ``Result.warnings``.
    only : str or iterable of str, optional
        Quantities wanted: ``"volume"``, ``"mass"``, ``"surface_area"``,
        ``"center_of_mass"``, ``"inertia"``, ``"principal"`` (one name, a
        comma-separated string, or a list).  Volume alone forms no first or
        second moments.
    density_field, density_map : optional
        Per-cell density of a volume mesh: a cell-data array's name, or
        ``{group: density}``.
    shell : float, optional
        Treat the surface as a sheet of this thickness (mesh units).
    max_unpacked : int, optional
        Bytes an archive (3MF) may unpack to; default 100 times its size, at
        least 64 MiB.
    max_instances, max_depth : int, optional
        Meshes a 3MF or COLLADA file may place through its instance graph
        (components, instanced nodes), and levels it may nest; default
        100,000 and 100.  Counted before anything is expanded.
    self_intersection : bool, optional
        Find faces that cross or overlap and integrate the region of positive
        winding number (:mod:`massprops.mesh.arrangement`): None or True (the
        default, at every size).  False integrates a one-shell surface's
        signed volume as it is.  ``checks["self_intersection"]`` says
        ``"none"``, ``"resolved"`` or ``"not checked"``.

    Returns
    -------
    Result
        ``properties`` (a :class:`MassProperties`, arrays read-only), the
        triangle count, the checks and the warnings.  For a scene,
        ``properties`` is the assembly's total in global axes and
        ``extra["parts"]`` maps each node to its posed :class:`MassProperties`.

    Raises
    ------
    MassPropsError
        A bad file or mesh (``MeshFormatError``, ``MeshReadError``,
        ``MeshGeometryError``...) or a bad argument value (``OptionError``,
        also a ``ValueError``).
    TypeError
        A source of the wrong type (``ArgumentTypeError``), e.g. a list of paths.
    """
    _check_pose(pose)
    if faces is not None:
        if is_path(source) or _is_trimesh_scene(source):
            raise ArgumentTypeError("faces: given with a file or a scene, which carry their own",
                                    fix="pass faces only with an array of vertices, mass_properties(V, F)")
        source = (source, faces)
    if _is_trimesh_scene(source):
        ignored = [name for name, value in (("mass", mass), ("shell", shell), ("density_field", density_field),
                                            ("density_map", density_map)) if value is not None]
        if ignored:
            raise OptionError(f"{option(ignored[0])} does not apply to a scene",
                              fix=f"give {option('density')} for every part, or compute the parts one by one")
        return _scene_result(source, density=density, unit=unit, pose=pose, repair=repair, only=only)
    return compute.mesh_result(source, density=density, mass=mass, unit=unit, pose=pose, repair=repair,
                               only=only, density_field=density_field, density_map=density_map, shell=shell,
                               max_unpacked=max_unpacked, max_instances=max_instances, max_depth=max_depth,
                               self_intersection=self_intersection)


def _check_pose(pose):
    """Refuse a ``pose`` that is not a :class:`Pose` (a 4×4 matrix, a tuple...) with what to do instead."""
    if pose is not None and not isinstance(pose, Pose):
        raise ArgumentTypeError(f"pose: expected a massprops.Pose, got {type(pose).__name__}",
                                fix="build one, e.g. Pose.from_matrix(R, translation=t) or Pose.from_quat(q)")


def _is_trimesh_scene(source):
    return hasattr(source, "graph") and hasattr(source, "geometry") and not hasattr(source, "faces")


def _scene_result(source, *, density, unit, pose, repair, only):
    """A ``trimesh.Scene`` as an assembly: the total (global axes), and every node's part in ``extra``."""
    from .scene.assembly import compute_scene
    from .scene.graph import scene_from_trimesh
    start = time.perf_counter()
    wanted = compute.quantities(only) or set(compute.QUANTITIES)
    scene = scene_from_trimesh(source, "<scene>", density)
    request = replace(scene.report, parts=True, total=True, quantities=frozenset(wanted - {"principal"}),
                      principal=frozenset({"total", "parts"}) if "principal" in wanted else frozenset(), unit=unit)
    result = compute_scene(replace(scene, report=request), repair=repair)
    total = result.total if pose is None else result.total.with_pose(pose)
    names = [name for part in scene.parts for name in part.instance_names()]
    warnings = tuple(f"{record.key}: {w}" for record in result.records.values() for w in record.warnings)
    checks = {"parts": len(names), "meshes": len(result.records)}
    return Result(file="<scene>", properties=total, triangles=sum(r.triangles for r in result.records.values()),
                  checks=checks, warnings=warnings, elapsed_s=time.perf_counter() - start,
                  extra={"parts": dict(zip(names, result.parts))})
