"""Builders of nested and hostile files for the untrusted-input tests, each with its exact expected volume.

3MF and COLLADA graphs, glTF accessors, VTU cell mixes: small, written in the
test, so every reproducer and every fuzz case is generated (nothing stored).
"""

from __future__ import annotations

import json
import re
import struct
import zipfile
from fractions import Fraction

import numpy as np

from massprops.validation import solids

_CUBE = solids.box((1.0, 1.0, 1.0))                # centred unit cube: volume 1
_CONTENT_TYPES = ('<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats.org/package/'
                  '2006/content-types"><Default Extension="rels" ContentType="application/vnd.openxmlformats-'
                  'package.relationships+xml"/><Default Extension="model" ContentType="application/vnd.ms-package.'
                  '3dmanufacturing-3dmodel+xml"/></Types>')
_RELS = ('<?xml version="1.0" encoding="UTF-8"?><Relationships xmlns="http://schemas.openxmlformats.org/package/2006/'
         'relationships"><Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/'
         '3dmanufacturing/2013/01/3dmodel"/></Relationships>')


def cube_object(ident, side=1.0):
    """A 3MF ``<object>`` holding a cube of ``side`` (volume side**3)."""
    vertices = "".join(f'<vertex x="{float(x) * side!r}" y="{float(y) * side!r}" z="{float(z) * side!r}"/>'
                       for x, y, z in _CUBE.vertices)
    triangles = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in _CUBE.faces)
    return (f'<object id="{ident}" type="model"><mesh><vertices>{vertices}</vertices>'
            f'<triangles>{triangles}</triangles></mesh></object>')


def components_object(ident, children):
    """A 3MF ``<object>`` of components: ``children`` is ``[(object id, x translation)]``."""
    parts = "".join(f'<component objectid="{child}" transform="1 0 0 0 1 0 0 0 1 {x!r} 0 0"/>'
                    for child, x in children)
    return f'<object id="{ident}" type="model"><components>{parts}</components></object>'


def write_3mf(path, objects, items, unit="millimeter"):
    """A 3MF archive; ``items`` is ``[(object id, x translation)]``."""
    build = "".join(f'<item objectid="{ident}" transform="1 0 0 0 1 0 0 0 1 {x!r} 0 0"/>' for ident, x in items)
    model = (f'<?xml version="1.0" encoding="UTF-8"?><model unit="{unit}" xmlns="http://schemas.microsoft.com/'
             f'3dmanufacturing/core/2015/02"><resources>{"".join(objects)}</resources><build>{build}</build></model>')
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", _CONTENT_TYPES)
        archive.writestr("_rels/.rels", _RELS)
        archive.writestr("3D/3dmodel.model", model)


def shared_levels_3mf(path, levels):
    """Each level places the previous one twice, side by side: 2**levels disjoint unit cubes (mm)."""
    objects = [cube_object(1)]
    for k in range(1, levels + 1):
        objects.append(components_object(k + 1, [(k, 0.0), (k, 2.0 ** k)]))
    write_3mf(path, objects, [(levels + 1, 0.0)])
    return 2 ** levels


def chain_3mf(path, depth):
    """A cube under ``depth`` levels of single components."""
    objects = [cube_object(1)] + [components_object(k + 1, [(k, 0.0)]) for k in range(1, depth + 1)]
    write_3mf(path, objects, [(depth + 1, 0.0)])


def collada_graph(path, levels, *, cycle=False):
    """A COLLADA cube under library nodes that each instance the previous twice (2**levels instances)."""
    import trimesh
    trimesh.Trimesh(_CUBE.vertices, _CUBE.faces, process=False).export(path)
    text = open(path).read()
    geometry = re.search(r'<geometry id="([^"]+)"', text).group(1)
    library = f'<library_nodes><node id="n0"><instance_geometry url="#{geometry}"/>'
    library += f'<instance_node url="#n{levels}"/></node>' if cycle else "</node>"
    library += "".join(f'<node id="n{k}"><instance_node url="#n{k - 1}"/><instance_node url="#n{k - 1}"/></node>'
                       for k in range(1, levels + 1))
    text = text.replace("<library_visual_scenes>", library + "</library_nodes><library_visual_scenes>")
    text = re.sub(r"(<visual_scene[^>]*>)", rf'\1<node id="top"><instance_node url="#n{levels}"/></node>', text)
    with open(path, "w") as f:
        f.write(text)


