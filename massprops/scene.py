"""Assemblies: parts with meshes, materials and poses, from TOML or a GLB/glTF/3MF scene graph.

Each part ``i`` has a pose ``(A_i, r_i)`` (see :mod:`massprops.frames`).  A mesh
used by several parts is read and integrated once; every instance reuses its
centroidal tensor through ``J_Gi = A_i J_Gi' A_iᵀ`` and the parallel-axis
terms.  The assembly's total is formed with centred formulas: each part's
``J_Gi`` is shifted to the total center of mass (``ρ_i = r_i − r``), so no
large, nearly equal numbers are subtracted.

A scene-graph node may also scale or shear its mesh (``x = L x' + t`` with a
general ``L``).  ``L`` is split into a rotation and a stretch, ``L = A P``; the
stretch is applied exactly to the raw moments (``|det P|``, ``|det P| P f``,
``|det P| P C Pᵀ``) before the usual post-processing, never ignored.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field, replace
from fractions import Fraction

import numpy as np

from .compute import QUANTITIES, checked_moments, order_for
from .errors import MassPropsError, MeshFormatError, MeshGeometryError, MeshReadError
from .frames import Pose
from .properties import ErrorBounds, MassProperties, unit_factor

__all__ = ["Part", "Frame", "ReportRequest", "Scene", "SceneResult", "load_scene", "compute_scene",
           "combine_parts", "stretched_moments"]

_U = 2.0 ** -53
SCENE_EXTENSIONS = (".glb", ".gltf", ".3mf")
DEFAULT_QUANTITIES = frozenset(q for q in QUANTITIES if q != "principal")


@dataclass(frozen=True, eq=False)
class Part:
    """One placed solid.

    Attributes
    ----------
    name : str
    mesh : str
        Key of its mesh in :attr:`Scene.meshes` (a file path for TOML scenes).
    pose : Pose
        ``x = A x'' + t`` for points ``x''`` of the stretched mesh (the mesh itself if rigid).
    density, mass : float or None
        At most one; density 1 when neither is given.
    stretch : ndarray, shape (3, 3), or None
        ``P`` of a non-rigid placement (local points ``x'' = P x'``); None when rigid.
    """

    name: str
    mesh: str
    pose: Pose
    density: float | None = None
    mass: float | None = None
    stretch: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Frame:
    """A named frame; ``pose`` is relative to ``part``'s frame when given, else global."""

    name: str
    pose: Pose
    part: str | None = None


@dataclass(frozen=True)
class ReportRequest:
    """What a scene asks to be reported.

    ``principal`` is a subset of ``{"total", "parts"}``; ``about`` names frames
    or parts whose frames the inertia is also expressed in (when "inertia" is
    among the quantities); ``unit`` is the meshes' length unit (outputs then SI).
    """

    parts: bool = True
    total: bool = True
    quantities: frozenset = DEFAULT_QUANTITIES
    principal: frozenset = frozenset({"total"})
    about: tuple = ()
    unit: str | None = None

    def wanted(self, scope):
        """Quantities to report for ``scope`` ("parts" or "total")."""
        return set(self.quantities) | ({"principal"} if scope in self.principal else set())

    @property
    def order(self):
        """Highest moment the request needs (0 volume/mass, 1 COM, 2 inertia)."""
        needed = set(self.quantities) | ({"principal"} if self.principal else set())
        return order_for(needed)


@dataclass(frozen=True, eq=False)
class Scene:
    """Parts, frames and the report request; ``meshes`` maps a mesh key to a path or a TriangleMesh."""

    path: str
    parts: tuple
    frames: dict = field(default_factory=dict)
    report: ReportRequest = field(default_factory=ReportRequest)
    meshes: dict = field(default_factory=dict)

    def frame_poses(self, length=1.0):
        """Global pose of every named frame, and of every part (its own frame), by name.

        ``length`` converts the scene's positions (mesh units) to the output unit.
        """
        by_part = {p.name: _scaled(p.pose, length) for p in self.parts}
        poses = dict(by_part)
        for frame in self.frames.values():
            pose = _scaled(frame.pose, length)
            poses[frame.name] = by_part[frame.part].compose(pose) if frame.part else pose
        return poses


def _scaled(pose, length):
    return pose if length == 1.0 else Pose(pose.rotation, pose.translation * length)


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
    global pose of every named frame and part, in output units.
    """

    scene: Scene
    parts: tuple
    total: MassProperties | None
    records: dict
    frames: dict
    stats: dict
    elapsed_s: float


def load_scene(path, *, density=None, unit=None):
    """Read a scene: ``.toml`` (massprops's format) or a GLB/glTF/3MF scene graph.

    ``density`` is the default for parts that give none; ``unit`` overrides the
    report's unit.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise MeshReadError("no such scene file", path=path, fix="check the path")
    if path.lower().endswith(SCENE_EXTENSIONS):
        scene = _graph_scene(path, density)
    elif path.lower().endswith(".toml"):
        scene = _toml_scene(path, density)
    else:
        raise MeshFormatError("unknown scene format", path=path,
                              fix="give a .toml scene or a .glb/.gltf/.3mf scene graph")
    return replace(scene, report=replace(scene.report, unit=unit)) if unit else scene


def _graph_scene(path, density):
    """Every node with geometry becomes a part with its world transform (instances share meshes)."""
    from .io.trimesh_formats import load_trimesh
    from .mesh import TriangleMesh
    loaded = load_trimesh(path)
    if not hasattr(loaded, "graph"):
        loaded = __import__("trimesh").Scene(loaded)
    nodes = sorted(loaded.graph.nodes_geometry)
    if not nodes:
        raise MeshFormatError("the scene holds no geometry", path=path, fix="export the parts as meshes")
    placements = [loaded.graph[node] for node in nodes]
    matrices = np.array([np.asarray(m, dtype=float) for m, _ in placements])
    poses = placement_poses(matrices[:, :3, :3], matrices[:, :3, 3], path=path)
    meshes = {}
    for name in dict.fromkeys(name for _, name in placements):
        geometry = loaded.geometry[name]
        # Welded by exact coordinates, as every reader does: exporters often split vertices per face.
        triangles = np.asarray(geometry.vertices, dtype=np.float64)[np.asarray(geometry.faces, dtype=np.int64)]
        meshes[f"{path}#{name}"] = TriangleMesh.from_triangles(triangles)
    parts = tuple(Part(node, f"{path}#{name}", pose, density=density, stretch=stretch)
                  for node, (_, name), (pose, stretch) in zip(nodes, placements, poses))
    return Scene(path, parts, meshes=meshes)


def placement_poses(linear, translation, *, path=None):
    """Split placements ``x = L x' + t`` into a pose and a stretch: ``L = A P``.

    Parameters
    ----------
    linear : ndarray, shape (n, 3, 3)
    translation : ndarray, shape (n, 3)

    Returns
    -------
    list of (Pose, ndarray (3, 3) or None)
        ``A`` a proper rotation (polar decomposition, a reflection moved into
        ``P``); ``P`` None where ``L`` is already a rotation to rounding.
    """
    defect = np.abs(linear @ linear.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(linear)
    if not np.all(np.isfinite(linear)) or np.any(det == 0):
        raise MeshGeometryError("a node's transform is singular or not finite", path=path,
                                fix="give every instance a non-zero scale")
    rigid = (defect <= 16 * _U) & (det > 0)
    out = []
    for k in range(linear.shape[0]):
        if rigid[k]:
            out.append((Pose(linear[k], translation[k]), None))
            continue
        u, _, vt = np.linalg.svd(linear[k])
        rotation = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
        out.append((Pose(rotation, translation[k]), rotation.T @ linear[k]))
    return out


def stretched_moments(moments, stretch):
    """Raw moments of the mesh mapped by ``P`` (``x'' = P x'``), exactly up to one rounding each.

    With ``y`` the scaled coordinates of :class:`massprops.integrate.Moments`,
    ``Σdet ↦ |det P| Σdet``, ``first ↦ |det P| P first``, ``second ↦
    |det P| P second Pᵀ``, and the reference point ``↦ P ref`` (kept exact as
    rationals).  The area is not a function of the moments; it is set by the
    caller from the faces (see :func:`stretched_area2`).
    """
    p = [[Fraction(float(x)) for x in row] for row in stretch]
    det = abs(p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0])
              + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]))
    norm = float(max(sum(abs(x) for x in row) for row in p))

    def mapped(vector):
        return [sum(row[k] * vector[k] for k in range(3)) for row in p]

    det_sum = float(Fraction(moments.det_sum) * det)
    first = np.array([float(x * det) for x in mapped([Fraction(v) for v in moments.first])])
    second_rows = [mapped([Fraction(float(v)) for v in column]) for column in np.asarray(moments.second).T]
    second = np.array([[float(det * sum(p[i][k] * second_rows[k][j] for k in range(3))) for j in range(3)]
                       for i in range(3)])
    d = float(det) * (1 + 4 * _U)
    return replace(moments, reference=tuple(mapped([Fraction(x) for x in moments.reference])),
                   det_sum=det_sum, det_error=moments.det_error * d + _U * abs(det_sum),
                   first=first, first_error=moments.first_error * d * norm + _U * float(np.abs(first).max()),
                   second=second,
                   second_error=moments.second_error * d * norm ** 2 + _U * float(np.abs(second).max()))


