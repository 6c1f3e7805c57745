"""Mass properties and bounding boxes of one link geometry: primitives in closed form, meshes through the library.

**Primitives** (box, cylinder, sphere, capsule, ellipsoid, cone) use the
closed forms below, in the full-length convention of
:class:`massprops.robot.model.Geometry` (z the axis of the solids of
revolution; the cone's base at ``z = −L/2``, apex at ``+L/2``, as sdformat
places it).  Each quantity is a rational function of the written numbers
times ``π`` or not; the rational part is formed exactly (Fractions of the
floats) and rounded once, then multiplied by ``math.pi``: three roundings at
most, so every bound is ``2u`` of the value (``u = 2**-53``).

======== ============== ============================== ===============================================
kind     volume         center (geometry frame)        inertia about the center, ``diag(Jxx, Jyy, Jzz)``
======== ============== ============================== ===============================================
box      abc            0                              m/12 (b²+c², a²+c², a²+b²)
cylinder πr²L           0                              m(3r²+L²)/12, same, m r²/2
sphere   4/3 πr³        0                              2/5 m r² (all three)
ellipsoid 4/3 πabc      0                              m/5 (b²+c², a²+c², a²+b²)
cone     πr²L/3         (0, 0, −L/4)                   m(3r²/20 + 3L²/80), same, 3/10 m r²
capsule  πr²L + 4/3 πr³ 0                              m_c(3r²+L²)/12 + m_h(2r²/5 + L²/4 + 3rL/8), same,
                                                       m_c r²/2 + 2/5 m_h r²  (m_c cylinder, m_h both caps)
======== ============== ============================== ===============================================

**Meshes** are read by :func:`massprops.io.read` (any format the library
reads), checked and integrated once per file (:func:`massprops.compute.checked_moments`),
then mapped by ``diag(scale)`` exactly on the raw moments
(:func:`massprops.model.stretch.stretched_moments`: ``|det P|`` keeps a mirrored
mesh, whose winding the negative determinant flips, a positive solid).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U
from ..model.errors import MassPropsError, OpenMeshError, OptionError, WindingError, option
from ..model.properties import ErrorBounds, MassProperties, unit_factor
from .model import PRIMITIVES
from .units import mesh_overlap_in_si

__all__ = ["NO_VOLUME", "GeometryResult", "geometry_properties", "primitive_properties", "primitive_bounds", "OnOpen",
           "parse_on_open", "clear_cache"]

NO_VOLUME = ("plane", "heightfield", "heightmap", "polyline", "image", "empty")
_PI_BOUND = 2.01 * _U          # a rational part rounded, times math.pi, rounded: within 2u (and π's own error)
_BOX_BOUND = 1.01 * _U         # one rounding


@dataclass(frozen=True)
class OnOpen:
    """What to do with an open mesh: refuse (``None``), ``hull``, ``shell`` of ``thickness`` metres, or ``skip``."""

    action: str | None = None
    thickness: float | None = None


def parse_on_open(text):
    """``hull``, ``shell:T`` (T in metres) or ``skip``; None refuses open meshes."""
    if text is None:
        return OnOpen()
    if text in ("hull", "skip"):
        return OnOpen(text)
    kind, _, value = text.partition(":")
    if kind == "shell":
        try:
            thickness = float(value)
        except ValueError:
            thickness = math.nan
        if math.isfinite(thickness) and thickness > 0:
            return OnOpen("shell", thickness)
    raise OptionError(f"{option('on_open')} {text!r} is not understood", fix="use hull, shell:THICKNESS (metres) or skip")


@dataclass(frozen=True, eq=False)
class GeometryResult:
    """One geometry's properties, placed at its pose in the link frame, and its box there.

    ``props`` is None for a geometry left out (no volume, or an open mesh skipped).
    ``bounds`` is (2, 3): min and max corner in the link frame.
    """

    props: MassProperties | None
    bounds: np.ndarray | None
    triangles: int = 0
    resolved_path: str | None = None
    resolved_by: str | None = None
    warnings: tuple = ()
    checks: dict | None = None
    surface: Surface | None = None


@dataclass(frozen=True, eq=False)
class Surface:
    """A geometry's closed surface before placement: ``pose.apply(linear_exact @ x)`` puts it in the link frame.

    ``mesh`` is wound outward after the map (faces already reversed for an
    inward file or a mirroring ``linear``); ``linear`` is the (3, 3) float map
    applied (a diagonal ``scale``, whose floats may round the written decimals
    by half an ulp, or MJCF's stretch, exact), ``resolved`` whether the file's
    own shells were united, nested or repeated (:class:`massprops.compute.Checked`).
    """

    mesh: object
    linear: np.ndarray
    pose: object
    resolved: bool = False


# -- primitives ----------------------------------------------------------------

def _fractions(size, *keys):
    return [Fraction(float(size[k])) for k in keys]


def _closed_form(kind, size):
    """``(volume, center z, (Jxx, Jyy, Jzz) per unit density, area, has π)``: Fractions (area a float)."""
    if kind == "box":
        a, b, c = (Fraction(float(x)) for x in size["size"])
        volume = a * b * c
        return volume, Fraction(0), tuple(volume / 12 * s for s in (b * b + c * c, a * a + c * c, a * a + b * b)), \
            float(2 * (a * b + b * c + c * a)), False
    if kind == "sphere":
        (r,) = _fractions(size, "radius")
        volume = Fraction(4, 3) * r ** 3
        return volume, Fraction(0), (volume * Fraction(2, 5) * r * r,) * 3, 4 * math.pi * float(r * r), True
    if kind == "ellipsoid":
        a, b, c = (Fraction(float(x)) for x in size["radii"])
        volume = Fraction(4, 3) * a * b * c
        return volume, Fraction(0), tuple(volume / 5 * s for s in (b * b + c * c, a * a + c * c, a * a + b * b)), \
            _ellipsoid_area(float(a), float(b), float(c)), True
    r, length = _fractions(size, "radius", "length")
    if kind == "cylinder":
        volume = r * r * length
        transverse = volume * (3 * r * r + length * length) / 12
        return volume, Fraction(0), (transverse, transverse, volume * r * r / 2), \
            2 * math.pi * float(r * (r + length)), True
    if kind == "cone":
        volume = r * r * length / 3
        transverse = volume * (Fraction(3, 20) * r * r + Fraction(3, 80) * length * length)
        area = math.pi * float(r) * (float(r) + math.hypot(float(r), float(length)))
        return volume, -length / 4, (transverse, transverse, Fraction(3, 10) * volume * r * r), area, True
    if kind == "capsule":
        cylinder, caps = r * r * length, Fraction(4, 3) * r ** 3
        transverse = (cylinder * (3 * r * r + length * length) / 12
                      + caps * (Fraction(2, 5) * r * r + length * length / 4 + Fraction(3, 8) * r * length))
        axial = cylinder * r * r / 2 + caps * Fraction(2, 5) * r * r
        return cylinder + caps, Fraction(0), (transverse, transverse, axial), \
            2 * math.pi * float(r * (2 * r + length)), True
    raise ValueError(kind)


def _ellipsoid_area(a, b, c):
    """``4π abc R_G(a⁻², b⁻², c⁻²)`` (Carlson's symmetric integral; scipy)."""
    from scipy.special import elliprg
    return 4 * math.pi * a * b * c * float(elliprg(a ** -2, b ** -2, c ** -2))


def _check_size(geometry):
    for key, value in geometry.size.items():
        for v in value if isinstance(value, (tuple, list)) else (value,):
            v = float(v)
            zero_allowed = geometry.kind == "capsule" and key == "length"      # a capsule of length 0 is a sphere
            if not math.isfinite(v) or v < 0 or (v == 0 and not zero_allowed):
                raise MassPropsError(f"{geometry.where}: {geometry.kind} size {_size_text(geometry)} is not "
                                     "positive and finite", fix="give positive dimensions")


def _size_text(geometry):
    return ", ".join(f"{k}={v}" for k, v in geometry.size.items())


def primitive_properties(geometry, density):
    """:class:`MassProperties` of a primitive geometry at ``density``, placed at its pose (link frame)."""
    _check_size(geometry)
    volume, z_center, moments, area, has_pi = _closed_form(geometry.kind, geometry.size)
    rho = Fraction(float(density))
    scale = math.pi if has_pi else 1.0
    relative = _PI_BOUND if has_pi else _BOX_BOUND
    volume_f = float(volume) * scale
    mass_f = float(volume * rho) * scale
    inertia = np.diag([float(m * rho) * scale for m in moments])
    center = np.array([0.0, 0.0, float(z_center)])
    error = ErrorBounds(volume=relative * volume_f, mass=relative * mass_f, center_of_mass=_U * abs(center[2]),
                        inertia_com=relative * float(np.abs(inertia).max()))
    return MassProperties(volume_f, mass_f, float(density), area, center, inertia, error, geometry.pose)


def box_surface(geometry):
    """The :class:`Surface` of a box primitive: its 8 corners ``±size/2`` (exact halves) and 12 outward triangles."""
    from ..mesh import TriangleMesh
    half = np.asarray(geometry.size["size"], dtype=float) / 2
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float) * half
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]], dtype=np.int64)
    return Surface(TriangleMesh(corners, faces), np.eye(3), geometry.pose)


