"""The in-memory robot model every format reader produces: links, their geometry and declared inertials, joints.

Frames (see :mod:`massprops.model.frames`): a pose maps a point of the inner frame
to the outer one, ``x = A x' + t``.  A geometry's ``pose`` is in its link's
frame; a declared inertial's ``center_of_mass`` and ``inertia_com`` are in the
link frame and link axes (the format's own inertial frame already applied);
a link's ``pose_in_parent`` is where its frame sits in its parent link's frame
with every joint at zero (a link without a parent sits in the model frame).

Lengths are metres, masses kilograms, inertias kg·m² (the formats' SI).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from ..model.errors import MassPropsError
from ..model.frames import Pose

__all__ = ["Geometry", "Inertial", "Link", "Joint", "RobotModel", "RobotFormatError", "Decimal",
           "rpy_rotation", "rotation_rpy", "tensor_from_elements", "ELEMENTS", "PRIMITIVES"]

# Inertia elements in the order URDF and SDF name them.
ELEMENTS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
_INDEX = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}
PRIMITIVES = ("box", "cylinder", "sphere", "capsule", "ellipsoid", "cone")


class RobotFormatError(MassPropsError, ValueError):
    """A robot description is malformed or uses something massprops does not read."""


@dataclass(frozen=True)
class Decimal:
    """A number as written in the file: its text, its float, and its exact decimal value.

    ``half_unit`` is half a unit in the last written digit: the written value is
    the rounding of any value within ``± half_unit`` of it.
    """

    text: str
    value: float

    @classmethod
    def parse(cls, text, *, what, path=None):
        text = text.strip()
        try:
            value = float(text)
        except ValueError:
            raise RobotFormatError(f"{what}: {text!r} is not a number", path=path) from None
        return cls(text, value)

    @classmethod
    def of(cls, value):
        """A number that was not written (a default, or a value computed by a compiler)."""
        return cls(repr(float(value)), float(value))

    @property
    def exact(self):
        try:
            return Fraction(self.text)
        except (ValueError, ZeroDivisionError):
            return Fraction(self.value) if math.isfinite(self.value) else None

    @property
    def half_unit(self):
        """Half a unit in the last written digit: 0 for zero, an integer, or a value not written in decimal."""
        match = re.fullmatch(r"[+-]?(\d*)(?:\.(\d*))?(?:[eE]([+-]?\d+))?", self.text)
        if not match or not (match.group(1) or match.group(2)):
            return Fraction(0)
        if self.value == 0 or (match.group(2) is None and match.group(3) is None):
            return Fraction(0)          # a zero (a symmetry) or an integer is taken as exact
        digits_after = len(match.group(2) or "")
        exponent = int(match.group(3) or 0)
        return Fraction(1, 2) * Fraction(10) ** (exponent - digits_after)


def rpy_rotation(rpy):
    """``R = Rz(y) Ry(p) Rx(r)`` (URDF and SDF ``rpy``: fixed axes x, then y, then z; radians)."""
    return Pose.from_euler("xyz", list(rpy), degrees=False).rotation


def rotation_rpy(rotation):
    """``(r, p, y)`` with ``rpy_rotation((r, p, y)) == rotation`` (p in [−π/2, π/2])."""
    a = np.asarray(rotation, dtype=float)
    pitch = math.asin(max(-1.0, min(1.0, -a[2, 0])))
    if abs(a[2, 0]) < 1 - 1e-12:
        return math.atan2(a[2, 1], a[2, 2]), pitch, math.atan2(a[1, 0], a[0, 0])
    # Gimbal lock: roll and yaw share one axis; put it all in yaw.
    return 0.0, pitch, math.atan2(-a[0, 1], a[1, 1])


def tensor_from_elements(elements):
    """The symmetric 3×3 tensor of ``{"ixx": .., "ixy": .., ...}`` (floats): ``ixy`` is ``J_xy`` itself."""
    tensor = np.zeros((3, 3))
    for name, (i, j) in _INDEX.items():
        tensor[i, j] = tensor[j, i] = float(elements[name])
    return tensor


@dataclass(frozen=True, eq=False)
class Geometry:
    """One collision or visual geometry of a link.

    Attributes
    ----------
    kind : str
        ``box``, ``cylinder``, ``sphere``, ``capsule``, ``ellipsoid``, ``cone``,
        ``mesh``, or one massprops gives no volume (``plane``, ``heightfield``, ...).
    role : {"collision", "visual"}
    name : str
        The element's name, else ``ROLE[k]`` (k counts the link's elements of that role from 0).
    pose : Pose
        The geometry's frame in the link frame.
    size : dict of str to float
        The primitive's dimensions in the *full-length* convention: box ``size``
        (3 edge lengths), ``radius``, ``length`` (cylinder, cone: the whole
        height; capsule: the cylindrical part), ellipsoid ``radii``.  Readers
        convert half-lengths (MJCF) to these.
    uri : str or None
        A mesh's URI as written.
    scale : tuple of 3 numbers or None
        A mesh's scale (may be non-uniform or negative; Fractions when read from
        decimals, so 0.001 is 1/1000); None when not written.
    stretch : ndarray, shape (3, 3), or None
        A general linear map applied to a mesh's coordinates instead of ``scale``
        (MJCF ``refquat`` with ``scale``).
    density, mass : float or None
        Given by the format for this geometry (SDF collision ``<density>``,
        MJCF geom ``density``/``mass``).
    mesh : TriangleMesh or None
        Inline mesh data (MJCF ``<mesh vertex=... face=...>``).
    base : str or None
        Folder that a relative ``uri`` is resolved against (default: the model file's).
    where : str
        How to find the element in the file, for messages (``collision 'c1' (line 12)``).
    """

    kind: str
    role: str
    name: str
    pose: Pose = field(default_factory=Pose)
    size: dict = field(default_factory=dict)
    uri: str | None = None
    scale: tuple | None = None
    stretch: np.ndarray | None = None
    density: float | None = None
    mass: float | None = None
    mesh: object = None
    base: str | None = None
    where: str = ""


@dataclass(frozen=True, eq=False)
class Inertial:
    """A link's inertial as declared in the file.

    Attributes
    ----------
    mass : Decimal
    center_of_mass : ndarray, shape (3,)
        Link frame.
    inertia_com : ndarray, shape (3, 3)
        About the center of mass, link axes: ``R J_written Rᵀ``.
    rotation : ndarray, shape (3, 3)
        ``R``: the axes the tensor was written in, in link axes.
    written : dict of str to Decimal
        The six elements as written (``ixx ...``), in the written axes.  For a
        tensor given by principal moments (MJCF ``diaginertia``) the off-diagonal ones are 0.
    rpy : tuple or None
        The written ``rpy`` (radians), when the format writes one.
    auto : bool
        SDF ``<inertial auto="true">``: the numbers are sdformat's, computed from the collisions.
    span : tuple or None
        ``(start, end)`` byte offsets of the ``<inertial>`` element in the file.
    line : int or None
    """

    mass: Decimal
    center_of_mass: np.ndarray
    inertia_com: np.ndarray
    rotation: np.ndarray
    written: dict
    rpy: tuple | None = None
    auto: bool = False
    span: tuple | None = None
    line: int | None = None


@dataclass(frozen=True, eq=False)
class Link:
    """A rigid body: its geometries, its declared inertial and where its frame sits.

    ``span`` is the link element's byte range and ``insert_at`` the offset where
    a new ``<inertial>`` goes (after the start tag), for :mod:`massprops.robot.write`.
    """

    name: str
    geometries: tuple = ()
    declared: Inertial | None = None
    parent: str | None = None
    pose_in_parent: Pose = field(default_factory=Pose)
    error: str | None = None
    span: tuple | None = None
    insert_at: int | None = None
    line: int | None = None

    def chosen(self, which):
        """The geometries ``which`` selects: ``collision``, ``visual``, or ``auto`` (collision if any, else visual)."""
        collision = tuple(g for g in self.geometries if g.role == "collision")
        visual = tuple(g for g in self.geometries if g.role == "visual")
        if which == "collision":
            return collision
        if which == "visual":
            return visual
        return collision or visual


@dataclass(frozen=True, eq=False)
class Joint:
    """A joint moving ``child`` relative to ``parent``.

    The motion is about (or along) ``axis`` through ``point``, both in the
    child link's frame at zero: the child's pose in its parent at value ``q`` is
    ``pose_in_parent ∘ T(point) M(axis, q − reference) T(−point)`` with ``M``
    a rotation (revolute, continuous, hinge) or a translation (prismatic, slide).
    Other types (fixed, floating, planar, ball, free) take no value.
    """

    name: str
    type: str
    parent: str
    child: str
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    point: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reference: float = 0.0

    @property
    def moves(self):
        return self.type in ("revolute", "continuous", "hinge", "prismatic", "slide")

    @property
    def rotates(self):
        return self.type in ("revolute", "continuous", "hinge")


@dataclass(frozen=True, eq=False)
class RobotModel:
    """A robot description as read: links in file order, joints, and what the reader noticed.

    ``source`` is the file's bytes (for :mod:`massprops.robot.write`); ``frame``
    names the frame the robot's total is expressed in.
    """

    path: str
    format: str
    name: str
    links: tuple
    joints: tuple = ()
    source: bytes = b""
    warnings: tuple = ()
    frame: str = ""
    writable: str | None = None
    extra: dict = field(default_factory=dict)

    def link(self, name):
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(name)
