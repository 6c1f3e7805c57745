"""Volume meshes: cells against their boundary surface, per-cell density, splits, bad cells."""

from __future__ import annotations

import itertools
import json
from fractions import Fraction

import meshio
import numpy as np
import pytest

import massprops.cli
from massprops.validation import solids
from massprops import mass_properties
from massprops.mesh.volume import VolumeMesh, parse_density_map

STEEL, ALUMINIUM = 7850.0, 2700.0


def kuhn_tets(cubes, size=1.0):
    """Unit cubes (i, j, k) split into 6 tetrahedra each along their main diagonal (Kuhn).

    The split is conforming by construction, independent of the code under
    test; each tetrahedron is oriented positive with an exact determinant.
    """
    index, points, tets = {}, [], []

    def node(p):
        if p not in index:
            index[p] = len(points)
            points.append([size * x for x in p])
        return index[p]

    for cube in cubes:
        for perm in itertools.permutations(range(3)):
            corner = list(cube)
            tet = [node(tuple(corner))]
            for axis in perm:
                corner[axis] += 1
                tet.append(node(tuple(corner)))
            tets.append(tet)
    points, tets = np.array(points, dtype=float), np.array(tets)
    for t in tets:
        if _exact_six_volume(points[t]) < 0:
            t[[2, 3]] = t[[3, 2]]
    return points, tets


def _exact_six_volume(p):
    a, b, c, d = ([Fraction(float(x)) for x in row] for row in p)
    e = [[u - v for u, v in zip(q, a)] for q in (b, c, d)]
    return (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0])
            + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]))


def exact_cells(points, tets, rho):
    """Exact mass, center of mass and inertia about it of tetrahedra with densities ``rho`` (Fractions).

    Per tetrahedron of volume V: ∫1 = V, ∫x = V Σp/4, ∫x xᵀ = V/20 (Σp Σpᵀ + Σ p pᵀ).
    """
    m0, m1, m2 = Fraction(0), [Fraction(0)] * 3, [[Fraction(0)] * 3 for _ in range(3)]
    for tet, density in zip(tets, rho):
        p = [[Fraction(float(x)) for x in points[k]] for k in tet]
        weight = Fraction(float(density)) * _exact_six_volume(points[tet]) / 6
        s = [sum(q[i] for q in p) for i in range(3)]
        m0 += weight
        m1 = [m1[i] + weight * s[i] / 4 for i in range(3)]
        for i, j in itertools.product(range(3), range(3)):
            m2[i][j] += weight / 20 * (s[i] * s[j] + sum(q[i] * q[j] for q in p))
    com = [x / m0 for x in m1]
    c = [[m2[i][j] - m0 * com[i] * com[j] for j in range(3)] for i in range(3)]
    trace = c[0][0] + c[1][1] + c[2][2]
    return m0, com, [[(trace if i == j else 0) - c[i][j] for j in range(3)] for i in range(3)]


def assert_matches(props, mass, com, inertia, rtol=1e-12):
    """Relative agreement, and the reported bounds cover the actual error."""
    assert abs(Fraction(props.mass) - mass) <= rtol * mass
    assert abs(Fraction(props.mass) - mass) <= Fraction(props.error.mass)
    size = max(abs(x) for x in com) + 1
    for ours, exact in zip(props.center_of_mass, com):
        assert abs(Fraction(float(ours)) - exact) <= rtol * size
        assert abs(Fraction(float(ours)) - exact) <= Fraction(props.error.center_of_mass)
    scale = max(abs(x) for row in inertia for x in row)
    for i, j in itertools.product(range(3), range(3)):
        diff = abs(Fraction(float(props.inertia_com[i, j])) - inertia[i][j])
        assert diff <= rtol * scale
        assert diff <= Fraction(props.error.inertia_com)


L_CUBES = [(i, 0, 0) for i in range(3)] + [(0, j, 0) for j in (1, 2)]


@pytest.mark.parametrize("suffix", [".vtu", ".msh"])
def test_tet_mesh_equals_its_boundary_surface(tmp_path, suffix):
    # An L-shape (products of inertia non-zero), far from the origin and rotated.
    from conftest import random_rotation
    rotation, offset = random_rotation(8), np.array([1000.25, -3.5, 7.0])
    points, tets = kuhn_tets(L_CUBES, size=0.5)
    path = str(tmp_path / f"l{suffix}")
    meshio.write(path, meshio.Mesh(points @ rotation.T + offset, [("tetra", tets)]),
                 **({"file_format": "gmsh22", "binary": False} if suffix == ".msh" else {}))
    cells = mass_properties(path).properties
    surface = mass_properties(solids.l_bracket(1.5, 0.5, 0.5).transformed(rotation, offset)).properties
    assert abs(cells.volume - surface.volume) <= 1e-12 * surface.volume
    assert np.abs(cells.center_of_mass - surface.center_of_mass).max() <= 1e-12 * 1000
    scale = np.abs(surface.inertia_com).max()
    assert np.abs(cells.inertia_com - surface.inertia_com).max() <= 1e-12 * scale
    assert abs(cells.surface_area - surface.surface_area) <= 1e-12 * surface.surface_area