def stretched_area2(mesh, stretch, scale_exp):
    """``Σ |cof(P) n_f|`` in the moments' scaled units: twice the stretched surface's area."""
    triangles = mesh.vertices[mesh.faces]
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    cofactor = np.linalg.det(stretch) * np.linalg.inv(stretch).T
    return math.ldexp(float(np.linalg.norm(normal @ cofactor.T, axis=1).sum()), -2 * scale_exp)


def compute_scene(scene, *, repair=False):
    """Mass properties of every part and of the assembly, computing only what the report asks.

    Returns
    -------
    SceneResult
    """
    start = time.perf_counter()
    request = scene.report
    order = request.order
    records = _integrate_meshes(scene, order, repair)
    wanted = request.quantities | ({"principal"} if request.principal else set())
    cache, local = {}, []
    frames = scene.frame_poses(float(unit_factor(request.unit)))
    poses = [frames[part.name] for part in scene.parts]
    for part in scene.parts:
        key = (part.mesh, None if part.stretch is None else part.stretch.tobytes(), part.density, part.mass)
        if key not in cache:
            cache[key] = _local_properties(part, records[part.mesh], request.unit, "surface_area" in wanted)
        local.append(cache[key])
    # Posed per-part objects only when parts are reported: the total works on arrays.
    parts = tuple(props.with_pose(pose) for props, pose in zip(local, poses)) if request.parts else ()
    total = combine_parts(local, poses, unit=request.unit) if request.total else None
    principal = (len(parts) if "parts" in request.principal else 0) + (
        1 if total is not None and "total" in request.principal else 0)
    stats = {"meshes_read": len(records), "meshes_integrated": len(records), "instances": len(local),
             "properties_formed": len(cache), "moment_order": order,
             "quantities_computed": sorted(q for q in wanted if QUANTITIES[q] <= order),
             "principal_decompositions": principal if order >= 2 else 0}
    return SceneResult(scene, parts, total, records, frames, stats, time.perf_counter() - start)