def primitive_bounds(geometry):
    """(2, 3) min/max corners of a primitive's axis-aligned box in the link frame."""
    rotation, translation = geometry.pose.rotation, geometry.pose.translation
    kind, size = geometry.kind, geometry.size
    if kind == "box":
        half = np.abs(rotation) @ (np.asarray(size["size"], float) / 2)
    elif kind == "sphere":
        half = np.full(3, float(size["radius"]))
    elif kind == "ellipsoid":
        half = np.sqrt((rotation ** 2) @ np.asarray(size["radii"], float) ** 2)
    else:
        axis = rotation[:, 2]
        r, h = float(size["radius"]), float(size["length"]) / 2
        across = r if kind == "capsule" else r * np.sqrt(np.maximum(0.0, 1 - axis ** 2))
        half = np.abs(axis) * h + across
    return np.array([translation - half, translation + half])


# -- meshes ---------------------------------------------------------------------

_MESHES = {}


@dataclass(frozen=True, eq=False)
class _MeshEntry:
    """A mesh file read once: its outward moments, checks and warnings, or the problem that stopped it."""

    mesh: object
    moments: object = None
    checks: dict | None = None
    warnings: tuple = ()
    problem: MassPropsError | None = None
    raw: object = None
    resolved: bool = False
    overlap_warning: str | None = None      # the one of ``warnings`` that states checks["overlap"]


