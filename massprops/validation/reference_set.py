"""The reference set that ``massprops solids DIR`` writes, with its exact expected values.

Each solid is written twice, as binary STL (float32 corners) and as OBJ
(float64 corners written with ``repr``, so they read back bit for bit).  For
every file ``expected.csv`` holds:

* the **exact polyhedral values of the tessellation as written**: rational
  arithmetic (:func:`massprops.validation.exact.exact_properties`) on the corners as the
  file stores them, rounded once — so an STL's row differs from its OBJ's by
  the float32 rounding of the corners;
* the **smooth analytic values** of the ideal solid (:mod:`massprops.validation.analytic`);
* the **tessellation error** between the two (for an STL it includes the
  float32 storage, which dominates far from the origin).

Everything is deterministic: the same call writes the same bytes.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from . import analytic, solids
from ..model.frames import Pose
from ..mesh.surface import TriangleMesh
from .regress import expected_row, write_expected

__all__ = ["ReferenceSolid", "reference_solids", "write_reference_set", "EXTRA_COLUMNS", "POSE_ROTATION",
           "OFFSETS"]

SMOOTH_COLUMNS = ["smooth_volume", "smooth_cx", "smooth_cy", "smooth_cz", "smooth_Ixx", "smooth_Iyy", "smooth_Izz",
                  "smooth_Ixy", "smooth_Ixz", "smooth_Iyz"]
EXTRA_COLUMNS = ["solid", *SMOOTH_COLUMNS, "tess_rel_volume", "tess_com", "tess_rel_inertia"]
# A rotation with no symmetry, so every product of inertia of a posed part is non-zero.
POSE_ROTATION = (0.8, 0.2, -0.4, 0.4)
# Posed variants sit this far from the origin, along a unit direction off every axis.
OFFSETS = (1e3, 1e6)
_DIRECTION = np.array([0.48, -0.6, 0.64])


@dataclass(frozen=True)
class ReferenceSolid:
    """A named mesh with the values of the ideal solid (``smooth``) and, where a closed form exists,
    of the ideal tessellation before float rounding (``polyhedral``)."""

    name: str
    description: str
    mesh: TriangleMesh
    smooth: analytic.Analytic
    polyhedral: analytic.Analytic | None = None


def _revolved(name, description, profile, n, smooth, *, closed=False):
    return ReferenceSolid(name, description, solids.revolve(profile, n, closed=closed), smooth,
                          analytic.revolved_values(profile, n, closed=closed))


def _posed_variants(solid):
    """The solid rotated, then rotated and moved each of :data:`OFFSETS` away."""
    out = []
    for offset in (0.0, *OFFSETS):
        pose = Pose.from_quat(POSE_ROTATION, translation=offset * _DIRECTION)
        name = f"{solid.name}_rotated" if offset == 0 else f"{solid.name}_at_{offset:.0e}".replace("+0", "")
        where = "" if offset == 0 else f", moved {offset:g} away"
        out.append(ReferenceSolid(name, f"{solid.description}, rotated by quat:{POSE_ROTATION}{where}",
                                  solids.posed(solid.mesh, pose), solid.smooth.posed(pose),
                                  solid.polyhedral and solid.polyhedral.posed(pose)))
    return out


def reference_solids(n=32, m=16, subdivisions=2):
    """The reference solids, in a fixed order.

    Parameters
    ----------
    n : int
        Sections around the axis of the solids of revolution.
    m : int
        Stacks of the UV sphere and ellipsoid, sections around the torus's tube.
    subdivisions : int
        Of the icospheres (20·4**s triangles each).
    """
    box_size, box_center = (1.0, 2.0, 3.0), (0.5, 1.0, 1.5)
    box = analytic.box_values(box_size, box_center)
    cylinder_profile = [(0.0, -1.0), (1.0, -1.0), (1.0, 1.0), (0.0, 1.0)]
    bracket = analytic.l_bracket_values()
    base = [
        ReferenceSolid("box", "box 1 x 2 x 3, corner at the origin", solids.box(box_size, box_center), box, box),
        ReferenceSolid("cube", "cube of edge 1, centred", solids.cube(1.0), analytic.box_values(),
                       analytic.box_values()),
        ReferenceSolid("tetrahedron", "regular tetrahedron, edge 2*sqrt(2)", solids.regular_tetrahedron(),
                       analytic.regular_tetrahedron_values(), analytic.regular_tetrahedron_values()),
        ReferenceSolid("octahedron", "regular octahedron, vertices ±1 on the axes", solids.octahedron(),
                       analytic.octahedron_values(), analytic.octahedron_values()),
        ReferenceSolid("icosahedron", "regular icosahedron, edge 2", solids.icosahedron(),
                       analytic.icosahedron_values(), analytic.icosahedron_values()),
        _revolved("cylinder", f"cylinder r=1 h=2 as a {n}-gon prism", cylinder_profile, n,
                  analytic.cylinder_values(1.0, 2.0)),
        _revolved("cone", f"cone r=1 h=3, {n} sections", [(0.0, 0.0), (1.0, 0.0), (0.0, 3.0)], n,
                  analytic.cone_values(1.0, 3.0)),
        _revolved("uv_sphere", f"sphere r=1, {n} sections x {m} stacks", solids.sphere_profile(m), n,
                  analytic.sphere_values(1.0)),
        ReferenceSolid("icosphere", f"sphere r=1, icosahedron subdivided {subdivisions}x",
                       solids.icosphere(subdivisions, 1.0), analytic.sphere_values(1.0)),
        _revolved("torus", f"torus R=2 r=0.5, {n} x {m} sections", solids.torus_profile(m, 2.0, 0.5), n,
                  analytic.torus_values(2.0, 0.5), closed=True),
        ReferenceSolid("hollow_sphere", f"sphere r=1 with a cavity r=0.5, icospheres subdivided {subdivisions}x",
                       solids.hollow_sphere(1.0, 0.5, subdivisions), analytic.hollow_sphere_values(1.0, 0.5)),
        ReferenceSolid("ellipsoid", f"ellipsoid 3 x 2 x 1, a scaled {n} x {m} UV sphere",
                       solids.ellipsoid((3.0, 2.0, 1.0), n, m), analytic.ellipsoid_values((3.0, 2.0, 1.0)),
                       analytic.revolved_values(solids.sphere_profile(m), n).scaled((3.0, 2.0, 1.0))),
        ReferenceSolid("l_bracket", "L-bracket, legs 3, thickness 1, height 1", solids.l_bracket(), bracket,
                       bracket),
    ]
    by_name = {s.name: s for s in base}
    return base + _posed_variants(by_name["l_bracket"]) + _posed_variants(by_name["cylinder"])


def _floats(exact):
    """(volume, center_of_mass (3,), inertia_com (3, 3)) rounded once from exact values."""
    return (float(exact["volume"]), np.array([float(x) for x in exact["center_of_mass"]]),
            np.array([[float(x) for x in row] for row in exact["inertia_com"]]))


def exact_row(label, triangles, solid):
    """The expected.csv row of one file: exact values of ``triangles`` (as stored), smooth values, errors."""
    from .exact import exact_properties
    from ..model.principal import principal

    volume, center, inertia = _floats(exact_properties(triangles))
    row = expected_row(label, volume=volume, mass=volume, center_of_mass=center, inertia_com=inertia,
                       principal=principal(inertia), triangles=len(triangles))
    smooth = solid.smooth
    row["solid"] = solid.description
    row.update(zip(SMOOTH_COLUMNS, map(repr, [float(smooth.volume), *map(float, smooth.center_of_mass),
                                              *(float(smooth.inertia_com[i, j]) for i, j in _TENSOR_ORDER)])))
    row["tess_rel_volume"] = repr((volume - smooth.volume) / smooth.volume)
    row["tess_com"] = repr(float(np.abs(center - smooth.center_of_mass).max()))
    row["tess_rel_inertia"] = repr(float(np.abs(inertia - smooth.inertia_com).max() / np.abs(smooth.inertia_com).max()))
    return row


_TENSOR_ORDER = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def write_reference_set(directory, reference=None):
    """Write every solid as ``NAME.stl`` and ``NAME.obj`` into ``directory``, and ``expected.csv`` beside them.

    Parameters
    ----------
    directory : str or os.PathLike
        Created if missing; files of the same names are overwritten.
    reference : sequence of ReferenceSolid, optional
        Default :func:`reference_solids`.

    Returns
    -------
    list of dict
        The rows written to ``expected.csv`` (one per file, sorted by file name).
    """
    from ..io import obj, stl

    directory = os.fspath(directory)
    os.makedirs(directory, exist_ok=True)
    rows = []
    for solid in reference_solids() if reference is None else reference:
        triangles = solid.mesh.triangles
        stl.write_binary(os.path.join(directory, f"{solid.name}.stl"), triangles,
                         header=f"massprops reference solid {solid.name}".encode())
        # The STL holds float32 corners: its exact values are those of the rounded corners.
        rows.append(exact_row(f"{solid.name}.stl", triangles.astype(np.float32), solid))
        obj.write(os.path.join(directory, f"{solid.name}.obj"), solid.mesh.vertices, solid.mesh.faces,
                  comment=f"massprops reference solid {solid.name}: {solid.description}")
        rows.append(exact_row(f"{solid.name}.obj", triangles, solid))
    write_expected(os.path.join(directory, "expected.csv"), rows, extra_columns=EXTRA_COLUMNS)
    return sorted(rows, key=lambda r: r["file"])
