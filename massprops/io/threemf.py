"""3MF (core specification): objects, components and build items, walked by massprops.

trimesh's 3MF graph loses instances when a component is shared between
levels (each level placing the previous one twice kept 51 of 64), and takes
minutes on a chain of nested components; so the graph is read and walked
here.  The model is parsed as a stream (each ``<vertex>`` and ``<triangle>``
into compact arrays, elements freed as they are read), so memory stays a
small multiple of the mesh's own size.

Before anything is expanded, the graph is checked: a component cycle is
refused, and so is a graph deeper than ``max_depth`` levels or one that
places more than ``max_instances`` meshes (defaults
:data:`massprops.io.inputs.MAX_DEPTH` and ``MAX_INSTANCES``) or
:data:`massprops.io.graph.MAX_TRIANGLES` triangles in all (counted per
object, once, from the bottom up).

Transforms are the specification's: ``m00 m01 m02 m10 ... m32``, a point
(row vector) maps to ``[x y z 1] · M``, so in column form ``x ↦ Lᵀ x + t``
with ``L`` the first three rows and ``t`` the fourth.
"""

from __future__ import annotations

import posixpath

import numpy as np

from ..model.errors import MeshFormatError, reason
from .graph import Graph, check_totals, placed_mesh, too_deep
from .inputs import graph_limits
from .registry import register_format

__all__ = ["read", "read_graph", "Graph"]

# 3MF's units (the specification's names) as massprops' unit names.
UNITS = {"micron": "um", "millimeter": "mm", "centimeter": "cm", "inch": "in", "foot": "ft", "meter": "m"}
_ROOT = "/3D/3dmodel.model"
_FIX = "check that the file is a complete 3MF export"


def _local(tag):
    return tag.rpartition("}")[2] if isinstance(tag, str) else ""


def _transform(text, path, what):
    """A 3MF transform attribute as a 4x4 column-vector matrix (identity when absent)."""
    matrix = np.eye(4)
    if text is None:
        return matrix
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != 12 or not all(np.isfinite(values)):
        raise MeshFormatError(f"{what} has a transform that is not 12 finite numbers: {text[:80]!r}", path=path,
                              fix=_FIX)
    rows = np.array(values).reshape(4, 3)
    matrix[:3, :3] = rows[:3].T
    matrix[:3, 3] = rows[3]
    return matrix


class _Part:
    """One model part's objects: ``{id: ("mesh", vertices, faces) | ("components", [(part, id, matrix)])}``."""

    def __init__(self, archive, name, path):
        self.name, self.path, self.objects, self.build, self.unit = name, path, {}, [], None
        from lxml import etree
        try:
            member = archive.open(name.lstrip("/"))
        except KeyError:
            raise MeshFormatError(f"the 3MF names a model part {name!r} it does not hold", path=path,
                                  fix=_FIX) from None
        tags = [f"{{*}}{t}" for t in ("model", "vertex", "triangle", "component", "object", "item")]
        self._clear()
        try:
            with member:
                for event, element in etree.iterparse(member, events=("start", "end"), tag=tags,
                                                       resolve_entities=False, no_network=True, huge_tree=True):
                    self._take(event, element)
        except etree.XMLSyntaxError as exc:
            raise MeshFormatError(f"model part {name!r} is not well-formed XML ({exc})", path=path,
                                  fix=_FIX) from None

    def _clear(self):
        from array import array                        # not on the path of the other formats
        self._xyz, self._abc, self._components, self._meshes = array("d"), array("q"), [], 0

    def _take(self, event, element):
        tag = _local(element.tag)
        if event == "start":
            if tag == "model":
                self.unit = element.get("unit", "millimeter")
            elif tag == "object":
                self._clear()
            return
        attrib = element.attrib
        if tag == "vertex":
            try:
                self._xyz.extend((float(attrib["x"]), float(attrib["y"]), float(attrib["z"])))
            except (KeyError, ValueError):
                raise MeshFormatError(f"a <vertex> of model part {self.name!r} is not three numbers x, y, z: "
                                      f"{dict(attrib)!r:.120}", path=self.path, fix=_FIX) from None
        elif tag == "triangle":
            try:
                self._abc.extend((int(attrib["v1"]), int(attrib["v2"]), int(attrib["v3"])))
            except (KeyError, ValueError, OverflowError):
                raise MeshFormatError(f"a <triangle> of model part {self.name!r} is not three vertex numbers "
                                      f"v1, v2, v3: {dict(attrib)!r:.120}", path=self.path, fix=_FIX) from None
        elif tag == "component":
            target = next((v for k, v in attrib.items() if _local(k) == "path"), None) or self.name
            self._components.append((target, attrib.get("objectid"),
                                     _transform(attrib.get("transform"), self.path, "a <component>")))
        elif tag == "object":
            self._object(attrib.get("id"))
        elif tag == "item":
            target = next((v for k, v in attrib.items() if _local(k) == "path"), None) or self.name
            self.build.append((target, attrib.get("objectid"), _transform(attrib.get("transform"), self.path,
                                                                           "a build <item>")))
        # Each element is freed once read, and its read siblings with it: the tree never holds the mesh.
        element.clear()
        while element.getprevious() is not None:
            del element.getparent()[0]

    def _object(self, ident):
        if ident is None:
            raise MeshFormatError(f"an <object> of model part {self.name!r} has no id", path=self.path, fix=_FIX)
        if ident in self.objects:
            raise MeshFormatError(f"model part {self.name!r} defines object {ident!r} twice", path=self.path,
                                  fix=_FIX)
        if self._components:
            self.objects[ident] = ("components", self._components)
        else:
            vertices = np.frombuffer(self._xyz, dtype=np.float64).reshape(-1, 3)
            faces = np.frombuffer(self._abc, dtype=np.int64).reshape(-1, 3)
            if faces.size and (faces.min() < 0 or faces.max() >= vertices.shape[0]):
                raise MeshFormatError(f"object {ident!r} has a triangle on vertex {int(faces.max())} of "
                                      f"{vertices.shape[0]}", path=self.path, fix=_FIX)
            self.objects[ident] = ("mesh", vertices, faces)
        self._clear()


