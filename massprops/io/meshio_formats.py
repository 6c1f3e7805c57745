"""Volume meshes (VTU/VTK, Gmsh MSH, Abaqus INP, MED, XDMF, ...) through meshio, imported only when read.

A file with volume cells becomes a :class:`massprops.mesh.volume.VolumeMesh`
(surface cells in it, such as boundary-condition faces, are ignored); a file
with surface cells only becomes a :class:`massprops.mesh.surface.TriangleMesh`.
Higher-order cells are integrated with straight edges through their corner
nodes (meshio lists corners first), and a warning says so.

A compressed VTU (zlib or LZMA blocks) may inflate to at most what an
archive may unpack to (:func:`massprops.io.inputs.unpack_limit`): meshio
inflates every block whole, so its decompressors are bounded while it reads.
A Gmsh file's ``$Nodes`` and ``$Elements`` counts are checked against its
size first (:func:`check_gmsh_counts`): meshio allocates arrays of the
declared size before it reads them; and its node numbers are bounded as it
reads them (meshio allocates a table as long as the largest node number: a
150-byte file numbering a node 2,000,000,000 took 8 GB).
"""

from __future__ import annotations

import threading

import numpy as np

from ..model.errors import MeshFormatError
from ..mesh.surface import TriangleMesh
from .boundary import third_party
from .inputs import file_size_text, unpack_limit
from .registry import register_format

__all__ = ["read", "EXTENSIONS"]

EXTENSIONS = [".vtu", ".vtk", ".msh", ".inp", ".med", ".xdmf", ".xmf", ".mesh", ".meshb", ".e", ".exo",
              ".ex2", ".h5m", ".ugrid", ".su2", ".avs", ".f3grid", ".bdf", ".fem", ".nas", ".vol", ".cgns",
              ".mdpa", ".tec"]

_VOLUME = {"tetra": 4, "pyramid": 5, "wedge": 6, "hexahedron": 8}
_SURFACE = {"triangle": 3, "quad": 4}
# Gmsh and Abaqus number a prism's first triangle with its normal towards the
# second; VTK (meshio's order) the other way round.
_MIRRORED_WEDGE = {".msh", ".inp"}
_TAG_ARRAYS = ("gmsh:physical", "cell_tags", "medit:ref")
_VTK_VOXEL, _VTK_HEXAHEDRON = 11, 12
_VOXEL_TO_HEXAHEDRON = np.array([0, 1, 3, 2, 4, 5, 7, 6])
_VTK_NAMES = {2: "poly-vertex", 4: "poly-line", 6: "triangle strip", 11: "voxel"}
_VTK_CELLS_SEEN = threading.Lock()        # the hook on meshio's VTK reader is one at a time


def _base_type(cell_type, table):
    """The linear type a (possibly higher-order) meshio cell type reduces to, or None."""
    for name in table:
        if cell_type == name or (cell_type.startswith(name) and cell_type[len(name):].isdigit()):
            return name
    return None


def _load(path):
    """``(meshio.Mesh, {VTK type: cells meshio left out})``."""
    try:
        import meshio
    except ImportError:  # pragma: no cover - meshio is a core dependency
        raise MeshFormatError("reading this format needs meshio", path=path, fix="pip install meshio") from None
    with _VTK_CELLS_SEEN:
        hooked, dropped = _hook_vtk_cells()
        inflating = _hook_decompression(path) + _hook_gmsh_tags(path)
        try:
            return third_party(path, "meshio", meshio.read, path), dropped
        finally:
            for module, original in hooked:
                module.vtk_cells_from_data = original
            for module, name, original in inflating:
                setattr(module, name, original)


