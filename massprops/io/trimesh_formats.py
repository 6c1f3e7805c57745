"""PLY, OFF and GLB/glTF surfaces through trimesh, imported only when such a file is read.

trimesh is asked not to process the mesh (no merging of close vertices, no
removal of faces), so coordinates arrive as stored; a scene is flattened with
its node transforms applied.  trimesh runs behind :mod:`massprops.io.boundary`;
a PLY header's element counts are checked against the file's size first, so a
header that lies is named as such, and the files a glTF names must be regular
files as long as it says.  Vertices are then welded by exact coordinates, as
for every format, so triangle soups (a PLY of separate triangles, a GLB with
per-face normals) are closed.  (3MF is read by :mod:`.threemf`.)
"""

from __future__ import annotations

import os

import numpy as np

from ..model.errors import MeshFormatError, MeshReadError
from ..mesh.surface import TriangleMesh
from .boundary import third_party
from .inputs import check_input, file_size_text, unpack_limit
from .registry import register_format

__all__ = ["load_trimesh", "read", "flattened", "check_ply_header", "check_gltf_resources"]

_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2, "uint16": 2,
              "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4, "float32": 4, "double": 8, "float64": 8}
_PLY_HEADER_MAX = 1 << 16


def load_trimesh(path, **kwargs):
    """``trimesh.load`` with processing off, behind the reader boundary (``kwargs`` passed on)."""
    try:
        import trimesh
    except ImportError:  # pragma: no cover - trimesh is a core dependency
        raise MeshFormatError("reading this format needs trimesh", path=path,
                              fix="pip install trimesh") from None
    if path.lower().endswith(".ply"):
        check_ply_header(path)
    elif path.lower().endswith((".gltf", ".glb")):
        check_gltf_resources(path)
    return third_party(path, "trimesh", trimesh.load, path, process=False, maintain_order=True, **kwargs)


def _gltf_json(path):
    """The JSON of a glTF, or of a GLB's first chunk; None if it cannot be read (trimesh then says why)."""
    import json
    import struct
    with open(path, "rb") as handle:
        data = handle.read()
    if data[:4] == b"glTF":
        if len(data) < 20:
            return None
        length, kind = struct.unpack_from("<II", data, 12)
        if kind != 0x4E4F534A:                       # "JSON"
            return None
        data = data[20:20 + length]
    try:
        document = json.loads(data)
    except (ValueError, UnicodeDecodeError):
        return None
    return document if isinstance(document, dict) else None


_GLTF_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_GLTF_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}


def check_gltf_resources(path):
    """Every file a glTF names (buffers, images) must be a regular file, and a buffer as long as declared.

    trimesh reads them whole: a named pipe beside the file would block it, a
    short buffer be read past.  An accessor with no buffer view is zeros
    that trimesh allocates from its declared count alone, so those are
    bounded like an archive's unpacked size (:func:`check_gltf_accessors`).
    """
    document = _gltf_json(path)
    if document is None:
        return
    folder = os.path.dirname(os.path.abspath(path))
    data = os.path.getsize(path)
    for kind in ("buffers", "images"):
        entries = document.get(kind)
        for entry in entries if isinstance(entries, list) else []:
            uri = entry.get("uri") if isinstance(entry, dict) else None
            if not isinstance(uri, str) or uri.startswith("data:"):
                continue
            from urllib.parse import unquote
            resource = os.path.join(folder, unquote(uri))
            try:
                info = check_input(resource)
            except MeshReadError as exc:
                raise MeshFormatError(f"{kind[:-1]} {uri!r}: {exc.problem}", path=path,
                                      fix="export the glTF with its files beside it, or as one .glb") from None
            declared = entry.get("byteLength")
            if kind == "buffers" and isinstance(declared, int) and declared > info.st_size:
                raise MeshFormatError(f"buffer {uri!r} holds {info.st_size} bytes, the glTF says {declared}",
                                      path=path, fix="the buffer is truncated or not this glTF's; export again")
            if kind == "buffers":
                data += info.st_size
    check_gltf_accessors(document, data, path)


