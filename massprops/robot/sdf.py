"""SDFormat into a :class:`massprops.robot.model.RobotModel`.

Conventions (sdformat's spec files ``sdf/1.12/pose.sdf``, ``inertial.sdf``,
``collision.sdf``, ``geometry.sdf`` and the pose-frame-semantics proposal):

* ``<pose>x y z r p y</pose>`` with ``R = Rz(y) Ry(p) Rx(r)``; ``degrees="true"``
  reads the angles in degrees; ``rotation_format="quat_xyzw"`` takes 7 numbers,
  ``x y z qx qy qz qw`` (scalar *last*).
* ``relative_to`` names the frame a pose is expressed in; without it, a link's
  pose is in the model frame, a joint's in its child link's frame, a
  collision's, visual's or inertial's in its link's frame, a ``<frame>``'s in
  the frame it is ``attached_to``, a nested model's in its parent model's.
  Before SDFormat 1.7, ``<pose frame="...">`` plays the part of ``relative_to``.
* ``<inertial><pose>`` is the center-of-mass frame C in the link frame; the
  ``<inertia>`` elements are about C's origin in C's axes, ``ixy = −∫ x y dm``.
  Missing elements take sdformat's defaults (mass 1, ``ixx = iyy = izz = 1``);
  a link without ``<inertial>`` gets those too, silently, in sdformat: here it is ``missing``.
* ``<inertial auto="true">``: sdformat computes the inertial from the
  collisions (density: ``<collision><density>``, else ``<inertial><density>``,
  else 1000 kg/m³) and, when ``<mass>`` is given, scales it to that mass.
* Geometry sizes: box ``size`` edge lengths; cylinder, cone ``length`` the
  whole height (the cone's base at ``z = −L/2``); capsule ``length`` the
  cylindrical part; ellipsoid ``radii``; mesh ``<scale>``.
* A joint's ``<axis><xyz>`` is in the joint frame (``expressed_in`` may name
  another frame; before 1.7, ``use_parent_model_frame`` the model frame).
"""

from __future__ import annotations

import math
import os
from dataclasses import replace

import numpy as np

from ..model.errors import MassPropsError
from ..model.frames import Pose
from .model import ELEMENTS, Decimal, Geometry, Inertial, Joint, Link, RobotFormatError, RobotModel, \
    rpy_rotation, tensor_from_elements
from .geometry import NO_VOLUME
from .xmlspans import line_of, parse_numbers, parse_with_spans, the_shape

__all__ = ["read_sdf", "parse_pose"]

_MODEL_FRAME = "__model__"
MAX_INCLUDE_DEPTH = 100       # far beyond real models; a chain of includes is refused, not recursed into


def parse_pose(element, path, what):
    """The Pose a ``<pose>`` element writes (identity for None)."""
    if element is None:
        return Pose()
    tokens = (element.text or "").split()
    form = element.get("rotation_format", "euler_rpy")
    degrees = (element.get("degrees") or "false").strip().lower() in ("true", "1")
    expected = 7 if form == "quat_xyzw" else 6
    if form not in ("euler_rpy", "quat_xyzw"):
        raise RobotFormatError(f"{what}: rotation_format {form!r} is not known", path=path,
                               fix="use euler_rpy or quat_xyzw")
    if not tokens:
        return Pose()
    if len(tokens) != expected:
        raise RobotFormatError(f"{what}: <pose> needs {expected} numbers ({form}), got {len(tokens)}", path=path)
    values = [Decimal.parse(t, what=f"{what} pose", path=path).value for t in tokens]
    if form == "quat_xyzw":
        return Pose.from_quat(values[3:], scalar_first=False, translation=values[:3])
    angles = [math.radians(v) for v in values[3:]] if degrees else values[3:]
    return Pose(rpy_rotation(angles), np.array(values[:3]))


def _relative_to(pose_element):
    if pose_element is None:
        return None
    return pose_element.get("relative_to") or pose_element.get("frame") or None