class _Bounded:
    """A stand-in for the ``zlib`` or ``lzma`` module whose ``decompress`` stops at a shared budget of bytes."""

    def __init__(self, module, budget, path):
        self.module, self.budget, self.path = module, budget, path

    def __getattr__(self, name):
        return getattr(self.module, name)

    def decompress(self, data, *args, **kwargs):
        inflater = self.module.decompressobj() if hasattr(self.module, "decompressobj") else \
            self.module.LZMADecompressor()
        limit = self.budget[0]
        out = inflater.decompress(data, limit + 1)
        if len(out) > limit:
            total = self.budget[1]
            raise MeshFormatError(f"the compressed data inflate to more than {file_size_text(total)}, the limit for "
                                  f"a file of its size", path=self.path,
                                  fix="the file is damaged or hostile; export it again (or uncompressed)")
        self.budget[0] -= len(out)
        return out


_GMSH_TAG_READERS = (("meshio.gmsh._gmsh22", "_read_cells", 2), ("meshio.gmsh._gmsh40", "_read_elements", 1),
                     ("meshio.gmsh._gmsh41", "_read_elements", 1))


def _hook_gmsh_tags(path):
    """Refuse node numbers whose table (8 bytes a number up to the largest) exceeds the archive limit.

    Returns ``[(module, name, original)]``.
    """
    import importlib
    import os
    largest = unpack_limit(os.path.getsize(path)) // 8
    hooked = []
    for module_name, name, position in _GMSH_TAG_READERS:
        try:
            module = importlib.import_module(module_name)
        except ImportError:  # pragma: no cover - another meshio layout
            continue
        original = getattr(module, name, None)
        if original is None:  # pragma: no cover
            continue

        def bounded(*args, original=original, position=position, **kwargs):
            tags = np.asarray(args[position]) if len(args) > position else np.zeros(0)
            if tags.size and int(tags.max()) > largest:
                raise MeshFormatError(f"the Gmsh file numbers a node {int(tags.max())}, more than {largest} (the "
                                      "most a file of its size may number)", path=path,
                                      fix="renumber the nodes (gmsh -renumber), or export the mesh again")
            return original(*args, **kwargs)

        setattr(module, name, bounded)
        hooked.append((module, name, original))
    return hooked


def _hook_decompression(path):
    """Bound the zlib and LZMA blocks meshio's VTU reader inflates; returns ``[(module, name, original)]``."""
    import importlib
    import os
    try:
        module = importlib.import_module("meshio.vtu._vtu")
    except ImportError:  # pragma: no cover - another meshio layout
        return []
    total = unpack_limit(os.path.getsize(path))
    budget = [total, total]
    hooked = []
    for name in ("zlib", "lzma"):
        original = getattr(module, name, None)
        if original is not None:
            setattr(module, name, _Bounded(original, budget, path))
            hooked.append((module, name, original))
    return hooked


def _hook_vtk_cells():
    """Watch the VTK cell types meshio reads (XML and legacy 5.1 VTK): it drops the types it does not know.

    Voxels, which it does not know, become hexahedra (corners reordered);
    any other unknown type is counted, so the file is refused instead of
    integrated without those cells.  Returns ``([(module, original)], dropped)``.
    """
    import importlib
    dropped = {}
    hooked = []
    for name in ("meshio.vtu._vtu", "meshio.vtk._vtk_51"):
        try:
            module = importlib.import_module(name)
            from meshio._vtk_common import vtk_to_meshio_type
        except ImportError:  # pragma: no cover - another meshio layout
            continue
        original = getattr(module, "vtk_cells_from_data", None)
        if original is None:  # pragma: no cover
            continue

        def cells_from_data(connectivity, offsets, types, cell_data_raw, original=original,
                            known=vtk_to_meshio_type):
            types = np.asarray(types)
            connectivity = _voxels_as_hexahedra(np.asarray(connectivity), np.asarray(offsets), types)
            types = np.where(types == _VTK_VOXEL, _VTK_HEXAHEDRON, types)
            unknown = ~np.isin(types, np.fromiter(known, dtype=np.int64))
            for kind, count in zip(*np.unique(types[unknown], return_counts=True)):
                dropped[int(kind)] = dropped.get(int(kind), 0) + int(count)
            return original(connectivity, offsets, types, cell_data_raw)

        module.vtk_cells_from_data = cells_from_data
        hooked.append((module, original))
    return hooked, dropped