def clear_cache():
    """Forget the meshes read so far (the cache lives for one process: a batch of models shares it)."""
    _MESHES.clear()


def _checked(mesh, path=None, repair=False):
    from ..compute import checked_solid
    try:
        checked = checked_solid(mesh, path=path, repair=repair)
    except (OpenMeshError, WindingError) as exc:
        return _MeshEntry(mesh, problem=exc)
    return _MeshEntry(checked.mesh, checked.moments, checked.checks, tuple(checked.warnings), raw=mesh,
                      resolved=bool(checked.resolved), overlap_warning=checked.overlap_warning)


def _read_checked(path, repair, limits=()):
    """The :class:`_MeshEntry` of a mesh file, read and integrated once per (file, repair, limits); other errors
    raise.  ``limits`` are the readers' keyword limits (``max_instances``, ``max_depth``) as pairs."""
    from ..io import read
    from ..mesh import TriangleMesh
    stat = os.stat(path)
    key = (os.path.abspath(path), stat.st_size, stat.st_mtime_ns, repair, limits)
    if key not in _MESHES:
        try:
            mesh = read(path, **dict(limits))
            if not isinstance(mesh, TriangleMesh):
                raise MassPropsError("a volume mesh cannot be a link geometry", path=path,
                                     fix="give the surface mesh (STL, OBJ, PLY, DAE, ...)")
            _MESHES[key] = _checked(mesh, path, repair)
        except MassPropsError as exc:
            _MESHES[key] = exc
    entry = _MESHES[key]
    if isinstance(entry, Exception):
        raise entry
    return entry


