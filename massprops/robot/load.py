"""Read a robot description of any supported format; the format comes from the root element."""

from __future__ import annotations

import os

from ..errors import MeshReadError
from .model import RobotFormatError

__all__ = ["load_model", "detect_format", "FORMATS"]

FORMATS = {"robot": "urdf", "sdf": "sdf", "mujoco": "mjcf"}
_XACRO_NS = "http://www.ros.org/wiki/xacro"


def detect_format(path):
    """``(format, needs_xacro)`` from the file's root element (and a ``.xacro`` name)."""
    from lxml import etree
    try:
        for _, element in etree.iterparse(os.fspath(path), events=("start",), resolve_entities=False,
                                          huge_tree=True):
            tag = element.tag.rpartition("}")[2] if isinstance(element.tag, str) else ""
            xacro = os.fspath(path).endswith(".xacro") or _XACRO_NS in (element.nsmap or {}).values()
            if tag not in FORMATS:
                raise RobotFormatError(f"the root element is <{tag}>: not a robot description", path=path,
                                       fix="give a URDF (<robot>), SDF (<sdf>) or MJCF (<mujoco>) file")
            return FORMATS[tag], xacro
    except etree.XMLSyntaxError as exc:
        raise RobotFormatError(f"not well-formed XML ({exc})", path=path,
                               fix="fix the XML (`xmllint FILE` shows where)") from None
    raise RobotFormatError("the file is empty", path=path)


def load_model(path, resolver, *, xacro_args=None):
    """The :class:`massprops.robot.model.RobotModel` of a URDF, xacro, SDF or MJCF file.

    Raises
    ------
    MeshReadError
        The file is missing or unreadable.
    RobotFormatError
        Not a robot description, or malformed.
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        raise MeshReadError("is a directory, not a robot description", path=path, fix="name the .urdf/.sdf/.xml file")
    if not os.path.isfile(path):
        raise MeshReadError("no such file", path=path, fix="check the path")
    kind, xacro = detect_format(path)
    if kind == "urdf":
        from .urdf import expand_xacro, read_urdf
        if xacro:
            data = expand_xacro(path, resolver, xacro_args)
            return read_urdf(path, data=data, writable="a xacro file is generated: write the expanded URDF "
                                                        "(xacro FILE > robot.urdf) and write that")
        return read_urdf(path)
    if kind == "sdf":
        from .sdf import read_sdf
        return read_sdf(path, resolver)
    from .mjcf import read_mjcf
    return read_mjcf(path, resolver)