def _two_material_bar(tmp_path):
    """A 2×1×1 bar of two unit cubes, cells tagged steel (x < 1) and aluminium, as Gmsh MSH."""
    points, tets = kuhn_tets([(0, 0, 0), (1, 0, 0)])
    steel = points[tets].mean(axis=1)[:, 0] < 1
    tags = np.where(steel, 1, 2)
    path = str(tmp_path / "bar.msh")
    meshio.write(path, meshio.Mesh(points, [("tetra", tets)], cell_data={"gmsh:physical": [tags],
                                                                          "gmsh:geometrical": [tags]},
                                   field_data={"steel": np.array([1, 3]), "aluminium": np.array([2, 3])}),
                 file_format="gmsh22", binary=False)
    return path


def test_two_material_bar_against_closed_form(tmp_path, runner):
    path = _two_material_bar(tmp_path)
    result = runner.invoke(massprops.cli.main, ["props", path, "--density-map",
                                                f"steel={STEEL},aluminium={ALUMINIUM}", "--format", "json"])
    assert result.exit_code == 0, result.output
    obj = json.loads(result.stdout)[0]
    # Closed form: two unit cubes centred at x = 1/2 and 3/2.
    ms, ma = Fraction(STEEL), Fraction(ALUMINIUM)
    mass = ms + ma
    cx = (ms / 2 + ma * 3 / 2) / mass
    own = [mass / 6, mass / 6, mass / 6]                        # (1 + 1)/12 per unit cube
    shift = ms * (Fraction(1, 2) - cx) ** 2 + ma * (Fraction(3, 2) - cx) ** 2
    expected = [[own[0], 0, 0], [0, own[1] + shift, 0], [0, 0, own[2] + shift]]
    assert obj["volume"] == pytest.approx(2.0, rel=1e-15)
    assert obj["mass"] == pytest.approx(float(mass), rel=1e-15)
    assert obj["density"] == pytest.approx(float(mass / 2), rel=1e-15)
    assert obj["center_of_mass"] == pytest.approx([float(cx), 0.5, 0.5], rel=1e-14)
    assert np.allclose(obj["inertia_com"], np.array(expected, dtype=float), rtol=1e-13, atol=1e-10)
    assert obj["checks"]["density"] == "per cell"
    # The physical tags name the same groups; --density fills cells in no listed group.
    tagged = runner.invoke(massprops.cli.main, ["props", path, "--density-map", f"1={STEEL}", "--density",
                                                str(ALUMINIUM), "--format", "json"])
    assert json.loads(tagged.stdout)[0]["mass"] == obj["mass"]


def test_linear_density_field_against_exact_sum(tmp_path):
    """ρ = 1 + 2x − y/4 sampled at each cell's centroid (per-cell constant, as the file stores it).

    The exact answer is then the Fraction sum over the cells of ρ_c ∫_cell (1, x, x xᵀ);
    the nodes are jittered so that no cell is axis-aligned.
    """
    points, tets = kuhn_tets([(i, j, k) for i in range(2) for j in range(2) for k in range(2)], size=0.5)
    interior = np.all((points > 0) & (points < 1), axis=1)
    points[interior] += np.random.default_rng(3).uniform(-0.05, 0.05, size=(interior.sum(), 3))
    centroid = points[tets].mean(axis=1)
    rho = 1 + 2 * centroid[:, 0] - centroid[:, 1] / 4
    path = str(tmp_path / "field.vtu")
    meshio.write(path, meshio.Mesh(points, [("tetra", tets)], cell_data={"rho": [rho]}))
    props = mass_properties(path, density_field="rho").properties
    assert_matches(props, *exact_cells(points, tets, rho))
    assert props.volume == pytest.approx(1.0, rel=1e-14)