class _Frames:
    """The frames of one model (nested models flattened with ``::``) and their poses in the model frame."""

    def __init__(self, path):
        self.path = path
        self.entries = {_MODEL_FRAME: (None, Pose())}
        self.poses = {_MODEL_FRAME: Pose()}

    def add(self, name, relative_to, pose):
        if name in self.entries:
            raise RobotFormatError(f"the name {name!r} is used twice in one model", path=self.path)
        self.entries[name] = (relative_to, pose)

    def pose(self, name, chain=()):
        if name in self.poses:
            return self.poses[name]
        if name not in self.entries:
            raise RobotFormatError(f"a pose is relative to {name!r}, which is no frame of the model", path=self.path)
        if name in chain:
            raise RobotFormatError(f"poses refer to each other in a cycle: {' -> '.join((*chain, name))}",
                                   path=self.path)
        relative_to, pose = self.entries[name]
        self.poses[name] = self.pose(relative_to, (*chain, name)).compose(pose)
        return self.poses[name]


class _Reader:
    """Reads one SDF file's models; included models are read from their own files."""

    def __init__(self, path, resolver, spans, main=True, chain=()):
        self.path, self.resolver, self.spans, self.main = path, resolver, spans, main
        self.chain = chain or (os.path.realpath(path),)       # the files including this one, outermost first
        self.links, self.joints, self.warnings = [], [], []

    def model(self, element, frames, scope, outer_default, version):
        """Read ``element`` (a <model>) into ``frames`` under ``scope`` ("" or "a::b::")."""
        here = scope[:-2] if scope else _MODEL_FRAME

        def name_in(name):
            if name is None or name == _MODEL_FRAME:
                return here
            return scope + name

        for link in element.findall("link"):
            pose_element = link.find("pose")
            frames.add(scope + link.get("name"), name_in(_relative_to(pose_element)),
                       parse_pose(pose_element, self.path, f"link {link.get('name')!r}"))
        for nested in element.findall("model"):
            self._nested(nested, frames, scope, name_in, version)
        for include in element.findall("include"):
            self._include(include, frames, scope, name_in)
        for joint in element.findall("joint"):
            pose_element = joint.find("pose")
            child = (joint.findtext("child") or "").strip()
            frames.add(scope + joint.get("name"), name_in(_relative_to(pose_element) or child),
                       parse_pose(pose_element, self.path, f"joint {joint.get('name')!r}"))
        for frame in element.findall("frame"):
            pose_element = frame.find("pose")
            attached = frame.get("attached_to") or None
            frames.add(scope + frame.get("name"), name_in(_relative_to(pose_element) or attached),
                       parse_pose(pose_element, self.path, f"frame {frame.get('name')!r}"))
        for link in element.findall("link"):
            self.links.append((scope, link, self))
        for joint in element.findall("joint"):
            self.joints.append((scope, joint, version))

    def _nested(self, nested, frames, scope, name_in, version):
        pose_element = nested.find("pose")
        name = scope + nested.get("name")
        frames.add(name, name_in(_relative_to(pose_element)), parse_pose(pose_element, self.path,
                                                                         f"model {nested.get('name')!r}"))
        if nested.get("placement_frame"):
            self.warnings.append(f"model {name!r}: placement_frame is not applied (its pose is taken as the "
                                 "model frame's)")
        self.model(nested, frames, name + "::", name, version)

    def _include(self, include, frames, scope, name_in):
        uri = (include.findtext("uri") or "").strip()
        folder = self._model_folder(uri)
        file = _model_file(folder)
        self._check_include(uri, file)
        root, spans, _ = parse_with_spans(file)
        model = root.find("model")
        if model is None:
            raise RobotFormatError(f"included {uri!r}: {file} holds no <model>", path=self.path)
        name = (include.findtext("name") or model.get("name")).strip()
        pose_element = include.find("pose")
        frames.add(scope + name, name_in(_relative_to(pose_element)),
                   parse_pose(pose_element, self.path, f"include {uri!r}"))
        inner = _Reader(file, self.resolver, spans, main=False, chain=self.chain + (os.path.realpath(file),))
        inner.model(model, frames, scope + name + "::", scope + name, root.get("version", "1.12"))
        self.links += inner.links
        self.joints += inner.joints
        self.warnings += inner.warnings

    def _check_include(self, uri, file):
        """Refuse an include that is not a regular file, that includes itself, or that nests too deep."""
        from ..io.inputs import check_input
        try:
            check_input(file, what="SDF file")
        except MassPropsError as exc:
            raise RobotFormatError(f"included {uri!r}: {file} {exc.problem}", path=self.path, fix=exc.fix) from None
        if os.path.realpath(file) in self.chain:
            cycle = " → ".join(os.path.basename(f) for f in self.chain + (os.path.realpath(file),))
            raise RobotFormatError(f"included {uri!r} includes itself ({cycle})", path=self.path,
                                   fix="remove the <include> that closes the cycle")
        if len(self.chain) > MAX_INCLUDE_DEPTH:
            raise RobotFormatError(f"included {uri!r} is nested more than {MAX_INCLUDE_DEPTH} includes deep",
                                   path=self.path, fix="flatten the model's includes")

    def _model_folder(self, uri):
        if uri.startswith("model://") or "://" not in uri:
            resolution = self.resolver.resolve(uri.rstrip("/") + "/model.config", base=os.path.dirname(
                os.path.abspath(self.path)))
            if resolution.path is not None:
                return os.path.dirname(resolution.path)
        raise RobotFormatError(f"included model {uri!r} not found", path=self.path,
                               fix="set GZ_SIM_RESOURCE_PATH or give {package}")