def _voxels_as_hexahedra(connectivity, offsets, types):
    """``connectivity`` with each voxel's corners (x fastest, then y, then z) in hexahedron order."""
    voxels = np.flatnonzero(types == _VTK_VOXEL)
    if voxels.size == 0 or offsets.shape != types.shape:
        return connectivity
    ends = offsets.astype(np.int64)
    starts = np.concatenate([[0], ends[:-1]])[voxels]
    if np.any(ends[voxels] - starts != 8) or np.any(starts < 0) or np.any(ends[voxels] > connectivity.size):
        return connectivity                       # not 8 nodes each: meshio refuses the offsets itself
    connectivity = connectivity.copy()
    corners = starts[:, None] + np.arange(8)
    connectivity[corners] = connectivity[starts[:, None] + _VOXEL_TO_HEXAHEDRON]
    return connectivity


_GMSH_SCAN = 1 << 20
_GMSH_SECTIONS = ((b"$Nodes", "nodes", 8), (b"$Elements", "elements", 4))    # least bytes each takes


def check_gmsh_counts(path):
    """Refuse a Gmsh ``.msh`` whose ``$Nodes`` or ``$Elements`` header declares more than the file can hold.

    Each node takes at least 8 bytes (``"1 0 0 0\\n"``), each element 4, in every
    version and encoding; the sections are found by a scan in 1 MiB pieces.
    """
    import os
    import struct
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        first = f.read(256).split(b"\n")
        if len(first) < 2 or not first[0].strip().startswith(b"$MeshFormat"):
            return
        words = first[1].split()
        try:
            version, binary, data_size = float(words[0]), words[1] == b"1", int(words[2])
        except (IndexError, ValueError):
            return                                  # meshio says what is wrong
        f.seek(0)
        tail = b""
        while True:
            chunk = f.read(_GMSH_SCAN)
            if not chunk:
                return
            data = tail + chunk
            for marker, what, least in _GMSH_SECTIONS:
                at = data.find(b"\n" + marker + b"\n")
                if at < 0 or (len(data) - at < 64 and len(chunk) == _GMSH_SCAN):
                    continue                        # none here, or its header is in the next piece
                body = data[at + len(marker) + 2:]
                if version >= 4 and binary:
                    if len(body) < 2 * data_size or data_size not in (4, 8):
                        continue
                    count = struct.unpack_from("<QQ" if data_size == 8 else "<II", body)[1]
                else:
                    numbers = body.split(b"\n", 1)[0].split()
                    try:
                        count = int(numbers[1] if version >= 4 else numbers[0])
                    except (IndexError, ValueError):
                        continue
                if count * least > size:
                    raise MeshFormatError(f"the Gmsh file declares {count} {what}, more than its "
                                          f"{file_size_text(size)} can hold", path=path,
                                          fix="the file is truncated or its header is wrong; export it again")
            tail = data[-(64 + 16):]


def _refuse_dropped(dropped, path):
    if dropped:
        said = ", ".join(f"{count} of VTK type {kind} ({_VTK_NAMES.get(kind, 'not a VTK cell type')})"
                         for kind, count in sorted(dropped.items()))
        raise MeshFormatError(f"the file holds cells massprops does not integrate: {said}", path=path,
                              fix="export tetrahedra, hexahedra, voxels, wedges or pyramids")


def _block_cells(block, corners, path):
    """A block's cells as (n, corners) int64 node numbers; None for an empty block (it adds nothing)."""
    data = np.asarray(block.data)
    if data.size == 0:
        return None
    if data.ndim != 2 or data.shape[1] < corners or data.dtype.kind not in "iu":
        raise MeshFormatError(f"a block of {block.type!r} cells has shape {data.shape}, not (cells, {corners} "
                              "or more nodes)", path=path, fix="check that the file is a complete mesh")
    return data[:, :corners].astype(np.int64)


