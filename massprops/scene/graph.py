"""GLB/glTF/3MF/COLLADA scene graphs as scenes: every node with geometry is a part.

A scene-graph node may also scale or shear its mesh (``x = L x' + t`` with a
general ``L``).  ``L`` is split into a rotation and a stretch, ``L = A P``; the
stretch is applied exactly to the raw moments (``|det P|``, ``|det P| P f``,
``|det P| P C Pᵀ``) before the usual post-processing, never ignored.
"""

from __future__ import annotations


import numpy as np

from ..core.rounding import U as _U
from ..model.errors import MeshFormatError, MeshGeometryError
from ..model.frames import Pose
from .model import Part, Scene

__all__ = ["graph_scene", "scene_from_trimesh", "placement_poses"]



def graph_scene(path, density, *, max_unpacked=None, max_instances=None, max_depth=None):
    """Every node with geometry becomes a part with its world transform (instances share meshes).

    3MF and COLLADA graphs are walked by massprops (:mod:`massprops.io.graph`),
    bounded by ``max_instances`` and ``max_depth``; glTF through trimesh.
    """
    from ..io.inputs import graph_limits
    from ..io.registry import check_mesh_file
    from ..io.trimesh_formats import load_trimesh
    limits = dict(zip(("max_instances", "max_depth"), graph_limits(max_instances, max_depth)))
    check_mesh_file(path, max_unpacked=max_unpacked)
    if str(path).lower().endswith((".3mf", ".dae")):
        return _scene_from_graph(path, density, limits)
    loaded = load_trimesh(path)
    if not hasattr(loaded, "graph"):
        loaded = __import__("trimesh").Scene(loaded)
    return scene_from_trimesh(loaded, path, density)


def scene_from_trimesh(loaded, name, density):
    """A :class:`Scene` of a ``trimesh.Scene``: one part per node with geometry, meshes keyed ``NAME#GEOMETRY``."""
    nodes = sorted(loaded.graph.nodes_geometry)
    if not nodes:
        raise MeshFormatError("the scene holds no geometry", path=name, fix="export the parts as meshes")
    placements = [loaded.graph[node] for node in nodes]
    return _placed(name, density, nodes, placements,
                   lambda key: (loaded.geometry[key].vertices, loaded.geometry[key].faces))


def _scene_from_graph(path, density, limits):
    """A 3MF's build or a COLLADA scene: its graph walked by massprops, each mesh read once."""
    if str(path).lower().endswith(".3mf"):
        from ..io.threemf import read_graph
        graph = read_graph(path, **limits)
        nodes = [f"object {key.rpartition('#')[2]} (instance {k + 1})" for k, (key, _) in enumerate(graph.instances)]
    else:
        from ..io.collada import read_graph
        graph = read_graph(path, **limits)
        nodes = [f"{key} (instance {k + 1})" for k, (key, _) in enumerate(graph.instances)]
    return _placed(path, density, nodes, [(matrix, key) for key, matrix in graph.instances], graph.meshes.get)


def _placed(name, density, nodes, placements, geometry_of):
    """A :class:`Scene`: part ``nodes[k]`` is geometry ``placements[k][1]`` at matrix ``placements[k][0]``."""
    from ..mesh.arrays import mesh_from_arrays
    matrices = np.array([np.asarray(m, dtype=float) for m, _ in placements])
    poses = placement_poses(matrices[:, :3, :3], matrices[:, :3, 3], path=name)
    meshes = {}
    for geometry_name in dict.fromkeys(geometry_name for _, geometry_name in placements):
        vertices, faces = geometry_of(geometry_name)
        # Welded by exact coordinates, as every reader does: exporters often split vertices per face.
        try:
            meshes[f"{name}#{geometry_name}"] = mesh_from_arrays(vertices, faces, argument=f"geometry {geometry_name!r}")
        except (TypeError, ValueError, AttributeError) as exc:
            raise MeshFormatError(f"geometry {geometry_name!r} is not a triangle mesh ({exc})", path=name,
                                  fix="export the parts as triangle meshes") from None
    parts = tuple(Part(node, f"{name}#{geometry_name}", pose, density=density, stretch=stretch)
                  for node, (_, geometry_name), (pose, stretch) in zip(nodes, placements, poses))
    return Scene(name, parts, meshes=meshes)


def placement_poses(linear, translation, *, path=None):
    """Split placements ``x = L x' + t`` into a pose and a stretch: ``L = A P``.

    Parameters
    ----------
    linear : ndarray, shape (n, 3, 3)
    translation : ndarray, shape (n, 3)

    Returns
    -------
    list of (Pose, ndarray (3, 3) or None)
        ``A`` a proper rotation (polar decomposition, a reflection moved into
        ``P``); ``P`` None where ``L`` is already a rotation to rounding.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        defect = np.abs(linear @ linear.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
        det = np.linalg.det(linear)
    if not np.all(np.isfinite(linear)) or np.any(det == 0):
        raise MeshGeometryError("a node's transform is singular or not finite", path=path,
                                fix="give every instance a non-zero scale")
    if not np.all(np.isfinite(det)) or not np.all(np.isfinite(defect)):
        raise MeshGeometryError("a node's transform scales volumes beyond double precision "
                                f"(scale up to {float(np.abs(linear).max()):.3g})", path=path,
                                fix="export the scene with moderate scales (meshes in the units they are used in)")
    rigid = (defect <= 16 * _U) & (det > 0)
    out = []
    for k in range(linear.shape[0]):
        if rigid[k]:
            out.append((Pose(linear[k], translation[k]), None))
            continue
        u, _, vt = np.linalg.svd(linear[k])
        rotation = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
        out.append((Pose(rotation, translation[k]), rotation.T @ linear[k]))
    return out