def _model_file(folder):
    """The SDF file a model folder's ``model.config`` names (the newest version listed), else ``model.sdf``."""
    from lxml import etree
    config = os.path.join(folder, "model.config")
    best = None
    try:
        tree = etree.parse(config)
        for sdf in tree.getroot().findall("sdf"):
            version = tuple(int(x) for x in (sdf.get("version") or "0").split(".") if x.isdigit())
            if best is None or version > best[0]:
                best = (version, (sdf.text or "").strip())
    except (OSError, etree.XMLSyntaxError):
        pass
    return os.path.join(folder, best[1] if best and best[1] else "model.sdf")


def _number(element, name, default, path, what, warnings=None):
    child = element.find(name) if element is not None else None
    if child is None or not (child.text or "").strip():
        if warnings is not None and default is not None:
            warnings.append(f"{what}: no <{name}>: sdformat's default {default:g} used")
        return None if default is None else Decimal.of(default)
    return Decimal.parse(child.text, what=f"{what} <{name}>", path=path)


def _geometry(element, role, index, frames, link_name, scope, path, link_density):
    name = element.get("name") or f"{role}[{index}]"
    where = f"{role} {name!r}{line_of(element)}"
    pose_element = element.find("pose")
    relative_to = _relative_to(pose_element)
    pose = parse_pose(pose_element, path, where)
    if relative_to is not None:
        pose = frames.pose(link_name).inverse().compose(frames.pose(scope + relative_to).compose(pose))
    shape = the_shape(element, where, path)
    kind = shape.tag
    density = _number(element, "density", None, path, where) if role == "collision" else None
    density = density.value if density is not None else link_density

    def vector(tag, count):
        text = shape.findtext(tag)
        values = (text or "").split()
        if len(values) != count:
            raise RobotFormatError(f"{where}: <{kind}><{tag}> needs {count} numbers", path=path)
        return tuple(Decimal.parse(v, what=f"{where} {tag}", path=path).value for v in values)

    def scalar(tag):
        return vector(tag, 1)[0]

    base = dict(role=role, name=name, pose=pose, density=density, where=where)
    if kind == "box":
        return Geometry("box", size={"size": vector("size", 3)}, **base)
    if kind == "sphere":
        return Geometry("sphere", size={"radius": scalar("radius")}, **base)
    if kind in ("cylinder", "capsule", "cone"):
        return Geometry(kind, size={"radius": scalar("radius"), "length": scalar("length")}, **base)
    if kind == "ellipsoid":
        return Geometry("ellipsoid", size={"radii": vector("radii", 3)}, **base)
    if kind == "mesh":
        uri = (shape.findtext("uri") or "").strip()
        if shape.find("submesh") is not None:
            raise RobotFormatError(f"{where}: <submesh> is not supported", path=path,
                                   fix="export the submesh as its own file")
        scale = None
        if shape.find("scale") is not None:
            scale = tuple(d.exact for d in parse_numbers(shape.findtext("scale"), 3, what=f"{where} scale",
                                                         path=path))
        return Geometry("mesh", uri=uri, scale=scale, base=os.path.dirname(os.path.abspath(path)), **base)
    if kind in NO_VOLUME:
        return Geometry(kind, **base)
    raise RobotFormatError(f"{where}: unknown geometry <{kind}>", path=path)


