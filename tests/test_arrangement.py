"""Every closed soup gets its solid ``{w > 0}``: faces that cross, coincide, repeat or cancel (SPEC).

Oracles are exact and independent of the arrangement: rational polygon areas
for prisms, and a coordinate-compressed grid in rationals for signed unions
of axis-aligned boxes (each cell's winding number is the signed count of
boxes holding its centre; its moments are closed forms).
"""

import itertools
from fractions import Fraction

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given, settings, strategies as st

from massprops.cli import main
from massprops import mass_properties
from massprops.model.errors import OpenMeshError
from massprops.io.stl import write_binary
from massprops.mesh.surface import TriangleMesh
from massprops.validation import solids
from oracle import exact_properties, within_bounds


# --- the grid oracle -------------------------------------------------------------------------------

def grid_oracle(boxes):
    """Exact moments of ``{w > 0}`` for signed boxes ``[(low, high, sign), ...]`` (rational corners)."""
    cuts = [sorted({Fraction(b[k][axis]) for b in boxes for k in (0, 1)}) for axis in range(3)]
    volume = Fraction(0)
    first = [Fraction(0)] * 3
    second = [[Fraction(0)] * 3 for _ in range(3)]
    for cell in itertools.product(*(zip(c[:-1], c[1:]) for c in cuts)):
        centre = [(lo + hi) / 2 for lo, hi in cell]
        w = sum(sign for low, high, sign in boxes
                if all(Fraction(low[a]) < centre[a] < Fraction(high[a]) for a in range(3)))
        if w <= 0:
            continue
        d = [hi - lo for lo, hi in cell]
        v = d[0] * d[1] * d[2]
        volume += v
        mean = [(lo + hi) / 2 for lo, hi in cell]
        square = [(hi ** 3 - lo ** 3) / 3 / (hi - lo) for lo, hi in cell]      # mean of x² over the side
        for i in range(3):
            first[i] += v * mean[i]
            for j in range(3):
                second[i][j] += v * (square[i] if i == j else mean[i] * mean[j])
    if volume == 0:
        return {"volume": volume}
    g = [x / volume for x in first]
    central = [[second[i][j] - volume * g[i] * g[j] for j in range(3)] for i in range(3)]
    trace = central[0][0] + central[1][1] + central[2][2]
    inertia = [[(trace if i == j else 0) - central[i][j] for j in range(3)] for i in range(3)]
    return {"volume": volume, "center_of_mass": g, "inertia_com": inertia}


def box_soup(boxes):
    """The boxes as one triangle soup (inward for sign -1), each box its own 8 corners."""
    meshes = []
    for low, high, sign in boxes:
        low, high = np.asarray(low, float), np.asarray(high, float)
        mesh = solids.box(tuple(high - low), tuple((high + low) / 2))
        meshes.append(mesh if sign > 0 else mesh.flipped())
    return solids.combine(*meshes)


def soup(mesh):
    """A mesh given as a soup of triangles, welded again by exact coordinates."""
    return TriangleMesh.from_triangles(mesh.triangles)


def test_the_grid_oracle_agrees_with_the_triangle_oracle_on_one_box():
    box = [((0, 0, 0), (2, 3, 1), 1)]
    exact = exact_properties(box_soup(box).triangles)
    assert grid_oracle(box) == {"volume": exact["volume"], "center_of_mass": exact["center_of_mass"],
                                "inertia_com": exact["inertia_com"]}


# --- prisms over self-crossing polygons ------------------------------------------------------------

def _fan(k):
    return [(0, i, i + 1) for i in range(1, k - 1)]


def _shoelace(points):
    return sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(points, points[1:] + points[:1])) / 2


def _meet(p, q, r, s):
    """The point where lines pq and rs cross (exact)."""
    (x1, y1), (x2, y2), (x3, y3), (x4, y4) = p, q, r, s
    d = (x1 - x2) * (y3 - y4) - (y1 - y2) * (x3 - x4)
    a, b = x1 * y2 - y1 * x2, x3 * y4 - y3 * x4
    return ((a * (x3 - x4) - (x1 - x2) * b) / d, (a * (y3 - y4) - (y1 - y2) * b) / d)