def _integrate_meshes(scene, order, repair):
    """Read and integrate each distinct mesh once; a failure names the first part that uses it."""
    from .io import read
    records = {}
    for part in scene.parts:
        if part.mesh in records:
            continue
        source = scene.meshes.get(part.mesh, part.mesh)
        path = source if isinstance(source, str) else part.mesh
        began = time.perf_counter()
        try:
            mesh = read(source) if isinstance(source, str) else source
            moments, mesh, checks, warnings = checked_moments(mesh, path=path, order=order, repair=repair)
        except MassPropsError as exc:
            raise type(exc)(f"part {part.name!r}: {exc.problem}", path=path, fix=exc.fix) from None
        records[part.mesh] = MeshRecord(part.mesh, moments, mesh, int(mesh.faces.shape[0]), checks,
                                        tuple(warnings), time.perf_counter() - began)
    return records


def _local_properties(part, record, unit, want_area):
    """A part's properties in its own frame (pose left to the caller)."""
    moments = record.moments
    if part.stretch is not None:
        moments = stretched_moments(moments, part.stretch)
        moments = replace(moments, area2=stretched_area2(record.mesh, part.stretch, moments.scale_exp)
                          if want_area else 0.0)
    try:
        return MassProperties.from_moments(moments, density=part.density, mass=part.mass, unit=unit,
                                           path=record.key)
    except MassPropsError as exc:
        raise type(exc)(f"part {part.name!r}: {exc.problem}", path=record.key, fix=exc.fix) from None


