"""Assemblies: parts with meshes, materials and poses, from TOML or a GLB/glTF/3MF/COLLADA scene graph.

Each part ``i`` has a pose ``(A_i, r_i)`` (see :mod:`massprops.model.frames`).  A mesh
used by several parts is read and integrated once; every instance reuses its
centroidal tensor through ``J_Gi = A_i J_Gi' A_iᵀ`` and the parallel-axis
terms.  The assembly's total is formed with centred formulas: each part's
``J_Gi`` is shifted to the total center of mass (``ρ_i = r_i − r``), so no
large, nearly equal numbers are subtracted.

Scene files are read by :mod:`massprops.scene.toml_file` (the TOML format, with
compact lists of many instances held as arrays) and :mod:`massprops.scene.graph`
(GLB/glTF/3MF/COLLADA, with exact non-uniform scale).
"""

from __future__ import annotations

import os
import time
from contextlib import contextmanager
from dataclasses import dataclass, replace

import numpy as np

from ..compute import QUANTITIES, checked_moments
from ..model.errors import MassPropsError, MeshFormatError, MeshGeometryError
from ..model.combine import combine_instances
from ..model.frames import Pose
from ..model.properties import MassProperties, unit_factor
from .model import Scene

__all__ = ["SceneResult", "load_scene", "compute_scene"]

SCENE_EXTENSIONS = (".glb", ".gltf", ".3mf", ".dae")


@dataclass(frozen=True, eq=False)
class MeshRecord:
    """A mesh read and integrated once: its outward moments and what the checks said."""

    key: str
    moments: object
    mesh: object
    triangles: int
    checks: dict
    warnings: tuple
    elapsed_s: float


@dataclass(frozen=True, eq=False)
class SceneResult:
    """Per-part properties (each with its pose), the total (global axes), and the bookkeeping.

    ``parts`` is empty unless the report asks for parts; ``frames`` holds the
    global pose of every named frame and of every part named in ``report.about``,
    in output units.
    """

    scene: Scene
    parts: tuple
    total: MassProperties | None
    records: dict
    frames: dict
    stats: dict
    elapsed_s: float


def load_scene(path, *, density=None, unit=None, max_unpacked=None, max_instances=None, max_depth=None):
    """Read a scene: ``.toml`` (massprops's format) or a GLB/glTF/3MF/COLLADA scene graph.

    ``density`` is the default for parts that give none; ``unit`` overrides the
    report's unit; ``max_unpacked`` is the size a 3MF may unpack to,
    ``max_instances`` and ``max_depth`` bound a 3MF's or COLLADA file's
    instance graph (see :func:`massprops.io.read`).
    """
    from ..io.inputs import check_input
    path = os.fspath(path)
    check_input(path, what="scene file")
    if path.lower().endswith(SCENE_EXTENSIONS):
        from .graph import graph_scene
        scene = graph_scene(path, density, max_unpacked=max_unpacked, max_instances=max_instances,
                            max_depth=max_depth)
    elif path.lower().endswith(".toml"):
        from .toml_file import toml_scene
        scene = toml_scene(path, density)
    else:
        raise MeshFormatError("unknown scene format", path=path,
                              fix="give a .toml scene or a .glb/.gltf/.3mf/.dae scene graph")
    return replace(scene, report=replace(scene.report, unit=unit)) if unit else scene