def test_a_prism_over_a_pentagram_drawn_as_one_loop_is_the_star():
    # The centre pentagon has winding number 2; {w > 0} is the star's outline times the height.
    angles = [np.pi / 2 + 2 * np.pi * k / 5 for k in range(5)]
    tips = [(float(np.cos(a)), float(np.sin(a))) for a in angles]
    loop = [tips[(2 * k) % 5] for k in range(5)]
    star = solids.prism(loop, _fan(5), 0.75)
    result = mass_properties(star)
    exact_tips = [(Fraction(x), Fraction(y)) for x, y in tips]
    outline = []
    for k in range(5):
        outline.append(exact_tips[k])
        # the inner corner between tips k and k+1: chords (k-1 .. k+1) and (k .. k+2) cross there
        outline.append(_meet(exact_tips[k], exact_tips[(k + 2) % 5], exact_tips[(k + 1) % 5],
                             exact_tips[(k - 1) % 5]))
    area = _shoelace(outline)
    assert abs(Fraction(result.properties.volume) - area * Fraction(0.75)) <= Fraction(result.properties.error.volume)
    signed = exact_properties(star.triangles)["volume"]
    assert signed > area * Fraction(0.75)                      # the signed volume counts the centre twice
    assert result.checks["self_intersection"] == "resolved"
    assert any("crosses itself" in w for w in result.warnings)


def test_a_prism_over_a_bowtie_is_its_positive_lobe():
    # Lobes of winding +1 (below the crossing) and -1 (above): the solid is the lower lobe alone.
    bowtie = solids.prism([(0.0, 0.0), (2.0, 0.0), (0.0, 2.0), (2.0, 2.0)], _fan(4), 1.0)
    lobe = solids.prism([(0.0, 0.0), (2.0, 0.0), (1.0, 1.0)], [(0, 1, 2)], 1.0)
    result = mass_properties(bowtie)
    within_bounds(result.properties, exact_properties(lobe.triangles))
    assert result.properties.volume == 1.0
    assert any("wound inward" in w for w in result.warnings)


def test_a_sphere_with_a_dent_pushed_through_the_opposite_side():
    # An icosphere whose top vertex is pushed down through the bottom: the faces around it cross the
    # lower hemisphere.  Independent check: the compiled core's exact ray counts at the points of a fine
    # grid, summed, agree with the volume to the grid's resolution; the signed volume does not.
    sphere = solids.icosphere(1, 1.0)
    vertices = sphere.vertices.copy()
    vertices[int(np.argmax(vertices[:, 2]))] = [0.0, 0.0, -1.5]
    result = mass_properties(TriangleMesh(vertices, sphere.faces))
    assert result.checks["self_intersection"] == "resolved"
    signed = float(exact_properties(vertices[sphere.faces])["volume"])
    xs = np.linspace(-1, 1, 41)
    zs = np.linspace(-1.6, 1, 53)
    grid = np.array(np.meshgrid(xs, xs, zs, indexing="ij")).reshape(3, -1).T + 1e-7
    from massprops.core.intersect import ExactGeometry
    geometry = ExactGeometry(np.vstack([vertices, grid]))
    w = geometry.winding(sphere.faces, np.arange(vertices.shape[0], vertices.shape[0] + grid.shape[0]))
    sampled = float(np.count_nonzero(w > 0)) * (xs[1] - xs[0]) ** 2 * (zs[1] - zs[0])
    assert abs(result.properties.volume - sampled) < 0.03 * sampled
    assert result.checks["overlap"] == pytest.approx(signed - result.properties.volume, rel=1e-9)


def test_a_box_with_a_dent_pushed_through_the_opposite_side():
    # The top's middle square pushed down through the bottom: an inward column whose top cancels the
    # top face there; below the bottom it encloses w = -1, which is not solid.
    boxes = [((0, 0, 0), (4, 4, 2), 1), ((1, 1, -1), (3, 2, 2), -1)]
    result = mass_properties(box_soup(boxes))
    within_bounds(result.properties, grid_oracle(boxes))
    assert result.properties.volume == 28.0