def _root_part(archive):
    """The name of the 3MF's root model part: from ``_rels/.rels``, else the usual name."""
    names = {name.lower(): name for name in archive.namelist()}
    rels = names.get("_rels/.rels")
    if rels is not None:
        import zipfile
        from lxml import etree
        try:
            with archive.open(rels) as handle:
                root = etree.parse(handle, etree.XMLParser(resolve_entities=False, no_network=True)).getroot()
            for relation in root.iter("{*}Relationship"):
                target = relation.get("Target") or ""
                if relation.get("Type", "").endswith("/3dmodel") and target.lstrip("/").lower() in names:
                    return "/" + names[target.lstrip("/").lower()]
        except (etree.XMLSyntaxError, OSError, KeyError, zipfile.BadZipFile):
            pass
    found = names.get(_ROOT.lstrip("/").lower())
    return "/" + found if found else None


class _Walk:
    """Counts, depth and cycles of the component graph, each object once (no expansion)."""

    def __init__(self, parts, path, max_depth):
        self.parts, self.path, self.max_depth = parts, path, max_depth
        self.count, self.triangles, self.depth = {}, {}, {}

    def object(self, key):
        part, ident = key
        found = self.parts(part).objects.get(ident)
        if found is None:
            raise MeshFormatError(f"object {ident!r} is placed but not defined (model part {part!r})",
                                  path=self.path, fix=_FIX)
        return found

    def measure(self, key):
        """Fill count/triangles/depth for ``key`` and all below it; iterative, refusing cycles."""
        on_path, stack = {key}, [(key, iter(self._children(key)))]
        while stack:
            node, children = stack[-1]
            child = next(children, None)
            if child is None:
                stack.pop()
                on_path.discard(node)
                self._settle(node)
            elif child in on_path:
                raise MeshFormatError(f"object {child[1]!r} contains itself through its components (a cycle)",
                                      path=self.path, fix="remove the component that closes the cycle")
            elif child in self.count:
                # Met before, maybe higher up: its own depth, below this path, counts here too.
                if len(stack) + self.depth[child] > self.max_depth:
                    raise too_deep(self.max_depth, "components", self.path)
            else:
                if len(stack) >= self.max_depth:
                    raise too_deep(self.max_depth, "components", self.path)
                on_path.add(child)
                stack.append((child, iter(self._children(child))))

    def _children(self, key):
        found = self.object(key)
        if found[0] == "mesh":
            return []
        return [(part, ident) for part, ident, _ in found[1]]

    def _settle(self, key):
        found = self.object(key)
        if found[0] == "mesh":
            self.count[key], self.triangles[key], self.depth[key] = 1, found[2].shape[0], 1
            return
        children = [(part, ident) for part, ident, _ in found[1]]
        self.count[key] = sum(self.count[c] for c in children)
        self.triangles[key] = sum(self.triangles[c] for c in children)
        self.depth[key] = 1 + max((self.depth[c] for c in children), default=0)