def test_density_field_on_a_fine_grid_keeps_its_weights():
    """12³ cubes (10 368 cells, heavy cancellation between interior faces): ρ_c = 1 + x_c at centroids.

    Σ_c ρ_c V_c = V + Σ_c V_c x_c = V + ∫x dV exactly, for the cube [0, 3/4]³: (27/64)(1 + 3/8).
    """
    points, tets = kuhn_tets([(i, j, k) for i in range(12) for j in range(12) for k in range(12)], size=1 / 16)
    rho = 1 + points[tets].mean(axis=1)[:, 0]
    props = mass_properties(VolumeMesh(points, (("tetra", tets),), {"rho": rho}), density_field="rho").properties
    mass = Fraction(27, 64) * Fraction(11, 8)
    assert abs(Fraction(props.mass) - mass) <= Fraction(props.error.mass) <= 1e-12 * mass
    assert props.volume == 27 / 64


def _hexahedron(matrix, origin):
    unit = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    return unit @ np.asarray(matrix, float).T + origin


def test_hexahedron_parallelepiped_closed_form(tmp_path):
    # x = A u + o over the unit cube: V = det A, centroid A/2 + o, ∫(x − c)(x − c)ᵀ = V A Aᵀ / 12.
    a = [[2, 0.5, 0], [0.25, 1, 0.5], [0, -0.5, 1.5]]
    origin = np.array([3.0, -1.0, 2.0])
    path = str(tmp_path / "hex.vtu")
    meshio.write(path, meshio.Mesh(_hexahedron(a, origin), [("hexahedron", np.arange(8)[None])]))
    props = mass_properties(path, density=3.0).properties
    A = [[Fraction(x) for x in row] for row in a]
    volume = (A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) - A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0])
              + A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]))
    mass = 3 * volume
    com = [sum(A[i]) / 2 + Fraction(origin[i]) for i in range(3)]
    c = [[mass * sum(A[i][k] * A[j][k] for k in range(3)) / 12 for j in range(3)] for i in range(3)]
    trace = c[0][0] + c[1][1] + c[2][2]
    assert_matches(props, mass, com, [[(trace if i == j else 0) - c[i][j] for j in range(3)] for i in range(3)])


@pytest.mark.parametrize("suffix, order", [(".vtu", [0, 1, 2, 3, 4, 5]), (".msh", [0, 2, 1, 3, 5, 4])])
def test_wedge_closed_form(tmp_path, suffix, order):
    # Right triangle (0,0) (a,0) (0,b) extruded by h; Gmsh numbers the first triangle the other way round.
    a, b, h = Fraction(2), Fraction(3), Fraction(1, 2)
    base = [(0, 0), (0, 3), (2, 0)]                      # VTK: normal of (0, 1, 2) points away from the top
    points = np.array([(x, y, z) for z in (0, 0.5) for x, y in base], float)
    path = str(tmp_path / f"wedge{suffix}")
    meshio.write(path, meshio.Mesh(points, [("wedge", np.array([order]))]),
                 **({"file_format": "gmsh22", "binary": False} if suffix == ".msh" else {}))
    props = mass_properties(path).properties
    volume = a * b * h / 2
    com = [a / 3, b / 3, h / 2]
    m2 = [[h * a ** 3 * b / 12, h * a ** 2 * b ** 2 / 24, a ** 2 * b / 6 * h ** 2 / 2],
          [0, h * a * b ** 3 / 12, a * b ** 2 / 6 * h ** 2 / 2], [0, 0, a * b / 2 * h ** 3 / 3]]
    c = [[m2[min(i, j)][max(i, j)] - volume * com[i] * com[j] for j in range(3)] for i in range(3)]
    trace = c[0][0] + c[1][1] + c[2][2]
    assert_matches(props, volume, com, [[(trace if i == j else 0) - c[i][j] for j in range(3)] for i in range(3)])


def test_pyramid_closed_form(tmp_path):
    # Square base of side s at z = 0, apex at height h: I_zz = m s²/10, I_xx = m (s²/20 + 3h²/80).
    s, h = Fraction(2), Fraction(3)
    points = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0], [0, 0, 3]], float)
    path = str(tmp_path / "pyramid.vtu")
    meshio.write(path, meshio.Mesh(points, [("pyramid", np.arange(5)[None])]))
    props = mass_properties(path).properties
    mass = s * s * h / 3
    side = mass * (s * s / 20 + 3 * h * h / 80)
    assert_matches(props, mass, [0, 0, h / 4], [[side, 0, 0], [0, side, 0], [0, 0, mass * s * s / 10]])