def combine_parts(parts, poses=None, *, unit=None):
    """The assembly of parts as one :class:`MassProperties` in global axes (identity pose).

    ``parts`` are :class:`MassProperties`, placed at ``poses`` (a Pose each) or,
    without ``poses``, at their own ``pose``.

    Masses and volumes add; the center of mass is the mass-weighted mean of the
    parts' global centers, accumulated relative to the heaviest part's; the
    inertia is ``Σ (A_i J_Gi' A_iᵀ + m_i (ρ_iᵀρ_i I − ρ_i ρ_iᵀ))`` with
    ``ρ_i = r_i − r``.  Error bounds add the parts' bounds, propagated
    through these formulas, and the rounding of the sums.
    """
    mass = np.array([p.mass for p in parts])
    volume = math.fsum(p.volume for p in parts)
    total_mass = math.fsum(mass)
    gamma = (8 + len(parts).bit_length()) * _U
    err_mass = math.fsum(p.error.mass for p in parts) + gamma * total_mass
    error = dict(volume=math.fsum(p.error.volume for p in parts) + gamma * volume, mass=err_mass)
    com = inertia = None
    if parts[0].center_of_mass is not None:
        poses = [p.pose for p in parts] if poses is None else poses
        com, inertia, error = _combine_moments(parts, poses, mass, total_mass, gamma, error)
    surface_area = math.fsum(p.surface_area for p in parts)
    return MassProperties(volume, total_mass, total_mass / volume, surface_area, com, inertia,
                          ErrorBounds(**error), Pose(), unit)