def compute_scene(scene, *, repair=False, max_unpacked=None, max_instances=None, max_depth=None):
    """Mass properties of every part and of the assembly, computing only what the report asks.

    ``max_unpacked``: the size an archive among the meshes may unpack to;
    ``max_instances``, ``max_depth``: the bounds of their instance graphs (see :func:`massprops.io.read`).

    Returns
    -------
    SceneResult
    """
    start = time.perf_counter()
    request = scene.report
    order = request.order
    limits = {"max_unpacked": max_unpacked, "max_instances": max_instances, "max_depth": max_depth}
    records = _integrate_meshes(scene, order, repair, limits)
    wanted = request.quantities | ({"principal"} if request.principal else set())
    cache, local, which = {}, [], []
    for part in scene.parts:
        key = (part.mesh, None if part.stretch is None else part.stretch.tobytes(), part.density, part.mass,
               part.density_field, None if part.density_map is None else tuple(part.density_map.items()))
        if key not in cache:
            cache[key] = len(local)
            local.append(_local_properties(part, records, request.unit, wanted, repair))
        which.append(cache[key])
    index = np.repeat(np.array(which, dtype=np.int64), [part.count for part in scene.parts])
    length = float(unit_factor(request.unit))
    arrays = [part.arrays() for part in scene.parts]
    rotation = np.concatenate([r for r, _ in arrays])
    translation = np.concatenate([t for _, t in arrays]) * length
    # Posed per-part objects only when parts are reported: the total works on arrays.
    parts = tuple(local[i].with_pose(Pose(rotation[k], translation[k])) for k, i in enumerate(index)) \
        if request.parts else ()
    total = combine_instances(local, index, rotation, translation, request.unit) if request.total else None
    principal = (len(parts) if "parts" in request.principal else 0) + (
        1 if total is not None and "total" in request.principal else 0)
    volume_forms = sum(1 for key in cache if records[key[0]].moments is None)
    stats = {"meshes_read": len(records),
             "meshes_integrated": sum(1 for r in records.values() if r.moments is not None) + volume_forms,
             "instances": int(index.size), "properties_formed": len(cache), "moment_order": order,
             "quantities_computed": sorted(q for q in wanted if QUANTITIES[q] <= order),
             "principal_decompositions": principal if order >= 2 else 0}
    return SceneResult(scene, parts, total, records, scene.frame_poses(length), stats,
                       time.perf_counter() - start)


def _integrate_meshes(scene, order, repair, limits):
    """Read each distinct mesh once and integrate each surface once; a failure names the first part using it.

    A volume mesh is only read here: its integrals depend on the part's cell
    densities, so :func:`_local_properties` forms them.
    """
    from ..io import read
    from ..mesh.surface import TriangleMesh
    records = {}
    for part in scene.parts:
        if part.mesh in records:
            continue
        source = scene.meshes.get(part.mesh, part.mesh)
        path = source if isinstance(source, str) else part.mesh
        began = time.perf_counter()
        with _naming(part, path):
            mesh = read(source, **limits) if isinstance(source, str) else source
            moments, checks, warnings = None, {}, ()
            if isinstance(mesh, TriangleMesh):
                moments, mesh, checks, warnings = checked_moments(mesh, path=path, order=order, repair=repair)
        triangles = int(mesh.faces.shape[0]) if moments is not None else 0
        records[part.mesh] = MeshRecord(part.mesh, moments, mesh, triangles, checks, tuple(warnings),
                                        time.perf_counter() - began)
    return records


@contextmanager
def _naming(part, path):
    """Re-raise a mesh's error with the part's name in front and the mesh's file as the path."""
    try:
        yield
    except MassPropsError as exc:
        raise exc.with_context(f"part {part.name!r}", path=path) from None


def _local_properties(part, records, unit, wanted, repair):
    """A part's properties in its own frame (pose left to the caller).

    A volume mesh is integrated here with the part's densities, and its
    record gets the checks of that integration.
    """
    record = records[part.mesh]
    with _naming(part, record.key):
        if record.moments is None or part.density_field is not None or part.density_map is not None:
            from ..compute import mesh_result
            result = mesh_result(record.mesh, density=part.density, mass=part.mass, unit=unit,
                                 repair=repair, only=wanted, density_field=part.density_field,
                                 density_map=part.density_map)
            records[part.mesh] = replace(record, triangles=result.triangles, checks=result.checks,
                                         warnings=result.warnings)
            return result.properties
        moments = record.moments
        if part.stretch is not None:
            from ..model.stretch import stretched_area2, stretched_moments
            try:
                moments = stretched_moments(moments, part.stretch)
            except OverflowError:
                raise MeshGeometryError("its node's scale takes the part's moments beyond double precision",
                                        fix="export the scene with moderate scales") from None
            moments = replace(moments, area2=stretched_area2(record.mesh, part.stretch, moments.scale_exp)
                              if "surface_area" in wanted else 0.0)
        return MassProperties.from_moments(moments, density=part.density, mass=part.mass, unit=unit,
                                           path=record.key)