def test_two_cubes_sharing_a_face_cancel_it():
    left = [((0, 0, 0), (1, 1, 1), 1)]
    right = [((1, 0, 0), (2, 1, 1), 1)]
    welded = soup(box_soup(left + right))            # the shared corners weld: the shared faces cancel
    result = mass_properties(welded)
    within_bounds(result.properties, grid_oracle([((0, 0, 0), (2, 1, 1), 1)]))
    # the other diagonal on one side: the shared squares overlap as different triangles, and still cancel
    other = box_soup(right)
    faces = other.faces.copy()
    faces[[0, 1]] = [[0, 1, 2], [1, 3, 2]]           # the x = 1 face, split along the other diagonal
    crossed = soup(solids.combine(box_soup(left), TriangleMesh(other.vertices, faces)))
    result = mass_properties(crossed)
    within_bounds(result.properties, grid_oracle([((0, 0, 0), (2, 1, 1), 1)]))


def test_a_cube_written_twice_and_a_cube_with_a_closed_part_written_twice():
    cube = box_soup([((0, 0, 0), (1, 2, 3), 1)])
    twice = solids.combine(cube, cube)
    result = mass_properties(twice)
    within_bounds(result.properties, grid_oracle([((0, 0, 0), (1, 2, 3), 1)]))
    # The top square again, once each way: a closed two-sided part; the soup stays closed.
    top = cube.faces[[2, 3]]
    extra = TriangleMesh(cube.vertices, np.vstack([cube.faces, top, top[:, ::-1], cube.faces[:4]]))
    with pytest.raises(OpenMeshError):
        mass_properties(extra)                       # four faces written once more: not closed
    extra = TriangleMesh(cube.vertices, np.vstack([cube.faces, top, top[:, ::-1]]))
    result = mass_properties(extra)
    within_bounds(result.properties, grid_oracle([((0, 0, 0), (1, 2, 3), 1)]))


def test_a_cube_with_one_face_written_twice_is_refused_naming_it():
    cube = box_soup([((0, 0, 0), (1, 1, 1), 1)])
    path_faces = np.vstack([cube.faces, cube.faces[5:6]])
    with pytest.raises(OpenMeshError, match=r"face 12 is face 5 duplicated"):
        mass_properties(TriangleMesh(cube.vertices, path_faces))


def test_a_cavity_crossing_the_body_surface():
    boxes = [((0, 0, 0), (2, 2, 2), 1), ((1, Fraction(1, 2), Fraction(1, 2)), (3, Fraction(3, 2), 1), -1)]
    result = mass_properties(box_soup(boxes))
    within_bounds(result.properties, grid_oracle(boxes))
    assert any("cavity" in w for w in result.warnings)


def test_a_two_sided_export_is_the_solid_one_side_encloses():
    cube = box_soup([((0, 0, 0), (1, 2, 4), 1)])
    order = np.random.default_rng(3).permutation(24)
    both = TriangleMesh(cube.vertices, np.vstack([cube.faces, cube.faces[:, ::-1]])[order])
    result = mass_properties(both)
    within_bounds(result.properties, grid_oracle([((0, 0, 0), (1, 2, 4), 1)]))
    assert any("two-sided export" in w for w in result.warnings)


def test_coplanar_overlapping_faces_of_two_boxes():
    boxes = [((0, 0, 0), (1, 1, 1), 1), ((Fraction(1, 2), Fraction(1, 2), 0), (Fraction(3, 2), Fraction(3, 2), 1), 1)]
    result = mass_properties(box_soup(boxes))
    within_bounds(result.properties, grid_oracle(boxes))
    assert result.checks["overlap"] == pytest.approx(0.25)


@pytest.mark.parametrize("boxes", [
    # Found by the property below: boxes touching along edges (one shell of faces sharing vertices), one inward.
    [((0, 65, 65), (65, 195, 130), 1), ((0, 195, 0), (65, 260, 65), -1), ((0, 0, 0), (65, 65, 65), 1)],
    # A cube and a larger cube wound inward, touching at one corner: the signed volume is 1 - 8.
    [((0, 0, 0), (1, 1, 1), 1), ((1, 1, 1), (3, 3, 3), -1)],
    # Two outward cubes touching at a corner, and one sharing an edge with the first.
    [((0, 0, 0), (1, 1, 1), 1), ((1, 1, 1), (2, 2, 2), 1), ((1, 1, 0), (2, 2, 1), 1)],
])
def test_bodies_touching_at_a_vertex_or_an_edge_are_told_apart(boxes):
    """Welded, they are one shell of faces sharing vertices; each body still counts by its own winding."""
    result = mass_properties(soup(box_soup(boxes)))
    within_bounds(result.properties, grid_oracle(boxes))
    assert any("wound inward" in w for w in result.warnings) == any(sign < 0 for *_, sign in boxes)


