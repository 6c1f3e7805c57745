"""COLLADA (``.dae``) surfaces: pycollada (the ``dae`` extra) parses, massprops walks the node graph.

The graph of ``<node>``, ``<instance_node>`` and ``<instance_geometry>`` is
walked here, not by trimesh: trimesh copies a geometry at every path to it
(a 1 kB file whose library nodes each instance the previous twice places
2**30 copies).  First the XML alone is counted, each node once
(:func:`check_instances`): a cycle is refused, and so is a graph nesting
more than ``max_depth`` levels or placing more than ``max_instances``
geometries.  Then each geometry's triangles are read once
(:class:`massprops.io.graph.Graph`) and placed at every instance;
``<instance_controller>`` (skinned or morphed geometry) is refused rather
than left out.

Two things the file says about its coordinates are applied, each with a note:

* ``<asset><unit meter="0.01"/>``: the mesh's length unit.  A unit massprops
  names (m, cm, mm, um, in, ft) becomes the mesh's declared unit, so results
  are in SI exactly as with ``--unit``; any other factor scales the
  coordinates to metres (each rounded once, within the input's own resolution).
* ``<asset><up_axis>Y_UP</up_axis>``: the axes are turned so that the file's
  up axis becomes +z (a proper rotation that permutes and negates coordinates,
  so exact).  COLLADA's conventions: Y_UP has right +x, up +y; X_UP has
  right −y, up +x; Z_UP (massprops' own) has right +x, up +z.
"""

from __future__ import annotations

import numpy as np

from ..model.errors import MeshFormatError
from .boundary import third_party
from .graph import Graph, check_totals, placed_mesh, too_deep
from .inputs import graph_limits
from .registry import register_format

__all__ = ["read", "read_graph", "asset", "check_instances"]

# Rows: the new x, y, z as signed picks of the old axes (a proper rotation each).
_TO_Z_UP = {"Z_UP": np.eye(3), "Y_UP": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
            "X_UP": np.array([[0.0, -1, 0], [0, 0, -1], [1, 0, 0]])}
# metres per unit, reduced (numerator, denominator) -> unit  (fractions is imported when a file has a unit)
_UNITS = {(1, 1): "m", (1, 100): "cm", (1, 1000): "mm", (1, 10 ** 6): "um", (127, 5000): "in", (381, 1250): "ft"}


def asset(path):
    """The file's ``(unit meter text or None, up axis or None)``, read from its ``<asset>`` element."""
    from lxml import etree

    unit = up = None
    try:
        for _, element in etree.iterparse(path, events=("end",), recover=True, huge_tree=True):
            tag = _localname(element)
            if tag == "unit" and unit is None:
                unit = element.get("meter")
            elif tag == "up_axis" and up is None:
                up = (element.text or "").strip().upper()
            elif tag == "asset":
                break
    except (etree.XMLSyntaxError, OSError) as exc:
        raise MeshFormatError(f"cannot parse the file as XML ({exc})", path=path,
                              fix="check that the file is a complete COLLADA document") from None
    return unit, up


def _unit_factor(meter, path):
    """``<unit meter=...>`` as an exact positive Fraction within 1e-300 to 1e300."""
    from fractions import Fraction
    text = meter.strip()
    try:
        # A decimal is checked as a float first: Fraction("1e999999999") builds a billion-digit integer.
        value = float(text)
    except ValueError:
        try:
            value = float(Fraction(text))
        except (ValueError, ZeroDivisionError, OverflowError):
            raise MeshFormatError(f"cannot read <unit meter={meter!r}>", path=path,
                                  fix="give the unit as a number of metres") from None
    if value != value or not value > 0:
        raise MeshFormatError(f"<unit meter={meter!r}> is not a positive number", path=path, fix="fix the unit")
    if not 1e-300 < value < 1e300:
        raise MeshFormatError(f"<unit meter={meter!r}> is outside the range massprops can scale by (1e-300 to "
                              "1e300 metres)", path=path, fix="give the unit in metres as a number within that range")
    return Fraction(text)