def _stretch(scale):
    """``diag(scale)`` as exact Fractions of the written decimals (or the floats), and as floats."""
    exact = [[Fraction(0)] * 3 for _ in range(3)]
    for k, value in enumerate(scale):
        exact[k][k] = value if isinstance(value, Fraction) else Fraction(float(value))
    return exact, np.diag([float(v) for v in scale])


def _vertex_bounds(vertices, scale, pose, stretch=None):
    linear = np.diag([float(s) for s in scale]) if stretch is None else np.asarray(stretch, dtype=float)
    points = pose.apply(vertices @ linear.T)
    return np.array([points.min(axis=0), points.max(axis=0)])


def mesh_properties(geometry, path, density, *, repair=False, on_open=OnOpen(), limits=()):
    """A mesh geometry's properties (placed at its pose) and box: ``(props, bounds, triangles, warnings, checks,
    surface)``."""
    from ..model.stretch import stretched_area2, stretched_moments
    scale = geometry.scale or (1, 1, 1)
    if any(float(s) == 0 or not math.isfinite(float(s)) for s in scale):
        raise MassPropsError(f"{geometry.where}: mesh scale {tuple(map(float, scale))} has a zero or non-finite "
                             "factor", path=path, fix="give a non-zero scale in every axis")
    entry = _read_checked(path, repair, limits) if geometry.mesh is None else _checked(geometry.mesh, repair=repair)
    # A mesh file that declares its length unit (Collada's <unit meter=...>) is in that unit: to metres first,
    # then the description's scale, as rviz and Gazebo read it.
    unit = getattr(entry.mesh, "unit", None)
    if unit is not None and geometry.stretch is None:
        factor = unit_factor(unit)
        scale = tuple((s if isinstance(s, Fraction) else Fraction(float(s))) * factor for s in scale)
    if entry.problem is not None:
        return _open_mesh(geometry, path, density, entry.problem, entry.mesh, scale, on_open)
    moments, mesh = entry.moments, entry.mesh
    if geometry.stretch is not None:
        exact = stretch = np.asarray(geometry.stretch, dtype=float)
    else:
        exact, stretch = _stretch(scale)
    if geometry.stretch is not None or any(float(s) != 1 for s in scale):
        moments = stretched_moments(moments, exact)
        moments = replace(moments, area2=stretched_area2(mesh, stretch, moments.scale_exp))
    props = MassProperties.from_moments(moments, density=float(density), pose=geometry.pose, path=path)
    bounds = _vertex_bounds(mesh.vertices, scale, geometry.pose, geometry.stretch)
    warnings, checks = mesh_overlap_in_si(entry.warnings, entry.checks, np.linalg.det(stretch),
                                          said=entry.overlap_warning)
    return props, bounds, int(mesh.faces.shape[0]), warnings, checks, _surface(entry, stretch, geometry)


def _surface(entry, linear, geometry):
    """The file's own surface (as read, wound outward after ``linear``) to be placed in the link frame."""
    from ..mesh.solid import without_unused_vertices
    mesh = without_unused_vertices(entry.raw)
    inward = entry.checks.get("orientation", "outward") != "outward"
    if inward != bool(np.linalg.det(linear) < 0):
        mesh = mesh.with_faces(mesh.faces[:, ::-1].copy())
    return Surface(mesh, np.asarray(linear, dtype=float), geometry.pose, entry.resolved)