def check_gltf_accessors(document, data, path):
    """Refuse accessors without a buffer view whose zeros would take more than ``data`` bytes could unpack to.

    ``data``: the bytes of the file and the buffers it names.  Such accessors
    are placeholders (for a compression extension, or sparse values); their
    zeros are bounded as an archive's contents are (:func:`unpack_limit`).
    """
    accessors = document.get("accessors")
    total, limit = 0, unpack_limit(data)
    for index, accessor in enumerate(accessors if isinstance(accessors, list) else []):
        if not isinstance(accessor, dict) or "bufferView" in accessor:
            continue
        count, width = accessor.get("count"), _GLTF_WIDTH.get(accessor.get("type"))
        size = _GLTF_BYTES.get(accessor.get("componentType"))
        if not isinstance(count, int) or width is None or size is None:
            continue                                     # trimesh refuses it
        total += max(0, count) * width * size
        if total > limit:
            raise MeshFormatError(f"accessor {index} holds no data but declares {count} {accessor.get('type')} "
                                  f"items: {file_size_text(total)} of zeros from a file of "
                                  f"{file_size_text(data)}, more than the limit of {file_size_text(limit)}",
                                  path=path, fix="the file is damaged or hostile; export it again")


def _ply_elements(header):
    """``(binary, [(name, count, (fixed bytes, properties))])`` of a PLY header's text, or None if unreadable."""
    binary, elements = None, []
    for line in header.splitlines()[1:]:
        words = line.split()
        if not words:
            continue
        if words[0] == "format" and len(words) >= 2:
            binary = words[1] != "ascii"
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append([words[1], int(words[2]), 0, 0])
        elif words[0] == "property" and elements:
            element = elements[-1]
            kind = words[2] if words[1:2] == ["list"] and len(words) >= 5 else words[1] if len(words) >= 3 else None
            element[2] += _PLY_SIZES.get(kind, 1)      # a list's count field; its items may be none
            element[3] += 1
    return binary, elements


def check_ply_header(path):
    """Refuse a PLY whose header declares more elements than the file's size can hold.

    Each binary row takes at least its fixed-size fields (a list at least its
    count); each ASCII row at least one character and one separator per
    property.  A header claiming more rows than that is a lie, said as such
    (trimesh would report a file holding "no triangles").
    """
    size = os.path.getsize(path)
    with open(path, "rb") as handle:
        head = handle.read(_PLY_HEADER_MAX)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        return                                   # not a PLY header we can read: trimesh says what is wrong
    data_start = head.find(b"\n", end) + 1 or len(head)
    binary, elements = _ply_elements(head[:end].decode("ascii", "replace"))
    if binary is None:
        return
    need, available = 0, size - data_start
    for name, count, fixed, properties in elements:
        need += count * (fixed if binary else 2 * properties)
        if need > available + 1:
            raise MeshFormatError(
                f"the PLY header says {count} {name} elements, which need at least {file_size_text(need)}, but "
                f"the file holds {file_size_text(max(0, available))} after its header", path=path,
                fix="the file is truncated or its header is wrong; export it again")


def flattened(loaded, path):
    """Vertices (float64) and faces of a trimesh mesh or scene, node transforms applied."""
    if hasattr(loaded, "to_geometry"):
        loaded = third_party(path, "trimesh", loaded.to_geometry) if len(loaded.geometry) else None
    elif hasattr(loaded, "dump") and not hasattr(loaded, "faces"):
        loaded = third_party(path, "trimesh", loaded.dump, concatenate=True) if len(loaded.geometry) else None
    faces = getattr(loaded, "faces", None)
    if faces is None or len(faces) == 0:
        raise MeshFormatError("the file holds no triangles", path=path, fix="export the part as a closed surface")
    return _checked_arrays(loaded.vertices, faces, path)


def _checked_arrays(vertices, faces, path, what="the mesh"):
    """Vertices (n, 3) float64 and faces (m, 3) int64 of what a reader returned, or a MeshFormatError."""
    try:
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces)
    except (TypeError, ValueError, OverflowError) as exc:
        raise MeshFormatError(f"{what} is not a triangle mesh ({exc})", path=path,
                              fix="check that the file is a complete mesh of this format") from None
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise MeshFormatError(f"{what}'s vertex positions have shape {vertices.shape}, not (vertices, 3) "
                              "(a glTF POSITION accessor must be a VEC3)", path=path,
                              fix="export positions as three coordinates per vertex")
    if faces.ndim != 2 or faces.shape[1] != 3 or (faces.size and faces.dtype.kind not in "iu"):
        raise MeshFormatError(f"{what}'s faces have shape {faces.shape}, not (faces, 3) vertex indices", path=path,
                              fix="export the part as triangles")
    return vertices, faces.astype(np.int64)


def read(path):
    vertices, faces = flattened(load_trimesh(path), path)
    return TriangleMesh.from_indexed(vertices, faces)


register_format("trimesh", [".ply", ".glb", ".gltf", ".off"], read)
