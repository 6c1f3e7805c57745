"""PLY, OFF, GLB/glTF and 3MF surfaces through trimesh, imported only when such a file is read.

trimesh is asked not to process the mesh (no merging of close vertices, no
removal of faces), so coordinates arrive as stored; a scene is flattened with
its node transforms applied.  Vertices are then welded by exact coordinates,
as for every format, so triangle soups (a PLY of separate triangles, a GLB
with per-face normals) are closed.  A 3MF file's ``unit`` becomes the mesh's
declared length unit.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import MeshFormatError
from ..mesh.surface import TriangleMesh
from .registry import register_format

# 3MF's units (the specification's names) as massprops' unit names.
_3MF_UNITS = {"micron": "um", "millimeter": "mm", "centimeter": "cm", "inch": "in", "foot": "ft", "meter": "m"}


def load_trimesh(path, **kwargs):
    """``trimesh.load`` with processing off; errors become MeshFormatError."""
    try:
        import trimesh
    except ImportError:  # pragma: no cover - trimesh is a core dependency
        raise MeshFormatError("reading this format needs trimesh", path=path,
                              fix="pip install trimesh") from None
    try:
        return trimesh.load(path, process=False, maintain_order=True, **kwargs)
    except Exception as exc:  # trimesh raises many types for bad bytes
        raise MeshFormatError(f"cannot parse the file ({type(exc).__name__}: {exc})".rstrip(), path=path,
                              fix="check that the file is a complete mesh of this format") from None


def flattened(loaded, path):
    """Vertices and faces of a trimesh mesh or scene (node transforms applied)."""
    if hasattr(loaded, "to_geometry"):
        loaded = loaded.to_geometry() if len(loaded.geometry) else None
    elif hasattr(loaded, "dump") and not hasattr(loaded, "faces"):
        loaded = loaded.dump(concatenate=True) if len(loaded.geometry) else None
    faces = getattr(loaded, "faces", None)
    if faces is None or len(faces) == 0:
        raise MeshFormatError("the file holds no triangles", path=path, fix="export the part as a closed surface")
    return loaded, np.asarray(loaded.vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)


def _declared_unit(loaded, path):
    """The 3MF ``unit`` (default millimeter), as a massprops unit name, and a note; else (None, None)."""
    if os.path.splitext(path)[1].lower() != ".3mf":
        return None, None
    name = str((getattr(loaded, "metadata", None) or {}).get("units") or "millimeter").lower()
    unit = _3MF_UNITS.get(name)
    if unit is None:
        raise MeshFormatError(f"unknown 3MF unit {name!r}", path=path,
                              fix=f"use one of {', '.join(_3MF_UNITS)}")
    return unit, f"the file declares its length unit: {name}"


def read(path):
    loaded = load_trimesh(path)
    unit, note = _declared_unit(loaded, path)
    _, vertices, faces = flattened(loaded, path)
    return TriangleMesh.from_indexed(vertices, faces, notes=(note,) if note else (), unit=unit)


register_format("trimesh", [".ply", ".off", ".glb", ".gltf", ".3mf"], read)