def test_the_cli_gives_a_number_and_a_warning_for_a_self_crossing_file(tmp_path):
    bowtie = solids.prism([(0.0, 0.0), (2.0, 0.0), (0.0, 2.0), (2.0, 2.0)], _fan(4), 1.0)
    path = tmp_path / "bowtie.stl"
    write_binary(path, bowtie.triangles)
    result = CliRunner().invoke(main, ["props", str(path), "--only", "volume"])
    assert result.exit_code == 0, result.output
    assert "crosses itself" in result.output and "volume                 1 " in result.output


# --- the property: signed unions of boxes, as soups ------------------------------------------------

# Integer corners that stay integers under rotations by the (3, 4, 5) and (5, 12, 13) triangles.
_ROTATIONS = [np.array(m, dtype=object) for m in (
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
    [[Fraction(3, 5), Fraction(-4, 5), 0], [Fraction(4, 5), Fraction(3, 5), 0], [0, 0, 1]],
    [[1, 0, 0], [0, Fraction(5, 13), Fraction(-12, 13)], [0, Fraction(12, 13), Fraction(5, 13)]],
    [[0, 0, 1], [-1, 0, 0], [0, -1, 0]],
)]


def _rotated(exact, rotation):
    r = [[Fraction(x) for x in row] for row in rotation.tolist()]
    g = [sum(r[i][k] * exact["center_of_mass"][k] for k in range(3)) for i in range(3)]
    j = exact["inertia_com"]
    inertia = [[sum(r[i][a] * j[a][b] * r[k][b] for a in range(3) for b in range(3)) for k in range(3)]
               for i in range(3)]
    return {"volume": exact["volume"], "center_of_mass": g, "inertia_com": inertia}


def _turned_soup(boxes, rotation, random=None):
    """:func:`box_soup` of ``boxes`` turned by the rational ``rotation`` (each coordinate rounded once), its
    faces shuffled by ``random`` if given."""
    mesh = box_soup(boxes)
    vertices = np.array([[float(sum(rotation[i][k] * int(v[k]) for k in range(3))) for i in range(3)]
                         for v in mesh.vertices.tolist()])
    faces = mesh.faces.tolist()
    if random is not None:
        random.shuffle(faces)
    return TriangleMesh(vertices, np.array(faces, dtype=np.int64))


_corner = st.integers(0, 6).map(lambda k: 65 * k)


@st.composite
def _box(draw):
    low = [draw(_corner) for _ in range(3)]
    high = [x + 65 * draw(st.integers(1, 3)) for x in low]
    return tuple(low), tuple(high), draw(st.sampled_from([1, 1, 1, -1]))


@settings(max_examples=40, deadline=None)
@given(st.lists(_box(), min_size=1, max_size=4), st.integers(0, 3), st.randoms(use_true_random=False),
       st.integers(0, 2))
def test_signed_unions_of_boxes_match_the_grid_oracle(boxes, rotation, random, repeats):
    if sum(sign for *_, sign in boxes) < 1:
        boxes = boxes + [((0, 0, 0), (65, 65, 65), 1)]
    exact = grid_oracle(boxes)
    if exact["volume"] == 0:
        return
    matrix = _ROTATIONS[rotation]
    result_mesh = _turned_soup(boxes, matrix, random)
    copies = [b for b in boxes if random.random() < 0.3 * repeats]
    if copies:
        result_mesh = solids.combine(result_mesh, _turned_soup(copies, matrix))
        exact = grid_oracle(boxes + copies)
    result = mass_properties(soup(result_mesh))
    within_bounds(result.properties, _rotated(exact, matrix))
