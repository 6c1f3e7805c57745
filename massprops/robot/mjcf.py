"""MJCF through ``mujoco.MjSpec``: MuJoCo resolves includes, defaults, frames and orientations.

Conventions (MuJoCo's XML reference, ``doc/XMLreference.rst``): quaternions
are ``w x y z`` (scalar first); ``euler`` angles are in degrees unless
``<compiler angle="radian">``, in the sequence ``<compiler eulerseq>``
(default ``xyz``: lower case intrinsic, upper case extrinsic; URDF's rpy is
``XYZ``); geom ``size`` is half-lengths (box:
half edges; capsule, cylinder: radius and half-length); ``fullinertia`` is
``Ixx Iyy Izz Ixy Ixz Iyz`` (the tensor's own elements) about ``pos`` in the
body axes, ``diaginertia`` the principal moments in the axes of ``quat``.
A geom's ``mass`` overrides its ``density`` (default 1000 kg/m³).

The model is compiled once, on a copy whose inertials are all replaced by a
valid placeholder (so a declared inertial MuJoCo would reject is still read
and checked) and whose meshes that cannot be found are left out.  From it
come the body frames, joints and geom frames.  Meshes are then re-read from
disk at full precision (MuJoCo keeps float32 vertices, re-centred): a mesh
geom's frame is recovered as ``geom_frame ∘ mesh_offset⁻¹``, and MuJoCo's
``refpos``/``refquat`` and ``scale`` are applied as the stretch
``x ↦ S R_refᵀ (x − refpos)``.  A geom is *visual* when its ``contype`` and
``conaffinity`` are both 0, else *collision*.
"""

from __future__ import annotations

import math
import os
from dataclasses import replace
from fractions import Fraction

import numpy as np

from ..model.errors import MassPropsError, OptionError
from ..model.frames import Pose, quat_to_matrix
from .model import Decimal, Geometry, Inertial, Joint, Link, RobotFormatError, RobotModel, tensor_from_elements
from .xmlspans import parse_with_spans

__all__ = ["read_mjcf", "import_mujoco"]

_KINDS = {"sphere": "sphere", "capsule": "capsule", "ellipsoid": "ellipsoid", "cylinder": "cylinder",
          "box": "box", "mesh": "mesh", "plane": "plane", "hfield": "heightfield", "sdf": "sdf"}
_JOINTS = {"free": "free", "ball": "ball", "slide": "slide", "hinge": "hinge"}


def import_mujoco(path=None):
    """The ``mujoco`` module, or a one-line OptionError naming the extra to install."""
    try:
        import mujoco
    except ImportError:
        raise OptionError("reading MJCF needs the mujoco package, which is not installed", path=path,
                          fix='pip install "massprops[robot]"') from None
    return mujoco


def _name(element, kind, index):
    return element.name or f"{kind}{index}"


def _quat(q):
    return quat_to_matrix(np.asarray(q, dtype=float))


def _mesh_folder(spec, path):
    folder = os.path.dirname(os.path.abspath(path))
    meshdir = spec.meshdir or ""
    return os.path.join(folder, meshdir) if meshdir else folder


