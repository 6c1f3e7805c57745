"""Read a robot description of any supported format; the format comes from the root element."""

from __future__ import annotations

import os
import re

from ..model.errors import MeshReadError
from .model import RobotFormatError

__all__ = ["load_model", "detect_format", "FORMATS"]

FORMATS = {"robot": "urdf", "sdf": "sdf", "mujoco": "mjcf"}
_XACRO_NS = "http://www.ros.org/wiki/xacro"


_SKIPPED = re.compile(rb"<!--.*?-->|<\?.*?\?>|<!DOCTYPE[^>]*>", re.S)
_ROOT = re.compile(rb"<([A-Za-z_][-\w:.]*)")


def detect_format(path):
    """``(format, needs_xacro)`` from the file's root element (and a ``.xacro`` name).

    The root tag is read from the first bytes (comments, processing instructions
    and the document type skipped), so a file lxml would refuse for its XML
    declaration alone (``version="0.0"``) is still recognised.
    """
    try:
        with open(path, "rb") as handle:
            head = handle.read(1 << 16)
    except OSError as exc:
        raise MeshReadError(f"cannot read the file ({exc.strerror or exc})", path=path) from None
    match = _ROOT.search(_SKIPPED.sub(b"", head))
    if match is None:
        raise RobotFormatError("no XML element found", path=path,
                               fix="give a URDF (<robot>), SDF (<sdf>) or MJCF (<mujoco>) file")
    tag = match.group(1).decode("utf-8", "replace").rpartition(":")[2]
    if tag not in FORMATS:
        raise RobotFormatError(f"the root element is <{tag}>: not a robot description", path=path,
                               fix="give a URDF (<robot>), SDF (<sdf>) or MJCF (<mujoco>) file")
    xacro = os.fspath(path).endswith(".xacro") or _XACRO_NS.encode() in head
    return FORMATS[tag], xacro


def load_model(path, resolver, *, xacro_args=None, allow_env=False):
    """The :class:`massprops.robot.model.RobotModel` of a URDF, xacro, SDF or MJCF file.

    A xacro file is expanded without running any of its code
    (:mod:`massprops.robot.xacro_safe`); ``allow_env`` lets it read environment variables.

    Raises
    ------
    MeshReadError
        The file is missing or unreadable.
    RobotFormatError
        Not a robot description, or malformed.
    """
    from ..io.inputs import check_input
    path = os.fspath(path)
    check_input(path, what="robot description", dir_fix="name the .urdf/.sdf/.xml file")
    kind, xacro = detect_format(path)
    if kind == "urdf":
        from .urdf import read_urdf
        if xacro:
            from dataclasses import replace
            from .xacro_safe import expand_xacro
            from .xacro_sources import locate, with_sources
            includes = []
            data, warnings = expand_xacro(path, resolver, xacro_args, allow_env=allow_env, includes=includes)
            model = read_urdf(path, data=data)
            model = with_sources(model, locate(model, path, includes))
            return replace(model, warnings=warnings + model.warnings) if warnings else model
        return read_urdf(path)
    if kind == "sdf":
        from .sdf import read_sdf
        return read_sdf(path, resolver)
    from .mjcf import read_mjcf
    return read_mjcf(path, resolver)