def _inertial(element, link_name, path, spans, warnings):
    where = f"link {link_name!r} <inertial>{line_of(element)}"
    auto = (element.get("auto") or "false").strip().lower() in ("true", "1")
    span = spans.get(element) if spans else None
    span = (span.start, span.end) if span else None
    pose_element = element.find("pose")
    if _relative_to(pose_element):
        warnings.append(f"{where}: the inertial pose's relative_to is ignored (it is relative to the link)")
    pose = parse_pose(pose_element, path, where)
    if auto:
        mass = _number(element, "mass", None, path, where)
        return Inertial(mass, None, None, pose.rotation, {}, auto=True, span=span, line=element.sourceline)
    mass = _number(element, "mass", 1.0, path, where, warnings)
    inertia = element.find("inertia")
    defaults = {"ixx": 1.0, "iyy": 1.0, "izz": 1.0, "ixy": 0.0, "ixz": 0.0, "iyz": 0.0}
    written = {name: _number(inertia, name, defaults[name], path, where,
                             warnings if inertia is not None else None) for name in ELEMENTS}
    if inertia is None:
        warnings.append(f"{where}: no <inertia>: sdformat's default (ixx = iyy = izz = 1) used")
    tensor = tensor_from_elements({k: v.value for k, v in written.items()})
    rotation = pose.rotation
    return Inertial(mass, pose.translation, rotation @ tensor @ rotation.T, rotation, written,
                    span=span, line=element.sourceline)


def _link(scope, element, reader, frames):
    name = scope + element.get("name")
    path, spans = reader.path, reader.spans
    span = spans.get(element) if spans and reader.main else None
    geometries, declared, error, warnings = [], None, None, []
    try:
        inertial = element.find("inertial")
        link_density = None
        if inertial is not None:
            declared = _inertial(inertial, name, path, spans if reader.main else None, warnings)
            found = _number(inertial, "density", None, path, name)
            link_density = found.value if found is not None else None
        for role in ("collision", "visual"):
            for k, child in enumerate(element.findall(role)):
                geometries.append(_geometry(child, role, k, frames, name, scope, path,
                                            link_density if role == "collision" else None))
    except MassPropsError as exc:
        error = exc.problem + (f" — {exc.fix}" if exc.fix else "")
    link = Link(name, tuple(geometries), declared, error=error, span=(span.start, span.end) if span else None,
                insert_at=span.content if span else None, line=element.sourceline)
    return link, warnings


def _axis(joint, frames, scope, name, child, path, version):
    axis = joint.find("axis")
    xyz = axis.find("xyz") if axis is not None else None
    if xyz is None:
        return np.array([0.0, 0.0, 1.0])
    vector = np.array([d.value for d in parse_numbers(xyz.text, 3, what=f"joint {name!r} axis", path=path)])
    norm = float(np.linalg.norm(vector))
    if not norm > 0:
        raise RobotFormatError(f"joint {name!r}: axis is zero", path=path)
    vector = vector / norm
    expressed = xyz.get("expressed_in")
    legacy = (axis.findtext("use_parent_model_frame") or "").strip().lower() in ("true", "1")
    joint_frame = frames.pose(scope + name)
    if expressed:
        return joint_frame.rotation.T @ frames.pose(scope + expressed).rotation @ vector
    if legacy and _version(version) < (1, 7):
        return joint_frame.rotation.T @ vector
    return vector


