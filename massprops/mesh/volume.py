"""Volume meshes: cells, per-cell density, the split into tetrahedra, exact integration.

A :class:`VolumeMesh` holds points and blocks of cells (tetrahedra,
hexahedra, wedges, pyramids) in VTK node order, which is meshio's, with the
cell data and named groups (physical groups, cell sets) that came with them.

Splitting, consistently: every quadrilateral face is cut along the diagonal
through its smallest node index, so two cells sharing a face cut it the same
way whatever their own node order; each cell is then the cone from its
smallest node over the triangles of the faces not touching it (a hexahedron
gives 6 tetrahedra, a wedge 3, a pyramid 2).

Integrating, exactly: a positive tetrahedron is the signed sum of the cones
from the reference point over its four outward faces, so a cell of density ρ
contributes ρ times the cone integrals of :func:`massprops.core.integrate`
over its faces.  A face shared by two cells of equal density appears twice,
once each way: the pair cancels exactly and is dropped, so a body of one
density is integrated over its boundary surface alone (the surface path,
term for term); faces between different densities keep both terms.
"""

from __future__ import annotations

import math

from dataclasses import dataclass, field

import numpy as np

from ..core import U as _U, face_groups, integrate, shells, tetra_determinants
from ..model.errors import MeshGeometryError, OptionError
from ..model.properties import MassProperties
from .nonplanar import nonplanar_quads

__all__ = ["VolumeMesh", "CELL_FACES", "parse_density_map", "cell_densities", "volume_mass_properties"]

# Outward faces of each cell type, VTK node order (a tetrahedron's face
# (0, 1, 2) has its right-hand normal towards node 3; a wedge's (0, 1, 2)
# points away from (3, 4, 5)).
CELL_FACES = {
    "tetra": ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)),
    "pyramid": ((0, 3, 2, 1), (0, 1, 4), (1, 2, 4), (2, 3, 4), (3, 0, 4)),
    "wedge": ((0, 1, 2), (3, 5, 4), (0, 3, 4, 1), (1, 4, 5, 2), (0, 2, 5, 3)),
    "hexahedron": ((0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)),
}
_TET_FACES = np.array(CELL_FACES["tetra"])


@dataclass(frozen=True, eq=False)
class VolumeMesh:
    """Cells of a solid in its local frame.

    Parameters
    ----------
    points : ndarray, shape (n, 3), float64
        Node coordinates, mesh units, local frame.
    blocks : tuple of (str, ndarray (k, nodes) int64)
        Cells by type (keys of :data:`CELL_FACES`), corner nodes in VTK order.
        Cells are numbered 0, 1, ... through the blocks in order.
    cell_data : dict of str to ndarray, shape (cells, ...)
        Per-cell arrays, concatenated over the blocks.
    groups : dict of str to ndarray of int64
        Named cell groups (physical groups by name and tag, cell sets): cell numbers.
    notes : tuple of str
        What reading changed or ignored (reported as warnings).
    """

    points: np.ndarray
    blocks: tuple
    cell_data: dict = field(default_factory=dict)
    groups: dict = field(default_factory=dict)
    notes: tuple = ()
    source_dtype: np.dtype = field(default=np.dtype(np.float64))

    @property
    def n_cells(self):
        return sum(cells.shape[0] for _, cells in self.blocks)

    def cell_types(self):
        """``{type: count}`` over the blocks."""
        counts = {}
        for cell_type, cells in self.blocks:
            counts[cell_type] = counts.get(cell_type, 0) + int(cells.shape[0])
        return counts

    def tetrahedra(self):
        """The consistent split into tetrahedra.

        Returns
        -------
        tets : ndarray, shape (t, 4), int64
            Node indices; positive volume for a cell in valid VTK order.
        cell : ndarray, shape (t,), int64
            The cell each tetrahedron comes from.
        """
        tets, cell, offset = [], [], 0
        for cell_type, cells in self.blocks:
            triangles = _face_triangles(cells, CELL_FACES[cell_type])        # (k, f, 3)
            apex = cells.min(axis=1)
            keep = ~np.any(triangles == apex[:, None, None], axis=2)
            apexes = np.broadcast_to(apex[:, None], keep.shape)[keep]
            tets.append(np.column_stack([apexes, triangles[keep]]))
            cell.append(np.broadcast_to(offset + np.arange(cells.shape[0])[:, None], keep.shape)[keep])
            offset += cells.shape[0]
        return np.concatenate(tets).astype(np.int64), np.concatenate(cell).astype(np.int64)