def test_warped_shared_face_is_split_the_same_way_by_both_cells(tmp_path):
    # Two hexahedra sharing a non-planar face, listed from a different corner in each cell.
    bottom = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.2], [0, 1, 0]], float)
    points = np.vstack([bottom, bottom + [0, 0, 1], bottom + [0, 0, 2.3]])
    first = [0, 1, 2, 3, 4, 5, 6, 7]
    second = [5, 6, 7, 4, 9, 10, 11, 8]                  # same cell shape, numbering rotated
    path = str(tmp_path / "two_hex.vtu")
    meshio.write(path, meshio.Mesh(points, [("hexahedron", np.array([first, second]))]))
    result = mass_properties(path)
    assert result.triangles == 20                        # the shared face cancelled: 10 quads left
    alone = [mass_properties(VolumeMesh(points, (("hexahedron", np.array([cell])),))).properties.volume
             for cell in (first, second)]
    assert result.properties.volume == pytest.approx(sum(alone), rel=1e-15)


def test_volume_json_has_the_surface_keys(tmp_path, runner):
    points, tets = kuhn_tets([(0, 0, 0)])
    path = str(tmp_path / "cube.vtu")
    meshio.write(path, meshio.Mesh(points, [("tetra", tets)]))
    result = runner.invoke(massprops.cli.main, ["props", path, "--format", "json"])
    assert result.exit_code == 0, result.output
    obj = json.loads(result.stdout)[0]
    for key in ("file", "triangles", "volume", "mass", "density", "surface_area", "center_of_mass",
                "inertia_com", "principal_moments", "principal_axes", "degenerate", "center_of_mass_global",
                "inertia_com_global", "inertia_origin", "error", "checks", "warnings", "elapsed_s"):
        assert key in obj
    assert obj["triangles"] == 12 and obj["checks"]["cells"] == 6
    assert obj["principal_axes"] == [[1, 0, 0], [0, 1, 0], [0, 0, 1]]


def _bad(tmp_path, name, *, flip=None, rho=None, collapse=False):
    points, tets = kuhn_tets([(0, 0, 0), (1, 0, 0)])
    if flip is not None:
        rows = np.atleast_1d(flip)
        tets[np.ix_(rows, [2, 3])] = tets[np.ix_(rows, [3, 2])]
    if collapse:
        tets[4, 3] = tets[4, 2]
    path = str(tmp_path / name)
    data = {} if rho is None else {"rho": [rho]}
    meshio.write(path, meshio.Mesh(points, [("tetra", tets)], cell_data=data))
    return path


def test_bad_volume_meshes_give_one_line(tmp_path, runner):
    rho = np.full(12, 2.0)
    rho[[3, 7]] = np.nan
    cases = [
        (_bad(tmp_path, "inverted.vtu", flip=5), [], "1 cells are inverted (negative volume; first: cell 5)"),
        (_bad(tmp_path, "nan.vtu", rho=rho), ["--density-field", "rho"],
         "2 cells have a negative or non-finite density (first: cell 3"),
        (_bad(tmp_path, "nofield.vtu"), ["--density-field", "rho"], "no cell data named 'rho'"),
        (_bad(tmp_path, "flat.vtu", collapse=True), [], "1 cells have zero volume (degenerate; first: cell 4)"),
        (_two_material_bar(tmp_path), ["--density-map", "steel=1"], "6 cells are in no group of --density-map"),
        (_two_material_bar(tmp_path), ["--density-map", "brass=1"], "no cell group named 'brass'"),
    ]
    for path, extra, fragment in cases:
        result = runner.invoke(massprops.cli.main, ["props", path, *extra])
        assert result.exit_code == 1, (path, result.output)
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: {path}: ") and fragment in lines[0], lines
        assert "Traceback" not in result.output


def test_repair_reorients_inverted_cells(tmp_path, runner):
    path = _bad(tmp_path, "inverted.vtu", flip=[2, 5])
    result = runner.invoke(massprops.cli.main, ["props", path, "--repair", "--format", "json"])
    assert result.exit_code == 0, result.output
    obj = json.loads(result.stdout)[0]
    assert obj["volume"] == pytest.approx(2.0, rel=1e-15)
    assert "reoriented 2 inverted cells" in " ".join(obj["warnings"])


def test_density_options_are_checked(tmp_path, runner):
    assert parse_density_map("a=1, b = 2.5") == {"a": 1.0, "b": 2.5}
    result = runner.invoke(massprops.cli.main, ["props", "x.vtu", "--density-map", "steel"])
    assert result.exit_code == 2 and "GROUP=VALUE" in result.output
    stl = str(tmp_path / "cube.stl")
    from massprops.io.stl import write_binary
    write_binary(stl, solids.box().triangles)
    result = runner.invoke(massprops.cli.main, ["props", stl, "--density-field", "rho"])
    assert result.exit_code == 1 and "need a volume mesh" in result.stderr
