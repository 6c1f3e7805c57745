"""URDF (and xacro) into a :class:`massprops.robot.model.RobotModel`.

Conventions, as urdfdom reads them (``urdf_parser/src/pose.cpp``, ``link.cpp``):
``<origin xyz rpy>`` places a child frame in its parent, ``R = Rz(y) Ry(p)
Rx(r)`` (radians); ``<inertial><origin>`` is the inertial frame, whose origin
is the center of mass and whose axes the six ``<inertia>`` attributes are
written in; ``ixy`` etc. are the tensor's own elements (``−∫ x y dm``); a
joint's ``<origin>`` places the joint frame (= the child link frame) in the
parent link frame, and ``<axis xyz>`` (default ``1 0 0``) is in the joint
frame.  Box ``size`` is the three edge lengths, cylinder ``length`` the whole
height along z; a mesh ``scale`` multiplies its coordinates per axis.
``<capsule radius length>`` (not in urdfdom; pybullet and Drake read it) has
``length`` the cylindrical part.
"""

from __future__ import annotations

import os
from fractions import Fraction

import numpy as np

from ..model.errors import MassPropsError
from ..model.frames import Pose
from .model import ELEMENTS, Decimal, Geometry, Inertial, Joint, Link, RobotFormatError, RobotModel, \
    rpy_rotation, tensor_from_elements
from .geometry import NO_VOLUME
from .xmlspans import line_of, parse_numbers, parse_with_spans, the_shape

__all__ = ["read_urdf"]


def _origin(element, path, what):
    """The Pose of an ``<origin>`` child (identity when absent), and its rpy."""
    origin = element.find("origin")
    if origin is None:
        return Pose(), (0.0, 0.0, 0.0)
    xyz = [d.value for d in parse_numbers(origin.get("xyz", "0 0 0"), 3, what=f"{what} origin xyz", path=path)]
    rpy = tuple(d.value for d in parse_numbers(origin.get("rpy", "0 0 0"), 3, what=f"{what} origin rpy", path=path))
    return Pose(rpy_rotation(rpy), np.array(xyz)), rpy


def _inertial(element, path, spans):
    where = f"<inertial>{line_of(element)}"
    pose, rpy = _origin(element, path, where)
    mass_element = element.find("mass")
    if mass_element is None or mass_element.get("value") is None:
        raise RobotFormatError(f"{where}: no <mass value=...>", path=path, fix="give the link's mass in kg")
    mass = Decimal.parse(mass_element.get("value"), what=f"{where} mass", path=path)
    inertia = element.find("inertia")
    if inertia is None:
        raise RobotFormatError(f"{where}: no <inertia>", path=path, fix="give ixx ixy ixz iyy iyz izz")
    missing = [name for name in ELEMENTS if inertia.get(name) is None]
    if missing:
        raise RobotFormatError(f"{where}: <inertia> has no {', '.join(missing)}", path=path,
                               fix="give all six of ixx ixy ixz iyy iyz izz")
    written = {name: Decimal.parse(inertia.get(name), what=f"{where} {name}", path=path) for name in ELEMENTS}
    tensor = tensor_from_elements({k: v.value for k, v in written.items()})
    rotation = pose.rotation
    span = spans.get(element) if spans else None
    return Inertial(mass, pose.translation, rotation @ tensor @ rotation.T, rotation, written, rpy,
                    span=(span.start, span.end) if span else None, line=element.sourceline)


def _scale(text, where, path):
    if text is None:
        return None
    values = parse_numbers(text, 3, what=f"{where} mesh scale", path=path)
    return tuple(d.exact if d.exact is not None else Fraction(d.value) for d in values)


def _geometry(element, role, index, path):
    name = element.get("name")
    where = f"{role} {name!r}{line_of(element)}" if name else f"{role}[{index}]{line_of(element)}"
    pose, _ = _origin(element, path, where)
    shape = the_shape(element, where, path)
    kind = shape.tag

    def number(attribute):
        text = shape.get(attribute)
        if text is None:
            raise RobotFormatError(f"{where}: <{kind}> has no {attribute}", path=path)
        return Decimal.parse(text, what=f"{where} {kind} {attribute}", path=path).value

    if kind == "box":
        size = {"size": tuple(d.value for d in parse_numbers(shape.get("size"), 3, what=f"{where} box size",
                                                             path=path))}
    elif kind == "sphere":
        size = {"radius": number("radius")}
    elif kind in ("cylinder", "capsule"):
        size = {"radius": number("radius"), "length": number("length")}
    elif kind == "mesh":
        uri = shape.get("filename")
        if not uri:
            raise RobotFormatError(f"{where}: <mesh> has no filename", path=path)
        return Geometry("mesh", role, name or f"{role}[{index}]", pose, uri=uri,
                        scale=_scale(shape.get("scale"), where, path), where=where)
    elif kind in NO_VOLUME:                 # pybullet's <plane normal=...>: no volume, left out with a warning
        return Geometry(kind, role, name or f"{role}[{index}]", pose, where=where)
    else:
        raise RobotFormatError(f"{where}: unknown geometry <{kind}>", path=path,
                               fix="use box, cylinder, sphere, capsule or mesh")
    return Geometry(kind, role, name or f"{role}[{index}]", pose, size, where=where)