def _face_triangles(cells, faces):
    """(k, f, 3) triangles of each cell's outward faces; quads cut through their smallest node."""
    triangles = []
    for face in faces:
        nodes = cells[:, list(face)]
        if len(face) == 3:
            triangles.append(nodes)
            continue
        a, b, c, d = nodes.T
        through_ac = (np.minimum(a, c) < np.minimum(b, d))[:, None]
        triangles.append(np.where(through_ac, np.column_stack([a, b, c]), np.column_stack([a, b, d])))
        triangles.append(np.where(through_ac, np.column_stack([a, c, d]), np.column_stack([b, c, d])))
    return np.stack(triangles, axis=1)


def parse_density_map(text):
    """``"GROUP=VALUE,..."`` to ``{group: density}`` (raises OptionError)."""
    mapping = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        group, sep, value = item.rpartition("=")
        try:
            mapping[group.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep or not group.strip():
            raise OptionError(f"cannot read {item!r} in {{density_map}}", fix="write GROUP=VALUE,GROUP=VALUE")
        if not (math.isfinite(mapping[group.strip()]) and mapping[group.strip()] >= 0):
            raise OptionError(f"the density in {item!r} is not a finite number ≥ 0", fix="give densities ≥ 0")
    if not mapping:
        raise OptionError("{density_map} is empty", fix="write GROUP=VALUE,GROUP=VALUE")
    return mapping


def _first_cell(mask):
    return int(np.flatnonzero(mask)[0])


def cell_densities(vmesh, *, density=None, density_field=None, density_map=None, path=None):
    """Density of every cell, or None when the body has one density.

    Parameters
    ----------
    density_field : str, optional
        Name of a scalar cell-data array holding the densities.
    density_map : dict of str to float, optional
        Density per group; ``density`` (if given) fills cells in no listed group.

    Returns
    -------
    ndarray, shape (cells,), float64, or None
    """
    if density_field is not None and density_map is not None:
        raise OptionError("give {density_field} or {density_map}, not both")
    if density_field is not None:
        if density is not None:
            raise OptionError("give {density} or {density_field}, not both")
        rho = _field(vmesh, density_field, path)
    elif density_map is not None:
        rho = _mapped(vmesh, density_map, density, path)
    else:
        return None
    bad = ~np.isfinite(rho) | (rho < 0)
    if bad.any():
        first = _first_cell(bad)
        raise MeshGeometryError(f"{int(bad.sum())} cells have a negative or non-finite density "
                                f"(first: cell {first}, {rho[first]!r})", path=path,
                                fix="fix the density values; every cell needs a density ≥ 0")
    if not np.any(rho > 0):
        raise MeshGeometryError("every cell has density 0", path=path, fix="give the cells positive densities")
    return rho


def _field(vmesh, name, path):
    if name not in vmesh.cell_data:
        names = ", ".join(sorted(vmesh.cell_data)) or "none"
        raise OptionError(f"no cell data named {name!r} (the file has: {names})", path=path,
                          fix="name one of them with {density_field}")
    values = np.asarray(vmesh.cell_data[name])
    if values.ndim > 1 and values[0].size != 1:
        raise OptionError(f"cell data {name!r} has {values[0].size} components per cell, not 1", path=path,
                          fix="name a scalar cell array with {density_field}")
    return values.reshape(-1).astype(np.float64)


def _mapped(vmesh, density_map, default, path):
    unknown = [g for g in density_map if g not in vmesh.groups]
    if unknown:
        names = ", ".join(sorted(vmesh.groups)) or "none"
        raise OptionError(f"no cell group named {unknown[0]!r} (the file has: {names})", path=path,
                          fix="use the physical group / cell set names in {density_map}")
    rho = np.full(vmesh.n_cells, np.nan)
    assigned = np.zeros(vmesh.n_cells, dtype=bool)
    for group, value in density_map.items():
        cells = vmesh.groups[group]
        clash = assigned[cells] & (rho[cells] != value)
        if clash.any():
            cell = int(cells[_first_cell(clash)])
            raise OptionError(f"cell {cell} is in two groups of {{density_map}} with different densities",
                              path=path, fix="give each cell one density")
        rho[cells] = value
        assigned[cells] = True
    if not assigned.all():
        if default is None:
            raise MeshGeometryError(f"{int((~assigned).sum())} cells are in no group of {{density_map}} "
                                    f"(first: cell {_first_cell(~assigned)})", path=path,
                                    fix="add their groups to {density_map}, or give {density} for the rest")
        rho[~assigned] = default
    return rho


def _used_points(vmesh, tets, path):
    """Only the points the cells use, finite, with the tetrahedra renumbered."""
    n = vmesh.points.shape[0]
    if tets.size and (tets.min() < 0 or tets.max() >= n):
        raise MeshGeometryError("a cell refers to a node that does not exist", path=path, fix="re-export the mesh")
    used = np.zeros(n, dtype=bool)
    used[tets.ravel()] = True
    bad = used & ~np.isfinite(vmesh.points).all(axis=1)
    if bad.any():
        raise MeshGeometryError(f"{int(bad.sum())} nodes have NaN or infinite coordinates "
                                f"(first: node {_first_cell(bad)})", path=path,
                                fix="re-export the mesh; non-finite coordinates cannot be repaired")
    renumber = np.cumsum(used) - 1
    return vmesh.points[used].astype(np.float64), renumber[tets]


def _cell_volumes(points, tets, cell, n_cells):
    """Six times each cell's signed volume (scaled units) and a bound on its error."""
    det, bound = tetra_determinants(points, tets)
    # Each tetrahedron's bound, plus the (≤ 6-term) sum per cell: γ5 of Σ|det| ≤ 7u|det| per term.
    bound = bound + 7 * _U * np.abs(det)
    return (np.bincount(cell, weights=det, minlength=n_cells),
            np.bincount(cell, weights=bound, minlength=n_cells) * (1 + 8 * _U))


def _cell_types(vmesh):
    return np.concatenate([np.full(cells.shape[0], name, dtype=object) for name, cells in vmesh.blocks])


def _orient_cells(vmesh, points, tets, cell, *, repair, path):
    """Refuse degenerate cells, and inverted ones unless ``repair`` (then reoriented).

    Returns the tetrahedra, all positive, and the number of cells reoriented.
    """
    six_volume, bound = _cell_volumes(points, tets, cell, vmesh.n_cells)
    degenerate = np.abs(six_volume) <= bound
    if degenerate.any():
        raise MeshGeometryError(f"{int(degenerate.sum())} cells have zero volume (degenerate; first: cell "
                                f"{_first_cell(degenerate)})", path=path, fix="remove or re-mesh those cells")
    inverted = six_volume < 0
    n_inverted = int(inverted.sum())
    if n_inverted and not repair:
        types = _cell_types(vmesh)
        mirrored = [t for t in np.unique(types[inverted]) if inverted[types == t].all()]
        hint = f" (every {mirrored[0]} is: the file may number their nodes the other way round)" if mirrored else ""
        raise MeshGeometryError(f"{n_inverted} cells are inverted (negative volume; first: cell "
                                f"{_first_cell(inverted)}){hint}", path=path,
                                fix="pass {repair} to reorient them")
    if n_inverted:
        flip = inverted[cell]
        tets = tets.copy()
        tets[flip] = tets[flip][:, [0, 1, 3, 2]]
    return tets, n_inverted


def _paired_faces(tets, cell, rho, path):
    """The tetrahedra's outward faces, which are on the boundary, and which must be integrated.

    A face met twice, once each way, by cells of equal density cancels exactly
    and is left out; met twice the same way, or more than twice, cells overlap.

    Returns
    -------
    faces : ndarray (f, 3); face_cell : ndarray (f,); boundary, kept : ndarray (f,) bool
    """
    faces = tets[:, _TET_FACES].reshape(-1, 3)
    face_cell = np.repeat(cell, 4)
    # A face with a repeated node has zero cone integrals: drop it exactly.
    proper = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 2] != faces[:, 0])
    faces, face_cell = faces[proper], face_cell[proper]
    groups = face_groups(faces)
    labels, first = groups.labels, groups.first
    count = np.bincount(labels)
    a, b, c = faces.T
    parity = ((a > b).astype(np.int64) + (a > c) + (b > c)) & 1
    odd = np.bincount(labels, weights=parity).astype(np.int64)
    overlap = (count > 2) | ((count == 2) & (odd != 1))
    if overlap.any():
        raise MeshGeometryError(f"{int(overlap.sum())} faces are shared by overlapping cells (first: cell "
                                f"{int(face_cell[first[_first_cell(overlap)]])})", path=path,
                                fix="re-mesh the part; cells must not overlap")
    paired = count[labels] == 2
    if rho is not None:
        face_rho = rho[face_cell]
        differs = np.bincount(labels, weights=face_rho != face_rho[first[labels]], minlength=first.size)
        paired &= differs[labels] == 0
    return faces, face_cell, count[labels] == 1, ~paired