def read(path):
    """Read a volume (or surface) mesh with meshio.

    Returns
    -------
    VolumeMesh or TriangleMesh
    """
    import os

    from ..mesh.volume import VolumeMesh

    if os.path.splitext(path)[1].lower() == ".msh":
        check_gmsh_counts(path)
    mesh, dropped = _load(path)
    _refuse_dropped(dropped, path)
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3):
        raise MeshFormatError(f"the nodes have shape {points.shape}, not (nodes, 3)", path=path,
                              fix="check that the file is a complete mesh")
    if points.shape[1:] == (2,):
        points = np.column_stack([points, np.zeros(len(points))])
    chosen, notes, higher = [], [], 0
    for index, block in enumerate(mesh.cells):
        base = _base_type(block.type, _VOLUME)
        if base is None:
            if block.dim == 3:
                raise MeshFormatError(f"the file holds cells massprops does not integrate: {len(block.data)} of "
                                      f"type {block.type!r}", path=path,
                                      fix="export tetrahedra, hexahedra, voxels, wedges or pyramids")
            continue
        cells = _block_cells(block, _VOLUME[base], path)
        if cells is None:
            continue
        if base == "wedge" and os.path.splitext(path)[1].lower() in _MIRRORED_WEDGE:
            cells = cells[:, [0, 2, 1, 3, 5, 4]]
        higher += cells.shape[0] if block.type != base else 0
        chosen.append((index, base, cells))
    if not chosen:
        return _surface(mesh, points, path)
    if higher:
        notes.append(f"{higher} higher-order cells integrated with straight edges (mid-side nodes ignored)")
    blocks = tuple((base, cells) for _, base, cells in chosen)
    indices = [index for index, _, _ in chosen]
    cell_data = {name: np.concatenate([np.asarray(arrays[i]) for i in indices])
                 for name, arrays in mesh.cell_data.items()}
    return VolumeMesh(points, blocks, cell_data, _groups(mesh, chosen, cell_data), tuple(notes))


def _groups(mesh, chosen, cell_data):
    """Named cell groups: cell sets, and physical groups / tags by number and by name."""
    offsets = np.cumsum([0] + [cells.shape[0] for _, _, cells in chosen])
    groups = {}
    for name, per_block in (getattr(mesh, "cell_sets", None) or {}).items():
        if name.startswith("gmsh:"):
            continue
        members = [offsets[k] + np.asarray(per_block[index], dtype=np.int64)
                   for k, (index, _, _) in enumerate(chosen)
                   if index < len(per_block) and per_block[index] is not None and len(per_block[index])]
        if members:
            groups[name] = np.concatenate(members)
    names = {}
    for name, value in (getattr(mesh, "field_data", None) or {}).items():
        value = np.asarray(value).ravel()
        if value.size >= 2 and int(value[1]) == 3:
            names.setdefault(int(value[0]), []).append(name)
    for tag, families in (getattr(mesh, "cell_tags", None) or {}).items():
        names.setdefault(int(tag), []).extend(families)
    for array in _TAG_ARRAYS:
        if array not in cell_data:
            continue
        tags = np.asarray(cell_data[array]).reshape(-1).astype(np.int64)
        for tag in np.unique(tags):
            members = np.flatnonzero(tags == tag)
            for name in [str(int(tag))] + names.get(int(tag), []):
                groups.setdefault(name, members)
    return groups


def _surface(mesh, points, path):
    triangles = []
    for block in mesh.cells:
        base = _base_type(block.type, _SURFACE)
        if base is None:
            continue
        cells = _block_cells(block, _SURFACE[base], path)
        if cells is None:
            continue
        if base == "quad":
            cells = np.vstack([cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]])
        triangles.append(cells)
    if not triangles:
        raise MeshFormatError("the file holds no volume cells and no surface cells", path=path,
                              fix="export tetrahedra, hexahedra, wedges, pyramids, or a closed surface")
    return TriangleMesh.from_indexed(points, np.vstack(triangles))


register_format("meshio", EXTENSIONS, read)