def _neutral_copy(spec, mujoco, missing_meshes):
    """A copy that compiles whatever the declared inertials: each body gets mass 1, inertia 1 at its declared frame."""
    neutral = spec.copy()
    neutral.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    neutral.compiler.balanceinertia = False
    for body in neutral.bodies[1:]:
        if not body.explicitinertial or not math.isfinite(body.ipos[0]):
            body.ipos = [0.0, 0.0, 0.0]
            body.iquat = [1.0, 0.0, 0.0, 0.0]
        if math.isfinite(body.fullinertia[0]):
            body.fullinertia = [math.nan, 0, 0, 0, 0, 0]
            body.iquat = [1.0, 0.0, 0.0, 0.0]
        body.explicitinertial = True
        body.mass = 1.0
        body.inertia = [1.0, 1.0, 1.0]
    for geom in list(neutral.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH and geom.meshname in missing_meshes:
            neutral.delete(geom)
    for mesh in list(neutral.meshes):
        if mesh.name in missing_meshes:
            neutral.delete(mesh)
    # Textures matter to no mass property, and a missing image file would stop the compile.
    for texture in list(neutral.textures):
        neutral.delete(texture)
    for material in neutral.materials:
        material.textures = [""] * len(material.textures)
    return neutral


def _mesh_files(spec, path, resolver):
    """``{mesh name: resolved path or None}`` (inline meshes map to ""), and the problems of those not found."""
    folder = _mesh_folder(spec, path)
    files, problems = {}, {}
    for k, mesh in enumerate(spec.meshes):
        name = mesh.name or os.path.splitext(os.path.basename(mesh.file))[0]
        if not mesh.file:
            files[name] = ""
            continue
        resolution = resolver.resolve(mesh.file, base=folder)
        files[name] = resolution.path
        if resolution.path is None:
            problems[name] = f"mesh {mesh.file!r} not found (tried: {'; '.join(resolution.tried)})"
        elif mesh.file.lower().endswith(".msh"):
            files[name] = None
            problems[name] = f"mesh {mesh.file!r}: MuJoCo's binary .msh format is not read by massprops"
    return files, problems


def _inline_mesh(mesh):
    from ..mesh import TriangleMesh
    vertices = np.asarray(mesh.uservert, dtype=float).reshape(-1, 3)
    faces = np.asarray(mesh.userface, dtype=np.int64).reshape(-1, 3)
    if faces.size == 0:
        return None
    return TriangleMesh(vertices, faces)


def _mesh_geometry(model, g, spec_mesh, mesh_path, base):
    """The geometry pose and stretch of mesh geom ``g``: file coordinates to the body frame."""
    m = int(model.geom_dataid[g])
    geom_rotation = _quat(model.geom_quat[g])
    user_rotation = geom_rotation @ _quat(model.mesh_quat[m]).T
    user_translation = model.geom_pos[g] - user_rotation @ model.mesh_pos[m]
    scale = [Fraction(float(s)) for s in spec_mesh.scale]
    refpos = np.asarray(spec_mesh.refpos, dtype=float)
    refquat = np.asarray(spec_mesh.refquat, dtype=float)
    if np.allclose(refquat / np.linalg.norm(refquat), [1, 0, 0, 0], rtol=0, atol=0):
        stretch = None
        shift = np.array([float(s) for s in scale]) * refpos
    else:
        r = _quat(refquat)
        stretch = r @ np.diag([float(s) for s in scale]) @ r.T       # S R_refᵀ = R_refᵀ (R_ref S R_refᵀ)
        user_rotation = user_rotation @ r.T
        shift = stretch @ refpos
        scale = None
    pose = Pose(user_rotation, user_translation - user_rotation @ shift)
    return pose, scale, stretch


def _spec_geoms_by_compiled(spec, missing_meshes, mujoco):
    """The spec's geoms in compiled order (the compiled copy leaves out those whose mesh is missing)."""
    kept, left_out = [], []
    for geom in spec.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH and geom.meshname in missing_meshes:
            left_out.append(geom)
        else:
            kept.append(geom)
    return kept, left_out


def _declared(body, compiled_rotation, element, path):
    """The declared inertial of a body with ``explicitinertial``, numbers as written where the file shows them."""
    attributes = {} if element is None else dict(element.attrib)

    def numbers(key, values):
        text = attributes.get(key)
        if text is not None and len(text.split()) == len(values):
            return [Decimal.parse(t, what=f"body {body.name!r} inertial {key}", path=path) for t in text.split()]
        return [Decimal.of(v) for v in values]

    mass = numbers("mass", [body.mass])[0]
    center = np.array([d.value for d in numbers("pos", list(body.ipos))])
    if math.isfinite(body.fullinertia[0]):
        six = numbers("fullinertia", list(body.fullinertia))
        written = dict(zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), six))
        rotation = np.eye(3)
    else:
        three = numbers("diaginertia", list(body.inertia))
        written = {"ixx": three[0], "iyy": three[1], "izz": three[2],
                   "ixy": Decimal.of(0.0), "ixz": Decimal.of(0.0), "iyz": Decimal.of(0.0)}
        rotation = compiled_rotation
    tensor = tensor_from_elements({k: v.value for k, v in written.items()})
    return Inertial(mass, center, rotation @ tensor @ rotation.T, rotation, written, line=None)