def volume_mass_properties(vmesh, *, density=None, mass=None, unit=None, pose=None, repair=False, order=2,
                           density_field=None, density_map=None, path=None):
    """Mass properties of a volume mesh, with one density or one per cell.

    Parameters
    ----------
    vmesh : VolumeMesh
    density, mass, unit, pose
        As for :meth:`MassProperties.from_moments`; with per-cell densities a
        total ``mass`` scales them, and ``density`` fills cells of no group.
    repair : bool
        Reorient inverted cells instead of refusing them.
    order : {0, 1, 2}
        Highest moment to form.
    density_field, density_map
        See :func:`cell_densities`.

    Returns
    -------
    properties : MassProperties
    triangles : int
        Triangles of the boundary surface.
    checks : dict
    warnings : list of str
    """
    if vmesh.n_cells == 0:
        raise MeshGeometryError("the file holds no volume cells", path=path, fix="export a volume mesh")
    rho = cell_densities(vmesh, density=density, density_field=density_field, density_map=density_map,
                         path=path)
    tets, cell = vmesh.tetrahedra()
    points, tets = _used_points(vmesh, tets, path)
    tets, reoriented = _orient_cells(vmesh, points, tets, cell, repair=repair, path=path)
    faces, face_cell, boundary, kept = _paired_faces(tets, cell, rho, path)
    surface = faces[boundary]
    if rho is None:
        moments = integrate(points, surface, order=order)
        properties = MassProperties.from_moments(moments, density=density, mass=mass, unit=unit, pose=pose,
                                                 path=path)
    else:
        volume_moments = integrate(points, surface, order=0)
        moments = integrate(points, faces[kept], order=order, weights=rho[face_cell[kept]])
        properties = MassProperties.from_cell_moments(volume_moments, moments, mass=mass, unit=unit, pose=pose,
                                                      path=path)
    warnings = list(vmesh.notes)
    if reoriented:
        warnings.append(f"reoriented {reoriented} inverted cells (their node order was mirrored)")
    bent, nonplanar = nonplanar_quads(vmesh.points, vmesh.blocks, CELL_FACES)
    if bent:
        warnings.append(bent)
    checks = {"closed": True, "orientation": "cells positive" + (", some reoriented" if reoriented else ""),
              "shells": shells(surface, points.shape[0], labels=False)[1], "boundary_edges": 0,
              "cells": vmesh.n_cells, "cell_types": vmesh.cell_types(), "tetrahedra": int(tets.shape[0]),
              "inverted_cells": reoriented, "degenerate_cells": 0, "refined_faces": moments.refined_faces,
              "density": "per cell" if rho is not None else "uniform", "nonplanar_faces": nonplanar,
              "self_intersection": "not checked"}
    return properties, int(surface.shape[0]), checks, warnings
