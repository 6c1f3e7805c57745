"""Mesh readers: one module per family of formats, one registry (:mod:`.registry`).

Only this package touches file formats, trimesh and meshio.
"""

from .registry import EXTENSIONS, read, reader_for, register_format
from . import stl, obj, trimesh_formats, meshio_formats  # noqa: E402,F401  (registration)

__all__ = ["read", "register_format", "reader_for", "EXTENSIONS"]