def included_files(path):
    """The files ``path`` includes, nested ones too, in document order (MuJoCo's rule: relative to the main
    file's folder); those that are missing or do not parse are left out (MuJoCo names them)."""
    from lxml import etree
    folder = os.path.dirname(os.path.abspath(path))
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True, recover=True)
    out, pending = [], [os.path.abspath(path)]
    while pending and len(out) <= MAX_INCLUDES:
        current = pending.pop(0)
        if current in out:
            continue
        out.append(current)
        try:
            root = etree.parse(current, parser).getroot()
        except (OSError, etree.XMLSyntaxError):
            continue
        if root is None:
            continue
        pending += [os.path.abspath(os.path.join(folder, i.get("file"))) for i in root.iter("include") if i.get("file")]
    return out[1:]


def _body_elements(path, spec):
    """``({body name: (body element, inertial element or None, file)}, {file: spans}, {file: bytes})``.

    Without includes the bodies are paired with the spec's in order (unnamed ones too); with includes, by
    name across the main file and every included file (an unnamed body there is not located).
    """
    root, spans, data = parse_with_spans(path)
    path = os.path.abspath(path)
    names = [b.name for b in spec.bodies[1:]]
    files_spans, files_data = {path: spans}, {path: data}
    if root.find(".//include") is not None or root.find(".//replicate") is not None \
            or root.find(".//attach") is not None:
        by_name = {e.get("name"): (e, path) for e in root.iter("body") if e.get("name")}
        for included in included_files(path):
            try:
                other, other_spans, other_data = parse_with_spans(included)
            except (MassPropsError, OSError):
                continue
            files_spans[included], files_data[included] = other_spans, other_data
            for e in other.iter("body"):
                if e.get("name") and e.get("name") not in by_name:
                    by_name[e.get("name")] = (e, included)
        matched = {n: by_name.get(n, (None, None)) for n in names if n}
    else:
        elements = list(root.iter("body"))
        matched = {(n or f"body{k + 1}"): (e, path) for k, (n, e) in enumerate(zip(names, elements))} \
            if len(elements) == len(names) else {}
    return {name: (element, element.find("inertial") if element is not None else None, file)
            for name, (element, file) in matched.items()}, files_spans, files_data


def _compiled(spec, path, resolver, mujoco):
    """``(model, files, problems)``: the neutral copy compiled, each mesh's file, and the meshes not found."""
    files, problems = _mesh_files(spec, path, resolver)
    try:
        model = _neutral_copy(spec, mujoco, problems).compile()
    except Exception as exc:  # noqa: BLE001 - MuJoCo raises ValueError with its own message
        raise RobotFormatError(f"MuJoCo cannot compile it: {' '.join(str(exc).split())}", path=path) from None
    return model, files, problems


def _body_geometries(model, spec, files, problems, path, mujoco):
    """``(geometries per body index, errors per body index, geoms of the world body)``."""
    kept, left_out = _spec_geoms_by_compiled(spec, problems, mujoco)
    if len(kept) != model.ngeom:
        raise RobotFormatError(f"MuJoCo compiled {model.ngeom} geoms from {len(kept)}: cannot match them",
                               path=path)
    bodies = list(spec.bodies)
    geometries, errors, counters, world_geoms = {k: [] for k in range(len(bodies))}, {}, {}, 0
    for g, geom in enumerate(kept):
        b = int(model.geom_bodyid[g])
        if b == 0:
            world_geoms += 1
            continue
        geometries[b].append(_geometry(model, g, geom, spec, files, path, counters, b, mujoco))
    for geom in left_out:
        k = next(i for i, body in enumerate(bodies) if body.name == geom.parent.name and body.id == geom.parent.id)
        errors.setdefault(k, []).append(f"geom {geom.name or '(unnamed)'}: {problems[geom.meshname]}")
    return geometries, errors, world_geoms


