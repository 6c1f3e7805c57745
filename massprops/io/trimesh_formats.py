"""PLY, OFF, GLB/glTF and 3MF surfaces through trimesh, imported only when such a file is read.

trimesh is asked not to process the mesh (no merging of close vertices, no
removal of faces), so coordinates arrive as stored; a scene is flattened with
its node transforms applied.
"""

from __future__ import annotations

import numpy as np

from ..errors import MeshFormatError
from ..mesh.surface import TriangleMesh
from .registry import register_format


def load_trimesh(path):
    """``trimesh.load`` with processing off; errors become MeshFormatError."""
    try:
        import trimesh
    except ImportError:  # pragma: no cover - trimesh is a core dependency
        raise MeshFormatError("reading this format needs trimesh", path=path,
                              fix="pip install trimesh") from None
    try:
        return trimesh.load(path, process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many types for bad bytes
        raise MeshFormatError(f"cannot parse the file ({type(exc).__name__}: {exc})".rstrip(), path=path,
                              fix="check that the file is a complete mesh of this format") from None


def read(path):
    loaded = load_trimesh(path)
    if hasattr(loaded, "to_geometry"):
        loaded = loaded.to_geometry() if len(loaded.geometry) else None
    elif hasattr(loaded, "dump") and not hasattr(loaded, "faces"):
        loaded = loaded.dump(concatenate=True) if len(loaded.geometry) else None
    faces = getattr(loaded, "faces", None)
    if faces is None or len(faces) == 0:
        raise MeshFormatError("the file holds no triangles", path=path, fix="export the part as a closed surface")
    return TriangleMesh(np.asarray(loaded.vertices, dtype=np.float64).copy(),
                        np.asarray(faces, dtype=np.int64).copy())


register_format("trimesh", [".ply", ".off", ".glb", ".gltf", ".3mf"], read)