def _version(text):
    try:
        return tuple(int(x) for x in text.split("."))
    except (ValueError, AttributeError):
        return (1, 12)


def read_sdf(path, resolver):
    """Read an SDF file: its model (or every model of a world) with nested and included models flattened."""
    root, spans, data = parse_with_spans(path)
    if root.tag != "sdf":
        raise RobotFormatError(f"the root element is <{root.tag}>, not <sdf>", path=path)
    version = root.get("version", "1.12")
    reader = _Reader(os.fspath(path), resolver, spans)
    models = root.findall("model")
    world = root.find("world")
    frame = "model"
    top = [(m, m.get("name")) for m in models]
    if world is not None:
        top += [(m, m.get("name")) for m in world.findall("model")]
        frame = "world"
    frames = _Frames(path)
    if len(top) == 1 and world is None:
        reader.model(top[0][0], frames, "", _MODEL_FRAME, version)
        name = top[0][1]
    else:
        for element, model_name in top:
            reader._nested(element, frames, "", lambda n: _MODEL_FRAME if n in (None, _MODEL_FRAME) else n,
                           version)
        for include in world.findall("include") if world is not None else ():
            reader._include(include, frames, "", lambda n: _MODEL_FRAME if n in (None, _MODEL_FRAME) else n)
        name = world.get("name", "") if world is not None else ""
    if not reader.links:
        raise RobotFormatError("no <model> with links in the file", path=path)
    links, warnings = [], list(reader.warnings)
    for scope, element, owner in reader.links:
        link, said = _link(scope, element, owner, frames)
        links.append(link)
        warnings += said
    links, joints, loops = _joined(links, reader.joints, frames, path)
    warnings += loops
    return RobotModel(os.fspath(path), "sdf", name or "", tuple(links), tuple(joints), data, tuple(warnings),
                      frame=frame, writable=None if spans is not None else "the file's elements could not be "
                                                                            "located byte by byte")


def _joined(links, joint_elements, frames, path):
    """Joints from their elements, and each link's parent and pose in it (model-frame poses made relative)."""
    names = {link.name for link in links}
    parents, joints, loops = {}, [], []
    for scope, element, version in joint_elements:
        name = element.get("name")
        parent = scope + (element.findtext("parent") or "").strip() if (element.findtext("parent") or "").strip() \
            not in ("world", "") else None
        child = scope + (element.findtext("child") or "").strip()
        if child not in names or (parent is not None and parent not in names):
            missing = child if child not in names else parent
            raise RobotFormatError(f"joint {scope + name!r} names link {missing!r}, which does not exist", path=path)
        kind = element.get("type", "fixed")
        child_pose = frames.pose(child)
        point = child_pose.inverse().compose(frames.pose(scope + name)).translation
        axis = child_pose.rotation.T @ frames.pose(scope + name).rotation @ _axis(element, frames, scope, name,
                                                                                child, path, version)
        if parent is not None and child in parents:
            # A kinematic loop (SDF allows them): the link keeps the pose the file gives it; this joint is not
            # followed when the robot is posed.
            loops.append(f"joint {scope + name!r} closes a kinematic loop (link {child!r} already has a parent): "
                         "it is not followed for {joints}")
            continue
        joints.append(Joint(scope + name, kind, parent or "world", child, axis, point))
        if parent is not None:
            parents[child] = parent
    placed = []
    for link in links:
        pose = frames.pose(link.name)
        parent = parents.get(link.name)
        if parent is not None:
            pose = frames.pose(parent).inverse().compose(pose)
        placed.append(replace(link, parent=parent, pose_in_parent=pose))
    return placed, joints, loops