def _link(k, body, names, model, geometries, errors, elements, files_spans, path):
    element, inertial_element, file = elements.get(names[k], (None, None, None))
    spans = files_spans.get(file) if file else None
    span = spans.get(element) if spans and element is not None else None
    inertial_span = spans.get(inertial_element) if spans and inertial_element is not None else None
    declared = None
    if body.explicitinertial:
        declared = _declared(body, _quat(model.body_iquat[k]), inertial_element, file or path)
        if inertial_span is not None:
            declared = replace(declared, span=(inertial_span.start, inertial_span.end),
                               line=inertial_element.sourceline)
    parent = int(model.body_parentid[k])
    return Link(names[k], tuple(geometries[k]), declared, names[parent] if parent else None,
                Pose(_quat(model.body_quat[k]), np.array(model.body_pos[k])),
                error="; ".join(errors[k]) if k in errors else None, span=(span.start, span.end) if span else None,
                insert_at=span.content if span else None, line=element.sourceline if element is not None else None)


MAX_INCLUDES = 10_000        # <include> elements followed in all; a cycle or a bomb is refused, not expanded


def check_includes(path):
    """Every file an MJCF ``<include file=...>`` names, nested ones too, must be a regular file.

    MuJoCo opens them itself: a named pipe would block it forever, a device
    be read until memory runs out.  Paths are relative to the main file's
    folder (MuJoCo's rule); a missing file is left for MuJoCo to name.
    """
    from lxml import etree

    from ..io.inputs import check_input
    folder = os.path.dirname(os.path.abspath(path))
    pending, seen = [os.path.abspath(path)], set()
    parser = etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True, recover=True)
    while pending:
        current = pending.pop()
        if current in seen:
            continue
        seen.add(current)
        if len(seen) > MAX_INCLUDES:
            raise RobotFormatError(f"the model includes more than {MAX_INCLUDES} files", path=path,
                                   fix="flatten the model's includes")
        try:
            root = etree.parse(current, parser).getroot()
        except (OSError, etree.XMLSyntaxError):
            continue                                    # MuJoCo says what is wrong with it
        if root is None:
            continue
        for include in root.iter("include"):
            name = include.get("file")
            if not name:
                continue
            target = os.path.join(folder, name)
            if not os.path.lexists(target):
                continue
            try:
                check_input(target, what="file")
            except MassPropsError as exc:
                raise RobotFormatError(f"<include file={name!r}>: {exc.problem}", path=path, fix=exc.fix) from None
            pending.append(os.path.abspath(target))