def collada_shared(path, levels):
    """Library nodes that each place the previous one twice, side by side: 2**levels disjoint unit cubes.

    Node ``s{k}`` holds ``s{k-1}`` at x = 0 and at x = 2**k (``s0`` is the cube); the scene places ``s{levels}``.
    """
    collada_graph(path, 0)
    text = open(path).read()
    text = re.sub(r'\s*<node id="node0".*?</node>', "", text, count=1, flags=re.S)     # trimesh's own placement
    library = "".join(f'<node id="s{k}"><node><instance_node url="#s{k - 1}"/></node><node><translate>{2 ** k} 0 0'
                      f'</translate><instance_node url="#s{k - 1}"/></node></node>' for k in range(1, levels + 1))
    text = text.replace('<node id="n0">', '<node id="s0">').replace("</library_nodes>", library + "</library_nodes>")
    text = text.replace('<instance_node url="#n0"/></node>', f'<instance_node url="#s{levels}"/></node>', 1)
    with open(path, "w") as f:
        f.write(text)
    return 2 ** levels


GLTF_TYPES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
TETRA = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)     # volume 1/6
TETRA_FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], dtype=np.uint32)


def write_glb(path, kind="VEC3", count=4, placeholder=False):
    """A GLB of the unit tetrahedron whose POSITION accessor says ``kind`` and ``count``.

    With ``placeholder``, the accessor has no buffer view (zeros, meant to be filled by an extension).
    """
    width = GLTF_TYPES[kind]
    positions = np.zeros(4 * width, dtype=np.float32)
    flat = TETRA.ravel()[:positions.size]
    positions[:flat.size] = flat
    vertex_bytes, face_bytes = positions.tobytes(), TETRA_FACES.tobytes()
    data = vertex_bytes + face_bytes
    document = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": len(data)}],
                "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(vertex_bytes)},
                                {"buffer": 0, "byteOffset": len(vertex_bytes), "byteLength": len(face_bytes)}],
                "accessors": [{"bufferView": 0, "componentType": 5126, "count": count, "type": kind},
                              {"bufferView": 1, "componentType": 5125, "count": 12, "type": "SCALAR"}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
                "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0}
    if placeholder:
        del document["accessors"][0]["bufferView"]
    text = json.dumps(document).encode()
    text += b" " * (-len(text) % 4)
    data += b"\0" * (-len(data) % 4)
    total = 12 + 8 + len(text) + 8 + len(data)
    with open(path, "wb") as f:
        f.write(b"glTF" + struct.pack("<II", 2, total) + struct.pack("<II", len(text), 0x4E4F534A) + text
                + struct.pack("<II", len(data), 0x004E4942) + data)


# VTK cells of unit size, VTK's corner order, each with its exact volume.
VTK_CELLS = {
    10: ([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], Fraction(1, 6)),                          # tetra
    11: ([(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)], Fraction(1)),              # voxel
    12: ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)], Fraction(1)),
    13: ([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1)], Fraction(1, 2)),    # wedge
    14: ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1)], Fraction(1, 3)),               # pyramid
}


def write_vtu(path, cells):
    """An ASCII VTU of ``cells``, ``[(VTK type, corners)]``, each cell moved 2 units along x from the last."""
    points, connectivity, offsets = [], [], []
    for k, (_, corners) in enumerate(cells):
        for x, y, z in corners:
            connectivity.append(len(points))
            points.append((x + 2 * k, y, z))
        offsets.append(len(connectivity))
    numbers = " ".join(repr(float(v)) for p in points for v in p)
    with open(path, "w") as f:
        f.write(f'<?xml version="1.0"?><VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">'
                f'<UnstructuredGrid><Piece NumberOfPoints="{len(points)}" NumberOfCells="{len(cells)}"><Points>'
                f'<DataArray type="Float64" NumberOfComponents="3" format="ascii">{numbers}</DataArray></Points>'
                f'<Cells><DataArray type="Int64" Name="connectivity" format="ascii">'
                f'{" ".join(map(str, connectivity))}</DataArray><DataArray type="Int64" Name="offsets" '
                f'format="ascii">{" ".join(map(str, offsets))}</DataArray><DataArray type="UInt8" Name="types" '
                f'format="ascii">{" ".join(str(kind) for kind, _ in cells)}</DataArray></Cells></Piece>'
                f'</UnstructuredGrid></VTKFile>')
