"""Mesh readers: one module per family of formats, one registry (:mod:`.registry`).

Only this package touches file formats, trimesh and meshio.
"""

from .registry import EXTENSIONS, UNSUPPORTED, read, reader_for, register_format
# Later registrations win: mujoco_msh takes .msh and hands Gmsh files to meshio.
from . import stl, obj, trimesh_formats, threemf, collada, meshio_formats, mujoco_msh  # noqa: E402,F401  (registration)

__all__ = ["read", "register_format", "reader_for", "EXTENSIONS", "UNSUPPORTED"]