def _combine_moments(parts, poses, mass, total_mass, gamma, error):
    rotation = np.array([pose.rotation for pose in poses])
    local = np.array([p.center_of_mass for p in parts])
    position = np.einsum("nij,nj->ni", rotation, local) + np.array([pose.translation for pose in poses])
    base = position[int(np.argmax(mass))]
    com = base + (mass @ (position - base)) / total_mass
    rho = position - com
    reach = np.abs(rho).max(axis=1)
    # Rotations are orthonormal only to rounding; their defect scales what they carry.
    defect = np.abs(rotation @ rotation.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
    err_position = np.array([p.error.center_of_mass for p in parts]) * (1.8 + defect) + 4 * _U * (
        np.abs(position).max(axis=1))
    err_mass_i = np.array([p.error.mass for p in parts])
    err_com = float(mass @ err_position + err_mass_i @ reach) / (total_mass - error["mass"]) * 1.01 + gamma * float(
        np.abs(position).max() + np.abs(com).max())
    error["center_of_mass"] = err_com
    if parts[0].inertia_com is None:
        return com, None, error
    local_inertia = np.array([p.inertia_com for p in parts])
    rotated = np.einsum("nij,njk,nlk->nil", rotation, local_inertia, rotation)
    shift = mass[:, None, None] * (np.einsum("ni,ni->n", rho, rho)[:, None, None] * np.eye(3)
                                   - np.einsum("ni,nj->nij", rho, rho))
    inertia = (rotated + shift).sum(axis=0)
    size = np.abs(local_inertia).max(axis=(1, 2))
    # Σ m_i P(r_i − c̃) = Σ m_i P(r_i − c) + M P(c − c̃) since Σ m_i (r_i − c) = 0: the error of the
    # total COM enters only squared; the parts' own position and mass errors enter linearly.
    err_inertia = (np.array([p.error.inertia_com for p in parts]) * 3 * (1 + defect) + 6 * defect * size
                   + 2 * err_mass_i * reach ** 2 + mass * (4 * reach * err_position + 2 * err_position ** 2))
    error["inertia_com"] = (float(err_inertia.sum()) + 2 * total_mass * err_com ** 2) * 1.01 + (
        gamma + 16 * _U) * float((3 * size + 2 * mass * reach ** 2).sum())
    return com, inertia, error



# -- TOML scenes -------------------------------------------------------------

_PART_KEYS = {"mesh", "density", "mass", "position", "rotation"}
_FRAME_KEYS = {"position", "rotation", "part"}
_REPORT_KEYS = {"parts", "total", "quantities", "principal", "about", "unit"}
_ROTATION_FORMS = ('give exactly one of quaternion = [w, x, y, z], euler = [a, b, c] with sequence = "ZYX" '
                   '(degrees; lower case extrinsic, upper case intrinsic), or matrix = [[...], [...], [...]]')


def _toml_scene(path, density):
    """Parse a TOML scene (format in the README): ``[parts.NAME]``, ``[frames.NAME]``, ``[report]``."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    try:
        with open(path, "rb") as handle:
            data = tomllib.load(handle)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise MeshFormatError(f"not valid TOML ({exc})", path=path, fix="fix the scene file's syntax") from None
    where = "the scene"
    try:
        _known(data, {"parts", "frames", "report"})
        folder = os.path.dirname(path)
        parts = []
        for name, spec in _table(data, "parts").items():
            where = f"part {name!r}"
            parts.append(_toml_part(name, spec, folder, density))
        if not parts:
            raise MeshFormatError("no parts", fix="add a [parts.NAME] table with mesh = \"file.stl\"")
        frames = {}
        for name, spec in _table(data, "frames").items():
            where = f"frame {name!r}"
            frames[name] = _toml_frame(name, spec, {p.name for p in parts})
        where = "[report]"
        report = _toml_report(_table(data, "report"), set(frames) | {p.name for p in parts})
    except MassPropsError as exc:
        raise type(exc)(f"{where}: {exc.problem}", path=path, fix=exc.fix) from None
    return Scene(path, tuple(parts), frames, report)


def _table(data, key):
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise MeshFormatError(f"{key!r} must be a table", fix=f"write it as [{key}.NAME] sections")
    return value


def _known(spec, keys):
    if not isinstance(spec, dict):
        raise MeshFormatError("must be a table of keys")
    unknown = sorted(set(spec) - keys)
    if unknown:
        raise MeshFormatError(f"unknown key {unknown[0]!r}", fix=f"use {', '.join(sorted(keys))}")


def _toml_pose(spec):
    position = spec.get("position", [0.0, 0.0, 0.0])
    if not (isinstance(position, list) and len(position) == 3 and all(_is_number(v) for v in position)):
        raise MeshFormatError(f"position must be 3 numbers, got {position!r}", fix="write position = [x, y, z]")
    rotation = spec.get("rotation")
    if rotation is None:
        return Pose(translation=np.asarray(position, dtype=float))
    forms = {"quaternion": {"quaternion"}, "euler": {"euler", "sequence"}, "matrix": {"matrix"}}
    keys = set(rotation) if isinstance(rotation, dict) else set()
    form = next((name for name, need in forms.items() if keys == need), None)
    values = rotation.get(form) if form else None
    flat = [v for row in values for v in (row if isinstance(row, list) else [row])] if isinstance(
        values, list) else [values]
    if form is None or not all(_is_number(v) for v in flat):
        raise MeshFormatError(f"cannot read rotation {rotation!r}", fix=_ROTATION_FORMS)
    if form == "euler":
        if not isinstance(rotation["sequence"], str):
            raise MeshFormatError("the Euler sequence must be a string", fix=_ROTATION_FORMS)
        return Pose.from_euler(rotation["sequence"], rotation["euler"], degrees=True, translation=position)
    if form == "quaternion":
        return Pose.from_quat(rotation["quaternion"], translation=position)
    return Pose.from_matrix(rotation["matrix"], translation=position)


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _toml_part(name, spec, folder, density):
    _known(spec, _PART_KEYS)
    if name in ("origin", "com", "total"):
        raise MeshFormatError(f"the name {name!r} is reserved", fix="rename the part")
    mesh = spec.get("mesh")
    if not isinstance(mesh, str) or not mesh:
        raise MeshFormatError("needs mesh = \"path\" (relative to the scene file)")
    for key in ("density", "mass"):
        if key in spec and not _is_number(spec[key]):
            raise MeshFormatError(f"{key} must be a number, got {spec[key]!r}")
    mass = spec.get("mass")
    part_density = spec.get("density", None if mass is not None else density)
    return Part(name, os.path.normpath(os.path.join(folder, mesh)), _toml_pose(spec), density=part_density,
                mass=mass)


def _toml_frame(name, spec, part_names):
    _known(spec, _FRAME_KEYS)
    if name in part_names or name in ("origin", "com", "total"):
        raise MeshFormatError(f"the name {name!r} is already a part's or reserved", fix="rename the frame")
    part = spec.get("part")
    if part is not None and part not in part_names:
        raise MeshFormatError(f"is attached to unknown part {part!r}", fix=f"use one of {', '.join(part_names)}")
    return Frame(name, _toml_pose(spec), part)


def _toml_report(spec, frame_names):
    _known(spec, _REPORT_KEYS)
    quantities = spec.get("quantities", sorted(DEFAULT_QUANTITIES))
    bad = [q for q in quantities if not isinstance(q, str) or q not in DEFAULT_QUANTITIES] if isinstance(
        quantities, list) and quantities else [quantities]
    if bad:
        raise MeshFormatError(f"unknown quantity {bad[0]!r}", fix=f"pick from {', '.join(sorted(DEFAULT_QUANTITIES))}")
    principal = spec.get("principal", "total")
    scopes = {True: {"total"}, False: set(), "none": set(), "total": {"total"}, "parts": {"parts"},
              "all": {"total", "parts"}}
    if not isinstance(principal, (bool, str)) or principal not in scopes:
        raise MeshFormatError(f"principal = {principal!r} is not understood",
                              fix="use \"total\", \"parts\", \"all\", \"none\", true or false")
    about = spec.get("about", [])
    unknown = [a for a in about if not isinstance(a, str) or a not in frame_names] if isinstance(
        about, list) else [about]
    if unknown:
        raise MeshFormatError(f"about names unknown frame or part {unknown[0]!r}",
                              fix="name frames from [frames.NAME] or parts from [parts.NAME]")
    if about and "inertia" not in quantities:
        raise MeshFormatError("about needs the inertia", fix='add "inertia" to quantities')
    unit = spec.get("unit")
    if unit is not None:
        unit_factor(unit)
    flags = {key: spec.get(key, True) for key in ("parts", "total")}
    if not all(isinstance(v, bool) for v in flags.values()):
        raise MeshFormatError("parts and total must be true or false")
    return ReportRequest(flags["parts"], flags["total"], frozenset(quantities), frozenset(scopes[principal]),
                         tuple(about), unit)