def _unpacking_errors():
    """What zipfile and its decompressors raise for damaged members."""
    import lzma
    import zipfile
    import zlib
    # bz2 raises OSError and ValueError; an encrypted member RuntimeError; an unknown method NotImplementedError.
    return (zipfile.BadZipFile, zlib.error, lzma.LZMAError, OSError, EOFError, NotImplementedError, RuntimeError,
            ValueError)


def read_graph(path, *, max_instances=None, max_depth=None):
    """The :class:`Graph` of a 3MF file, checked before it is expanded (limits: see :func:`graph_limits`)."""
    import zipfile      # here, not at import: zipfile loads pathlib, shutil, bz2 and lzma (5 ms of start-up)

    max_instances, max_depth = graph_limits(max_instances, max_depth)
    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError, EOFError, NotImplementedError) as exc:
        raise MeshFormatError(f"not a 3MF archive ({exc})", path=path, fix=_FIX) from None
    with archive:
        parsed = {}

        def parts(name):
            name = "/" + posixpath.normpath(name).lstrip("/")
            if name not in parsed:
                if len(parsed) >= 1000:
                    raise MeshFormatError("the 3MF refers to more than 1000 model parts", path=path, fix=_FIX)
                parsed[name] = _Part(archive, name, path)
            return parsed[name]

        try:
            root = _root_part(archive)
            if root is None:
                raise MeshFormatError("the archive holds no 3D/3dmodel.model", path=path, fix=_FIX)
            top = parts(root)
            unit = top.unit or "millimeter"
            walk = _Walk(lambda name: parts(name), path, max_depth)
            items = [(("/" + posixpath.normpath(part).lstrip("/"), ident), matrix) for part, ident, matrix in top.build]
            for key, _ in items:
                walk.measure(key)
        except MeshFormatError:
            raise
        except _unpacking_errors() as exc:
            raise MeshFormatError(f"cannot unpack the 3MF ({reason(exc, 'not a readable zip archive')})", path=path,
                                  fix=_FIX) from None
    _check_totals(walk, items, path, max_instances)
    return Graph(unit, *_expanded(walk, items))


def _check_totals(walk, items, path, max_instances):
    check_totals(sum(walk.count[key] for key, _ in items), sum(walk.triangles[key] for key, _ in items),
                 max_instances, path)
    if not items:
        raise MeshFormatError("the 3MF's build places no objects", path=path, fix="export the part as a build item")


def _expanded(walk, items):
    """``(meshes, instances)``: each mesh object once; one (key, world matrix) per placed mesh."""
    meshes, instances = {}, []
    stack = [(key, matrix) for key, matrix in reversed(items)]
    while stack:
        key, matrix = stack.pop()
        found = walk.object(key)
        if found[0] == "mesh":
            name = f"{key[0]}#{key[1]}"
            meshes.setdefault(name, found[1:])
            instances.append((name, matrix))
            continue
        for part, ident, local in reversed(found[1]):
            stack.append((("/" + posixpath.normpath(part).lstrip("/"), ident), matrix @ local))
    return meshes, instances


def read(path, *, max_instances=None, max_depth=None):
    """A 3MF's build as one triangle mesh (every instance placed), in the file's unit."""
    graph = read_graph(path, max_instances=max_instances, max_depth=max_depth)
    unit = UNITS.get(graph.unit.lower())
    if unit is None:
        raise MeshFormatError(f"unknown 3MF unit {graph.unit!r}", path=path, fix=f"use one of {', '.join(UNITS)}")
    return placed_mesh(graph, path, notes=(f"the file declares its length unit: {graph.unit}",), unit=unit)


register_format("3mf", [".3mf"], read, graph=True)