def _localname(element):
    """An element's tag without its namespace ("" for comments; a recovered, invalid tag as it is)."""
    return element.tag.rpartition("}")[2] if isinstance(element.tag, str) else ""


_LEAF = object()


def check_instances(path, max_instances=None, max_depth=None):
    """Refuse an instance graph with a cycle, deeper than ``max_depth`` or placing more than ``max_instances``.

    Counted on the XML, per node once, iteratively, before anything is
    expanded: a 1 kB file whose library nodes each instance the previous
    twice places 2**30 geometries.
    """
    from lxml import etree
    max_instances, max_depth = graph_limits(max_instances, max_depth)
    try:
        root = etree.parse(path, etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True,
                                                 recover=True)).getroot()
    except (etree.XMLSyntaxError, OSError):
        return                                    # pycollada says what is wrong
    if root is None:
        return
    nodes = {node.get("id"): node for node in root.iter("{*}node") if node.get("id")}

    def children(node):
        for child in node:
            tag = _localname(child)
            if tag in ("instance_geometry", "instance_controller"):
                yield _LEAF
            elif tag == "node":
                yield child
            elif tag == "instance_node":
                target = nodes.get((child.get("url") or "").lstrip("#"))
                if target is not None:
                    yield target

    counted, total = {}, 0
    for scene in root.iter("{*}visual_scene"):
        for top in scene:
            if _localname(top) != "node":
                continue
            total += _count(top, children, counted, max_instances, max_depth, path)[0]
            check_totals(total, 0, max_instances, path, "geometries", partial=True)


def _count(top, children, counted, max_instances, max_depth, path):
    """``(geometries, levels)`` under ``top``, memoized in ``counted`` by element; refusing cycles and depth.

    A node met again is not walked again: its levels, below the path that meets it, are checked instead.
    """
    if id(top) in counted:
        return counted[id(top)]
    stack, totals, on_path = [(top, children(top))], [[0, 0]], {id(top)}
    while stack:
        node, rest = stack[-1]
        child = next(rest, None)
        if child is None:
            stack.pop()
            on_path.discard(id(node))
            done, below = totals.pop()
            counted[id(node)] = (done, below + 1)
            if totals:
                totals[-1][0] += done
                totals[-1][1] = max(totals[-1][1], below + 1)
        elif child is _LEAF:
            totals[-1][0] += 1
        elif id(child) in counted:
            done, levels = counted[id(child)]
            if len(stack) + levels > max_depth:
                raise too_deep(max_depth, "nodes (counting <instance_node>)", path)
            totals[-1][0] += done
            totals[-1][1] = max(totals[-1][1], levels)
        elif id(child) in on_path:
            raise MeshFormatError(f"node {child.get('id')!r} instances itself (a cycle of <instance_node>)",
                                  path=path, fix="remove the <instance_node> that closes the cycle")
        elif len(stack) >= max_depth:
            raise too_deep(max_depth, "nodes (counting <instance_node>)", path)
        else:
            on_path.add(id(child))
            stack.append((child, children(child)))
            totals.append([0, 0])
        if totals and totals[-1][0] > max_instances:
            check_totals(totals[-1][0], 0, max_instances, path, "geometries", partial=True)
    return counted[id(top)]


def _geometry_triangles(geometry, path):
    """A ``<geometry>``'s triangles (polylists and polygons triangulated; lines have no volume)."""
    import collada
    vertices, faces, count = [], [], 0
    for primitive in geometry.primitives:
        if isinstance(primitive, collada.polylist.Polylist):
            primitive = primitive.triangleset()
        if not isinstance(primitive, collada.triangleset.TriangleSet) or primitive.vertex is None:
            continue
        points = np.asarray(primitive.vertex, dtype=np.float64).reshape(-1, 3)
        index = np.asarray(primitive.vertex_index).reshape(-1, 3)
        if index.size == 0:
            continue
        if index.dtype.kind not in "iu" or index.min() < 0 or index.max() >= points.shape[0]:
            raise MeshFormatError(f"geometry {geometry.id!r} has a triangle on a vertex it does not hold",
                                  path=path, fix="check that the file is a complete COLLADA export")
        vertices.append(points)
        faces.append(index.astype(np.int64) + count)
        count += points.shape[0]
    if not faces:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.concatenate(vertices), np.concatenate(faces)


