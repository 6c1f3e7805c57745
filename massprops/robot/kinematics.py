"""The whole robot at a joint configuration: link poses (forward kinematics) and the total's mass properties.

A link's pose in the model frame is its parent's pose, then its
``pose_in_parent`` (every joint at zero), then each of its joints' motions
in order (:class:`massprops.robot.model.Joint`): a rotation by ``q − reference``
about the joint's axis through its point, or a translation along the axis.
Joints that take no single value (fixed, floating, planar, ball, free) stay
at their zero.  A joint not given a value is at 0 (for MJCF: ``qpos = 0``,
which differs from the pose the file draws when the joint has a ``ref``).  The total is :func:`massprops.model.combine.combine_parts` of the
links placed at those poses: the scene machinery's centred parallel-axis sums.
"""

from __future__ import annotations

import math

import numpy as np

from ..model.errors import OptionError, option
from ..model.frames import Pose, axis_angle_quat, quat_to_matrix
from ..model.combine import combine_parts

__all__ = ["parse_joint_values", "link_poses", "robot_total"]


def parse_joint_values(text, model):
    """``{joint name: value}`` from ``NAME=VALUE,...`` (radians or metres); unknown or fixed joints are refused."""
    values = {}
    if not text:
        return values
    joints = {j.name: j for j in model.joints}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, sep, value = item.partition("=")
        name = name.strip()
        try:
            number = float(value)
        except ValueError:
            number = math.nan
        if not sep or not math.isfinite(number):
            raise OptionError(f"{option('joints')}: {item!r} is not NAME=VALUE", fix="e.g. {joints=shoulder=0.5,elbow=-1.2}")
        if name not in joints:
            moving = [j.name for j in model.joints if j.moves]
            raise OptionError(f"{option('joints')}: no joint {name!r} in the model", path=model.path,
                              fix=f"its moving joints are: {', '.join(moving[:12]) or '(none)'}")
        if not joints[name].moves:
            raise OptionError(f"{option('joints')}: joint {name!r} is {joints[name].type}: it takes no single value",
                              path=model.path)
        values[name] = number
    return values


def _motion(joint, value):
    offset = value - joint.reference
    if joint.rotates:
        rotation = quat_to_matrix(axis_angle_quat(joint.axis, offset))
        return Pose(rotation, joint.point - rotation @ joint.point)
    return Pose(np.eye(3), joint.axis * offset)


def link_poses(model, values=None):
    """``{link name: Pose in the model frame}`` with the joints at ``values`` (default all zero)."""
    values = values or {}
    by_child = {}
    for joint in model.joints:
        by_child.setdefault(joint.child, []).append(joint)
    links = {link.name: link for link in model.links}
    poses = {}

    def pose_of(name, chain=()):
        if name in poses:
            return poses[name]
        if name in chain:
            raise OptionError(f"the joints form a loop through link {name!r}", path=model.path)
        link = links[name]
        base = Pose() if link.parent is None else pose_of(link.parent, (*chain, name))
        pose = base.compose(link.pose_in_parent)
        for joint in by_child.get(name, ()):
            if joint.moves:
                pose = pose.compose(_motion(joint, values.get(joint.name, 0.0)))
        poses[name] = pose
        return pose

    for name in links:
        pose_of(name)
    return poses


def robot_total(parts):
    """The total of ``[(MassProperties in its link frame, Pose of the link)]``: one MassProperties, model frame."""
    if not parts:
        return None
    return combine_parts([p for p, _ in parts], [pose for _, pose in parts])
