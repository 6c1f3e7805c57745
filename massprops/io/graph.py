"""Instance graphs (3MF components, COLLADA nodes) as massprops reads them: each mesh once, placed many times.

A reader walks its format's graph itself and gives a :class:`Graph`: every
mesh once, in its own coordinates, and one world matrix per place it is
used.  Before anything is expanded it counts, per node and once, how many
meshes and triangles the graph places and how deep it nests
(:func:`check_totals`), so a 1 kB file placing 2**30 meshes is refused
before it allocates anything.  ``props`` integrates the placed meshes as one
surface (:func:`placed_mesh`); ``scene`` integrates each mesh once and places
its moments.
"""

from __future__ import annotations

import numpy as np

from ..model.errors import MeshFormatError, option
from ..model.records import record
from ..mesh.surface import TriangleMesh

__all__ = ["Graph", "check_totals", "placed_mesh", "MAX_TRIANGLES", "too_deep"]

MAX_TRIANGLES = 50_000_000       # triangles once every instance is placed


@record
class Graph:
    """A file's meshes and where it places them.

    ``meshes``: ``{key: (vertices (n, 3) float64, faces (m, 3) int64)}``, each
    mesh's own coordinates; ``instances``: ``[(key, matrix (4, 4))]``, one per
    placed mesh, ``x_world = M[:3, :3] x + M[:3, 3]``; ``unit``: the file's unit name.
    """

    unit: str
    meshes: dict
    instances: list


def too_deep(limit, what, path):
    """The refusal of a graph nested more than ``limit`` levels."""
    return MeshFormatError(f"the {what} are nested more than {limit} levels deep", path=path,
                           fix=f"flatten the assembly on export, or if the file is trusted raise the limit with "
                               f"{option('max_depth', 'N')}")


def check_totals(instances, triangles, max_instances, path, what="meshes", *, partial=False):
    """Refuse a graph placing more than ``max_instances`` meshes or :data:`MAX_TRIANGLES` triangles.

    ``partial``: ``instances`` is a count so far (the file places at least that many).
    """
    if instances > max_instances:
        counted = f"at least {instances}" if partial else instances
        raise MeshFormatError(f"the file places {counted} {what} through its instance graph, more than the "
                              f"limit of {max_instances}", path=path,
                              fix=f"export fewer instances (or a merged mesh), or if the file is trusted raise the "
                                  f"limit with {option('max_instances', 'N')}")
    if triangles > MAX_TRIANGLES:
        raise MeshFormatError(f"the file places {triangles} triangles in all, more than {MAX_TRIANGLES}", path=path,
                              fix="export fewer instances (or a simplified mesh)")


def placed_mesh(graph, path, *, notes=(), unit=None, scale=None):
    """One :class:`TriangleMesh` of every instance placed (vertices of each instance kept apart, then welded).

    ``scale``: a factor applied to the placed coordinates (each rounded once more).
    """
    vertices, faces, offset = [], [], 0
    for name, matrix in graph.instances:
        local, triangles = graph.meshes[name]
        if not triangles.shape[0]:
            continue
        identity = np.array_equal(matrix, np.eye(4))
        with np.errstate(over="ignore", invalid="ignore"):
            vertices.append(local if identity else local @ matrix[:3, :3].T + matrix[:3, 3])
        faces.append(triangles + offset)
        offset += local.shape[0]
    if not faces:
        raise MeshFormatError("the file holds no triangles", path=path, fix="export the part as a closed surface")
    vertices = np.concatenate(vertices)
    if scale is not None:
        with np.errstate(over="ignore", under="ignore"):
            vertices = vertices * scale
    return TriangleMesh.from_indexed(vertices, np.concatenate(faces), notes=tuple(notes), unit=unit)