def _open_mesh(geometry, path, density, exc, mesh, scale, on_open):
    """An open (or inconsistently wound) mesh: refused, or what ``--on-open`` asks for, said in a warning."""
    what = f"{geometry.where}: mesh {geometry.uri or '(inline)'}"
    if on_open.action is None:
        raise type(exc)(f"{what}: {exc.problem}", path=path,
                        fix="fix the mesh, or pass {on_open=hull|shell:THICKNESS|skip}, or {repair}")
    if on_open.action == "skip":
        return None, None, 0, (f"{what}: {exc.problem}; left out ({option('on_open', 'skip')})",), None, None
    from ..mesh import TriangleMesh
    linear = np.diag([float(s) for s in scale]) if geometry.stretch is None else np.asarray(geometry.stretch)
    scaled = TriangleMesh(mesh.vertices @ linear.T, mesh.faces)
    if on_open.action == "hull":
        from scipy.spatial import ConvexHull
        hull = ConvexHull(scaled.vertices)
        scaled = TriangleMesh(scaled.vertices, np.asarray(hull.simplices, dtype=np.int64))
        note = "used its convex hull ({on_open=hull})"
        from ..compute import mesh_result
        result = mesh_result(_outward(scaled), density=float(density), pose=geometry.pose)
    else:
        note = f"treated as a sheet {on_open.thickness:g} m thick ({option('on_open', 'shell')})"
        from ..compute import mesh_result
        result = mesh_result(scaled, density=float(density), pose=geometry.pose, shell=on_open.thickness)
    bounds = _vertex_bounds(mesh.vertices, scale, geometry.pose, geometry.stretch)
    return (result.properties, bounds, int(mesh.faces.shape[0]), (f"{what}: {exc.problem}; {note}",
                                                                   *result.warnings), result.checks, None)


def _outward(mesh):
    """A convex hull's faces, each wound with its normal away from the centroid."""
    from ..mesh import TriangleMesh
    triangles = mesh.vertices[mesh.faces]
    centroid = mesh.vertices[np.unique(mesh.faces)].mean(axis=0)
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    inward = np.einsum("ij,ij->i", normal, triangles[:, 0] - centroid) < 0
    faces = mesh.faces.copy()
    faces[inward] = faces[inward][:, ::-1]
    return TriangleMesh(mesh.vertices, faces)


def geometry_properties(geometry, density, *, resolver=None, repair=False, on_open=OnOpen(), limits=()):
    """Mass properties of one geometry at ``density`` (kg/m³), placed in the link frame.

    Returns
    -------
    GeometryResult
        ``props`` None (with a warning) for a kind with no volume or an open mesh skipped.

    Raises
    ------
    MassPropsError
        A mesh that cannot be found, read or integrated; an open mesh unless
        ``on_open`` says otherwise; bad dimensions.
    """
    if geometry.kind in PRIMITIVES:
        return GeometryResult(primitive_properties(geometry, density), primitive_bounds(geometry),
                              surface=box_surface(geometry) if geometry.kind == "box" else None)
    if geometry.kind in NO_VOLUME:
        return GeometryResult(None, None, warnings=(f"{geometry.where}: a {geometry.kind} has no volume; left out",))
    if geometry.kind != "mesh":
        raise MassPropsError(f"{geometry.where}: a {geometry.kind} geometry is not supported",
                             fix="replace it by a mesh or a primitive")
    resolution = None
    if geometry.mesh is None:
        path = resolver.require(geometry.uri, base=geometry.base, what=f"{geometry.where}: mesh")
        resolution = resolver.resolve(geometry.uri, base=geometry.base)
    else:
        path = None
    props, bounds, triangles, warnings, checks, surface = mesh_properties(geometry, path, density, repair=repair,
                                                                          on_open=on_open, limits=limits)
    if resolution is not None and resolution.warning:
        warnings = (resolution.warning, *warnings)
    return GeometryResult(props, bounds, triangles, path, resolution.by if resolution else "inline", warnings, checks,
                          surface)