def read_mjcf(path, resolver):
    """Read an MJCF file through MuJoCo into a RobotModel (bodies are the links; the world body is left out)."""
    mujoco = import_mujoco(path)
    path = os.fspath(path)
    check_includes(path)
    try:
        spec = mujoco.MjSpec.from_file(path)
    except Exception as exc:  # noqa: BLE001 - MuJoCo raises ValueError with its own message
        raise RobotFormatError(f"MuJoCo cannot read it: {' '.join(str(exc).split())}", path=path) from None
    model, files, problems = _compiled(spec, path, resolver, mujoco)
    elements, files_spans, files_data = _body_elements(path, spec)
    main = os.path.abspath(path)
    spans, data = files_spans[main], files_data[main]
    geometries, errors, world_geoms = _body_geometries(model, spec, files, problems, path, mujoco)
    bodies = list(spec.bodies)
    names = [_name(b, "body", k) for k, b in enumerate(bodies)]
    links = [_link(k, bodies[k], names, model, geometries, errors, elements, files_spans, path)
             for k in range(1, len(bodies))]
    warnings = []
    if world_geoms:
        warnings.append(f"{world_geoms} geom(s) of the world body (static scenery) are not reported")
    if spec.compiler.inertiafromgeom == mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_TRUE:
        warnings.append("<compiler inertiafromgeom=\"true\">: MuJoCo ignores the declared inertials and computes "
                        "them from the geoms")
    writable = None if spans is not None else "the file's elements could not be located byte by byte"
    # Each link's bytes are in the file that holds its body (an included file for a scene's robot).
    link_files = {name: file for name, (_, _, file) in elements.items() if file and file != main}
    extra = {"sources": {f: d for f, d in files_data.items() if files_spans.get(f) is not None},
             "link_files": link_files}
    return RobotModel(path, "mjcf", spec.modelname or "", tuple(links), tuple(_joints(model, names, mujoco)), data,
                      tuple(warnings), frame="world", writable=writable, extra=extra)


def _geometry(model, g, geom, spec, files, path, counters, body, mujoco):
    kind = _KINDS.get(str(geom.type).rpartition("_")[2].lower(), str(geom.type))
    role = "visual" if geom.contype == 0 and geom.conaffinity == 0 else "collision"
    index = counters.setdefault((body, role), 0)
    counters[(body, role)] = index + 1
    name = geom.name or f"{role}[{index}]"
    where = f"geom {geom.name!r}" if geom.name else f"geom {role}[{index}]"
    mass = None if not math.isfinite(geom.mass) else float(geom.mass)
    base = dict(role=role, name=name, density=float(geom.density), mass=mass, where=where)
    size = np.asarray(model.geom_size[g], dtype=float)
    pose = Pose(_quat(model.geom_quat[g]), np.array(model.geom_pos[g]))
    if geom.typeinertia == mujoco.mjtGeomInertia.mjINERTIA_SHELL:
        return Geometry(f"{kind} with shellinertia", pose=pose, **base)
    if kind == "box":
        return Geometry("box", pose=pose, size={"size": tuple(2 * size)}, **base)
    if kind == "sphere":
        return Geometry("sphere", pose=pose, size={"radius": size[0]}, **base)
    if kind == "ellipsoid":
        return Geometry("ellipsoid", pose=pose, size={"radii": tuple(size)}, **base)
    if kind in ("capsule", "cylinder"):
        return Geometry(kind, pose=pose, size={"radius": size[0], "length": 2 * size[1]}, **base)
    if kind == "mesh":
        spec_mesh = spec.meshes[int(model.geom_dataid[g])]
        mesh_name = spec_mesh.name or os.path.splitext(os.path.basename(spec_mesh.file))[0]
        mesh_pose, scale, stretch = _mesh_geometry(model, g, spec_mesh, files.get(mesh_name), path)
        inline = _inline_mesh(spec_mesh) if not spec_mesh.file else None
        uri = spec_mesh.file or None
        return Geometry("mesh", pose=mesh_pose, uri=uri, scale=tuple(scale) if scale else None, stretch=stretch,
                        mesh=inline, base=_mesh_folder(spec, path), **base)
    return Geometry(kind, pose=pose, **base)


def _joints(model, names, mujoco):
    joints = []
    for j in range(model.njnt):
        kind = _JOINTS[str(mujoco.mjtJoint(model.jnt_type[j])).rpartition("_")[2].lower()]
        body = int(model.jnt_bodyid[j])
        parent = int(model.body_parentid[body])
        name = model.joint(j).name or f"joint{j}"
        reference = float(model.qpos0[model.jnt_qposadr[j]]) if kind in ("hinge", "slide") else 0.0
        axis = np.array(model.jnt_axis[j], dtype=float)
        joints.append(Joint(name, kind, names[parent] if parent else "world", names[body], axis,
                            np.array(model.jnt_pos[j], dtype=float), reference))
    return joints