def _walk(path):
    """``(meshes, instances)`` of the document's scene: each geometry once, one matrix per instance."""
    import collada
    ignored = [collada.common.DaeError, collada.common.DaeIncompleteError, collada.common.DaeMalformedError,
               collada.common.DaeBrokenRefError, collada.common.DaeUnsupportedError]
    document = collada.Collada(path, ignore=ignored)
    meshes, instances, keys = {}, [], {}
    stack = [(node, np.eye(4)) for node in reversed(document.scene.nodes if document.scene is not None else [])]
    while stack:
        node, parent = stack.pop()
        if isinstance(node, collada.scene.GeometryNode):
            geometry = node.geometry
            key = keys.setdefault(id(geometry), geometry.id or f"geometry {len(keys) + 1}")
            if key not in meshes:
                meshes[key] = _geometry_triangles(geometry, path)
            instances.append((key, parent))
        elif isinstance(node, collada.scene.ControllerNode):
            raise MeshFormatError("the scene places skinned or morphed geometry (<instance_controller>), which "
                                  "massprops does not read", path=path,
                                  fix="export the mesh in its pose as plain geometry (apply the armature)")
        elif isinstance(node, collada.scene.Node):
            matrix = parent @ np.asarray(node.matrix, dtype=np.float64)
            stack.extend((child, matrix) for child in reversed(node.children or []))
    return meshes, instances


def read_graph(path, *, max_instances=None, max_depth=None):
    """The :class:`massprops.io.graph.Graph` of a COLLADA file, its up axis turned to +z, checked first.

    ``unit`` is the ``<unit meter>`` text (or ``""``).
    """
    try:
        import collada  # noqa: F401
    except ImportError:
        raise MeshFormatError("reading COLLADA needs pycollada", path=path,
                              fix="pip install 'massprops[dae]' (or pip install pycollada)") from None
    max_instances, max_depth = graph_limits(max_instances, max_depth)
    meter, up = asset(path)
    check_instances(path, max_instances, max_depth)
    meshes, instances = third_party(path, "pycollada", _walk, path)
    check_totals(len(instances), sum(meshes[key][1].shape[0] for key, _ in instances), max_instances, path,
                 "geometries")
    if up and up != "Z_UP":
        if up not in _TO_Z_UP:
            raise MeshFormatError(f"unknown <up_axis> {up!r}", path=path, fix="use X_UP, Y_UP or Z_UP")
        turn = np.eye(4)
        turn[:3, :3] = _TO_Z_UP[up]
        instances = [(key, turn @ matrix) for key, matrix in instances]
    return Graph(meter or "", meshes, instances)


def read(path, *, max_instances=None, max_depth=None):
    graph = read_graph(path, max_instances=max_instances, max_depth=max_depth)
    _, up = asset(path)
    notes = []
    if up and up != "Z_UP":
        notes.append(f"applied the file's <up_axis>{up}</up_axis>: turned its up axis to +z")
    unit, scale = None, None
    if graph.unit:
        factor = _unit_factor(graph.unit, path)
        unit = _UNITS.get(factor.as_integer_ratio())
        if unit is None:
            unit, scale = "m", float(factor)
            notes.append(f"applied the file's <unit meter=\"{graph.unit}\">: coordinates scaled to metres")
        else:
            notes.append(f"applied the file's <unit meter=\"{graph.unit}\">: the mesh is in {unit}")
    return placed_mesh(graph, path, notes=notes, unit=unit, scale=scale)


register_format("collada", [".dae"], read, graph=True)