# -- what encloses a link's geometry ---------------------------------------------

_BALL = []


def _unit_sphere_points():
    """Points whose convex hull holds the unit ball: an icosphere's vertices pushed out by its inradius."""
    if not _BALL:
        _BALL.append(_icosphere_around_ball())
    return _BALL[0]


def _icosphere_around_ball():
    from scipy.spatial import ConvexHull
    t = (1 + 5 ** 0.5) / 2
    points = np.array([[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t],
                       [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], float)
    points /= np.linalg.norm(points, axis=1)[:, None]
    for _ in range(2):                       # midpoints of the hull's edges, pushed to the sphere
        hull = ConvexHull(points)
        edges = {tuple(sorted((a, b))) for face in hull.simplices for a, b in ((face[0], face[1]),
                                                                                (face[1], face[2]),
                                                                                (face[2], face[0]))}
        middle = np.array([(points[a] + points[b]) / 2 for a, b in edges])
        points = np.vstack([points, middle / np.linalg.norm(middle, axis=1)[:, None]])
    hull = ConvexHull(points)
    inradius = float(-hull.equations[:, 3].max())          # the hull's nearest face plane from the centre
    return points / inradius * (1 + 1e-9)


def _polygon(radius, count=48):
    """A regular polygon around the circle of ``radius`` in the xy plane (its vertices, z = 0)."""
    angles = np.arange(count) * (2 * math.pi / count)
    reach = radius / math.cos(math.pi / count) * (1 + 1e-9)
    return np.column_stack([reach * np.cos(angles), reach * np.sin(angles), np.zeros(count)])


def enclosing_points(results):
    """Points in the link frame whose convex hull holds every geometry of ``results`` (``(geometry, props,
    GeometryResult)``), and how far their rounding may reach (a margin for tests on them), or ``(None, 0)``."""
    clouds, reach = [], 0.0
    ball = None
    for geometry, _, result in results:
        kind = geometry.kind
        pose = geometry.pose
        if kind == "mesh" and result.surface is not None:
            surface = result.surface
            local = surface.mesh.vertices @ surface.linear.T
        elif kind in PRIMITIVES:
            size = geometry.size
            if kind == "box":
                half = np.asarray(size["size"], float) / 2
                local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float) * half
            elif kind in ("sphere", "ellipsoid", "capsule"):
                ball = _unit_sphere_points() if ball is None else ball
                if kind == "ellipsoid":
                    local = ball * np.asarray(size["radii"], float)
                else:
                    r = float(size["radius"])
                    h = float(size.get("length", 0.0)) / 2
                    local = np.vstack([ball * r + [0, 0, h], ball * r - [0, 0, h]])
            else:
                r, h = float(size["radius"]), float(size["length"]) / 2
                disk = _polygon(r)
                if kind == "cylinder":
                    local = np.vstack([disk + [0, 0, h], disk - [0, 0, h]])
                else:
                    local = np.vstack([disk - [0, 0, h], [[0, 0, h]]])
        elif result.bounds is not None:
            low, high = result.bounds
            clouds.append(np.array([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1])
                                    for z in (low[2], high[2])], float))
            reach = max(reach, 16 * _U * float(np.abs(result.bounds).max()))
            continue
        else:
            continue
        placed = pose.apply(local)
        clouds.append(placed)
        reach = max(reach, 16 * _U * (float(np.abs(local).max()) * 2 + float(np.abs(pose.translation).max())))
    if not clouds:
        return None, 0.0
    return np.vstack(clouds), reach
