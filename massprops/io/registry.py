"""The reader registry: which reader takes a file, by extension.

Reader modules register ``read(path) -> mesh`` for their extensions with
:func:`register_format`; :func:`read` picks the reader by extension.  A
reader of instance graphs (3MF, COLLADA) registers with ``graph=True`` and is
called ``read(path, max_instances=N, max_depth=N)``.
"""

from __future__ import annotations

import os

from ..model.errors import MeshFormatError, MeshReadError
from .inputs import check_archive, check_input, check_no_holes, graph_limits

__all__ = ["read", "register_format", "reader_for", "check_mesh_file", "EXTENSIONS", "UNSUPPORTED"]

_READERS = {}
_GRAPH_READERS = set()
_PLAIN_READERS = set()           # readers that never unpack an archive (register_format's ``unpacks=False``)


def register_format(name, extensions, reader, *, graph=False, unpacks=True):
    """Register ``reader(path) -> mesh`` for file names ending in any of ``extensions``.

    With ``graph``, the reader walks an instance graph and takes the keywords
    ``max_instances`` and ``max_depth`` (positive integers, see
    :func:`massprops.io.inputs.graph_limits`).  ``unpacks=False`` says the
    reader parses the file's bytes as they are and never unpacks a zip
    container (the compiled STL and OBJ parsers: a zip under their name is
    refused as malformed), so the archive check, which opens the file, is
    left out for it.
    """
    for ext in extensions:
        _READERS[ext.lower()] = (name, reader)
        if graph:
            _GRAPH_READERS.add(reader)
        else:
            _GRAPH_READERS.discard(reader)
        if unpacks:
            _PLAIN_READERS.discard(reader)
        else:
            _PLAIN_READERS.add(reader)


def _extension(path):
    return os.path.splitext(str(path))[1].lower()


# Formats users have that massprops does not read: what each is, and how to get a mesh from it.
UNSUPPORTED = {
    ".step": ("a STEP CAD model (B-rep, not a mesh)", "export STL or 3MF from the CAD tool, or mesh it with gmsh"),
    ".stp": ("a STEP CAD model (B-rep, not a mesh)", "export STL or 3MF from the CAD tool, or mesh it with gmsh"),
    ".iges": ("an IGES CAD model (B-rep, not a mesh)", "export STL from the CAD tool, or mesh it with gmsh"),
    ".igs": ("an IGES CAD model (B-rep, not a mesh)", "export STL from the CAD tool, or mesh it with gmsh"),
    ".brep": ("an OpenCASCADE B-rep model", "mesh it with gmsh or FreeCAD and export STL"),
    ".sldprt": ("a SolidWorks part", "export STL or 3MF from SolidWorks"),
    ".ipt": ("an Inventor part", "export STL or 3MF from Inventor"),
    ".f3d": ("a Fusion 360 design", "export STL or 3MF from Fusion 360"),
    ".fbx": ("an Autodesk FBX scene", "convert it to GLB (Blender, or FBX2glTF)"),
    ".blend": ("a Blender file", "export GLB or STL from Blender"),
    ".3ds": ("a 3D Studio scene", "convert it to GLB or OBJ (Blender)"),
    ".dxf": ("a DXF drawing", "export a mesh (STL) from the CAD tool"),
    ".usd": ("a USD scene", "convert it to GLB (usd2gltf, Blender)"),
    ".usda": ("a USD scene", "convert it to GLB (usd2gltf, Blender)"),
    ".usdc": ("a USD scene", "convert it to GLB (usd2gltf, Blender)"),
    ".usdz": ("a USDZ scene", "convert it to GLB (usd2gltf, Blender)"),
    ".wrl": ("a VRML scene", "convert it to GLB or STL (Blender, MeshLab)"),
    ".x3d": ("an X3D scene", "convert it to GLB or STL (Blender, MeshLab)"),
    ".urdf": ("a URDF robot description", "use `massprops robot props`"),
    ".sdf": ("an SDF robot or world description", "use `massprops robot props`"),
    ".xml": ("an XML file (an MJCF robot?)", "use `massprops robot props` for MJCF"),
    ".xacro": ("a xacro robot description", "use `massprops robot props`"),
    ".mtl": ("an OBJ material library (no geometry)", "give the .obj file"),
    ".toml": ("a TOML file (a scene?)", "use `massprops scene`"),
    ".png": ("an image", "give a mesh file"),
    ".jpg": ("an image", "give a mesh file"),
}


def reader_for(path):
    """The ``(format name, reader)`` registered for ``path``'s extension."""
    ext = _extension(path)
    try:
        return _READERS[ext]
    except KeyError:
        if ext in UNSUPPORTED:
            what, how = UNSUPPORTED[ext]
            raise MeshFormatError(f"{ext} is {what}, which massprops does not read", path=path, fix=how) from None
        known = ", ".join(sorted(_READERS))
        raise MeshFormatError(f"unknown mesh format {ext or '(no extension)'!r}", path=path,
                              fix=f"convert it to STL, OBJ, PLY or GLB (or another of {known})") from None


def check_mesh_file(path, *, max_unpacked=None):
    """Everything checked of a mesh file before a reader opens it (see :mod:`massprops.io.inputs`).

    Returns the ``(format name, reader)`` for it.
    """
    info = check_input(path, what="mesh file", dir_fix="name the mesh files, or use `massprops batch DIR`")
    found = reader_for(path)
    # Any format: a mesh file is written, never seeked past (a 10 GB file of holes would be read whole).
    check_no_holes(path, info)
    if found[1] not in _PLAIN_READERS:
        check_archive(path, info, max_unpacked)
    return found


def read(path, *, max_unpacked=None, max_instances=None, max_depth=None):
    """Read a mesh file into a :class:`massprops.mesh.surface.TriangleMesh` (or a volume mesh).

    Parameters
    ----------
    max_unpacked : int, optional
        Bytes an archive (3MF) may unpack to; default: 100 times its size, at
        least 64 MiB (:func:`massprops.io.inputs.unpack_limit`).
    max_instances, max_depth : int, optional
        Meshes an instance graph (3MF components, COLLADA nodes) may place, and
        levels it may nest; default 100,000 and 100.

    Raises
    ------
    MeshReadError
        Missing path, a directory, a FIFO, a device, or unreadable.
    MeshFormatError
        Unknown extension, or contents that are not a mesh of that format.
    """
    path = os.fspath(path)
    instances, depth = graph_limits(max_instances, max_depth)
    _, reader = check_mesh_file(path, max_unpacked=max_unpacked)
    try:
        if reader in _GRAPH_READERS:
            return reader(path, max_instances=instances, max_depth=depth)
        return reader(path)
    except (MeshFormatError, MeshReadError):
        raise
    except OSError as exc:
        raise MeshReadError(f"cannot read the file ({exc.strerror or exc})", path=path,
                            fix="check permissions and that the file is complete") from None


EXTENSIONS = _READERS