def _link(element, path, spans):
    name = element.get("name")
    span = spans.get(element) if spans else None
    geometries, error, declared = [], None, None
    try:
        inertials = element.findall("inertial")
        if len(inertials) > 1:
            raise RobotFormatError(f"link {name!r} has {len(inertials)} <inertial> elements", path=path,
                                   fix="keep one")
        declared = _inertial(inertials[0], path, spans) if inertials else None
        for role in ("collision", "visual"):
            for k, child in enumerate(element.findall(role)):
                geometries.append(_geometry(child, role, k, path))
    except MassPropsError as exc:
        error = exc.problem + (f" — {exc.fix}" if exc.fix else "")
    return Link(name, tuple(geometries), declared, error=error, span=(span.start, span.end) if span else None,
                insert_at=span.content if span else None, line=element.sourceline)


def _joint(element, path):
    name = element.get("name")
    where = f"joint {name!r}{line_of(element)}"
    kind = element.get("type")
    parent, child = element.find("parent"), element.find("child")
    if kind is None or parent is None or child is None or not parent.get("link") or not child.get("link"):
        raise RobotFormatError(f"{where}: needs a type, <parent link=...> and <child link=...>", path=path)
    pose, _ = _origin(element, path, where)
    axis_element = element.find("axis")
    axis = np.array([1.0, 0.0, 0.0]) if axis_element is None else np.array(
        [d.value for d in parse_numbers(axis_element.get("xyz", "1 0 0"), 3, what=f"{where} axis", path=path)])
    norm = float(np.linalg.norm(axis))
    if kind not in ("fixed", "floating", "planar") and not norm > 0:
        raise RobotFormatError(f"{where}: axis is zero", path=path, fix="give a non-zero axis xyz")
    return Joint(name, kind, parent.get("link"), child.get("link"), axis / norm if norm else axis), pose


def read_urdf(path, *, data=None, writable=None, resolver=None):
    """Read a URDF file (or its text ``data``) into a RobotModel.

    A link whose elements cannot be read gets ``Link.error`` (the others are
    still read); a malformed file or joint raises :class:`RobotFormatError`.
    """
    root, spans, data = parse_with_spans(path, data=data)
    if root.tag != "robot":
        raise RobotFormatError(f"the root element is <{root.tag}>, not <robot>", path=path)
    if spans is None and writable is None:
        writable = "the file's elements could not be located byte by byte (entities?)"
    links = [_link(e, path, spans) for e in root.findall("link")]
    names = [link.name for link in links]
    duplicates = sorted({n for n in names if names.count(n) > 1})
    if duplicates:
        raise RobotFormatError(f"link names are not unique: {', '.join(map(repr, duplicates))}", path=path)
    joints, placed, warnings, broken = [], {}, [], []
    for element in root.findall("joint"):
        # A joint that cannot be read leaves its child unplaced: the links are still checked, the total is not.
        try:
            joint, pose = _joint(element, path)
            for end in (joint.parent, joint.child):
                if end not in names:
                    raise RobotFormatError(f"joint {joint.name!r} names link {end!r}, which does not exist")
            if joint.child in placed:
                raise RobotFormatError(f"link {joint.child!r} is the child of two joints")
        except MassPropsError as exc:
            broken.append(element.get("name"))
            warnings.append(exc.problem)
            continue
        placed[joint.child] = (joint.parent, pose)
        joints.append(joint)
    links = [_placed(link, placed) for link in links]
    roots = [link.name for link in links if link.parent is None]
    if len(roots) != 1 and not broken:
        warnings.append(f"{len(roots)} root links ({', '.join(roots[:5])}): the robot's total is given in the "
                        "model frame (the root links' frames at the origin)")
    return RobotModel(os.fspath(path), "urdf", root.get("name", ""), tuple(links), tuple(joints), data,
                      tuple(warnings), frame=roots[0] if len(roots) == 1 else "model", writable=writable,
                      extra={"broken_joints": broken} if broken else {})


def _placed(link, placed):
    if link.name not in placed:
        return link
    parent, pose = placed[link.name]
    from dataclasses import replace
    return replace(link, parent=parent, pose_in_parent=pose)
