"""COLLADA (``.dae``) surfaces through trimesh and pycollada (the ``dae`` extra).

trimesh flattens the scene graph but ignores two things the file says about
its coordinates, which are applied here, each with a note:

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

from fractions import Fraction

import numpy as np

from ..errors import MeshFormatError
from ..mesh.surface import TriangleMesh
from .registry import register_format

__all__ = ["read", "asset"]

# Rows: the new x, y, z as signed picks of the old axes (a proper rotation each).
_TO_Z_UP = {"Z_UP": np.eye(3), "Y_UP": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
            "X_UP": np.array([[0.0, -1, 0], [0, 0, -1], [1, 0, 0]])}
_UNITS = {Fraction(1): "m", Fraction(1, 100): "cm", Fraction(1, 1000): "mm", Fraction(1, 10 ** 6): "um",
          Fraction(254, 10000): "in", Fraction(3048, 10000): "ft"}


def asset(path):
    """The file's ``(unit meter text or None, up axis or None)``, read from its ``<asset>`` element."""
    from lxml import etree

    unit = up = None
    try:
        for _, element in etree.iterparse(path, events=("end",), recover=True, huge_tree=True):
            tag = etree.QName(element).localname if isinstance(element.tag, str) else ""
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


MAX_INSTANCES = 100_000       # geometries placed, counting every path through <instance_node>
MAX_DEPTH = 100               # levels of nodes and instanced nodes


def check_instances(path):
    """Refuse an instance graph with a cycle, deeper than MAX_DEPTH, or placing more than MAX_INSTANCES geometries.

    Counted per node once, before trimesh expands anything: a 1 kB file whose
    library nodes each instance the previous twice places 2**30 geometries.
    """
    from lxml import etree
    try:
        root = etree.parse(path, etree.XMLParser(resolve_entities=False, no_network=True, huge_tree=True,
                                                 recover=True)).getroot()
    except (etree.XMLSyntaxError, OSError):
        return                                    # trimesh says what is wrong
    if root is None:
        return
    nodes = {node.get("id"): node for node in root.iter("{*}node") if node.get("id")}
    counted, on_path = {}, set()

    def count(node, depth):
        if depth > MAX_DEPTH:
            raise MeshFormatError(f"the nodes are nested more than {MAX_DEPTH} levels deep (counting "
                                  "<instance_node>)", path=path, fix="flatten the scene on export")
        if id(node) in counted:
            return counted[id(node)]
        if id(node) in on_path:
            raise MeshFormatError(f"node {node.get('id')!r} instances itself (a cycle of <instance_node>)",
                                  path=path, fix="remove the <instance_node> that closes the cycle")
        on_path.add(id(node))
        total = 0
        for child in node:
            tag = etree.QName(child).localname if isinstance(child.tag, str) else ""
            if tag in ("instance_geometry", "instance_controller"):
                total += 1
            elif tag == "node":
                total += count(child, depth + 1)
            elif tag == "instance_node":
                target = nodes.get((child.get("url") or "").lstrip("#"))
                if target is not None:
                    total += count(target, depth + 1)
            if total > MAX_INSTANCES:
                raise MeshFormatError(f"the scene places more than {MAX_INSTANCES} geometries through "
                                      "<instance_node>", path=path, fix="export fewer instances (or a merged mesh)")
        on_path.discard(id(node))
        counted[id(node)] = total
        return total

    total = 0
    for scene in root.iter("{*}visual_scene"):
        total += sum(count(node, 1) for node in scene if isinstance(node.tag, str) and
                     etree.QName(node).localname == "node")
        if total > MAX_INSTANCES:
            raise MeshFormatError(f"the scene places more than {MAX_INSTANCES} geometries through <instance_node>",
                                  path=path, fix="export fewer instances (or a merged mesh)")


def read(path):
    try:
        import collada  # noqa: F401  (trimesh's COLLADA loader needs it)
    except ImportError:
        raise MeshFormatError("reading COLLADA needs pycollada", path=path,
                              fix="pip install 'massprops[dae]' (or pip install pycollada)") from None
    from .trimesh_formats import flattened, load_trimesh

    meter, up = asset(path)
    check_instances(path)
    vertices, faces = flattened(load_trimesh(path, file_type="dae"), path)
    notes = []
    if up and up != "Z_UP":
        if up not in _TO_Z_UP:
            raise MeshFormatError(f"unknown <up_axis> {up!r}", path=path, fix="use X_UP, Y_UP or Z_UP")
        vertices = vertices @ _TO_Z_UP[up].T
        notes.append(f"applied the file's <up_axis>{up}</up_axis>: turned its up axis to +z")
    unit = None
    if meter is not None:
        factor = _unit_factor(meter, path)
        unit = _UNITS.get(factor)
        if unit is None:
            with np.errstate(over="ignore", under="ignore"):
                vertices = vertices * float(factor)
            unit = "m"
            notes.append(f"applied the file's <unit meter=\"{meter}\">: coordinates scaled to metres")
        else:
            notes.append(f"applied the file's <unit meter=\"{meter}\">: the mesh is in {unit}")
    return TriangleMesh.from_indexed(vertices, faces, notes=tuple(notes), unit=unit)


register_format("collada", [".dae"], read)
