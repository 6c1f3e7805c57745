"""Geometries of one link that overlap: meshes and boxes united (each point once), exactly placed unions as the
oracle; primitives united too (tests/test_robot_union.py has their closed-form unions)."""

import math
from fractions import Fraction

import numpy as np
import pytest

from massprops.model.frames import Pose
from massprops.robot.links import MassSettings, link_properties
from massprops.robot.model import Geometry, Link, RobotModel, rpy_rotation
from massprops.validation import solids
from massprops.validation.exact import exact_properties

U = 2.0 ** -53
CUBE = solids.cube()          # [-1/2, 1/2]³, outward


def _link(*geometries):
    link = Link("l", geometries)
    return link_properties(RobotModel("m.urdf", "urdf", "m", (link,)), link, MassSettings(density=1.0), None)


def _mesh(name, mesh=CUBE, scale=None, xyz=(0, 0, 0), rpy=(0, 0, 0)):
    pose = Pose(rpy_rotation(rpy), translation=xyz)
    return Geometry("mesh", "collision", name, pose=pose, mesh=mesh, scale=scale)


# -- exact oracles ---------------------------------------------------------------

def _raw(values):
    """``(V, ∫x, ∫x xᵀ)`` from exact ``(V, c, J)`` (Fractions): the moments add over disjoint regions."""
    volume, c, j = values["volume"], values["center_of_mass"], values["inertia_com"]
    half = sum(j[k][k] for k in range(3)) / 2
    second = [[(half if a == b else 0) - j[a][b] + volume * c[a] * c[b] for b in range(3)] for a in range(3)]
    return volume, [volume * x for x in c], second


def _signed_sum(terms):
    """``(V, c, J)`` of Σ sign · region, from raw moments: inclusion-exclusion of exact regions."""
    volume = sum(s * _raw(t)[0] for s, t in terms)
    first = [sum(s * _raw(t)[1][k] for s, t in terms) for k in range(3)]
    second = [[sum(s * _raw(t)[2][a][b] for s, t in terms) for b in range(3)] for a in range(3)]
    c = [x / volume for x in first]
    central = [[second[a][b] - volume * c[a] * c[b] for b in range(3)] for a in range(3)]
    trace = sum(central[k][k] for k in range(3))
    return volume, c, [[(trace if a == b else 0) - central[a][b] for b in range(3)] for a in range(3)]


def _placed_box(low, high, rotation=None, translation=(0, 0, 0)):
    """Exact properties of the box ``[low, high]`` mapped by ``x ↦ R x + t`` in rationals (R the floats)."""
    r = np.eye(3) if rotation is None else rotation
    r = [[Fraction(float(x)) for x in row] for row in r]
    t = [Fraction(float(x)) for x in translation]
    corners = np.array([[[Fraction(h if (k >> a) & 1 else l) for a, (l, h) in enumerate(zip(low, high))]
                         for k in face] for face in _CUBE_CORNERS], dtype=object)
    placed = np.empty_like(corners)
    for f in range(corners.shape[0]):
        for v in range(3):
            placed[f, v] = [sum(r[i][k] * corners[f, v][k] for k in range(3)) + t[i] for i in range(3)]
    return exact_properties(placed)


# The unit cube's 12 outward triangles, corners numbered by bits (x, y, z).
_CUBE_CORNERS = [(0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6), (0, 1, 5), (0, 5, 4),
                 (2, 6, 7), (2, 7, 3), (0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5)]


def _covers(props, exact):
    """Every computed value within its bound of the exact one (rounded once: half an ulp more)."""
    volume, c, j = exact
    for actual, wanted, bound in ((props.volume, [volume], props.error.volume),
                                  (props.center_of_mass, c, props.error.center_of_mass),
                                  (props.inertia_com, j, props.error.inertia_com)):
        wanted = np.array([[float(x) for x in row] for row in wanted] if isinstance(wanted[0], list)
                          else [float(x) for x in wanted])
        assert float(np.abs(np.asarray(actual, float) - wanted).max()) <= bound + U * float(np.abs(wanted).max())


def _sum_misses(props, exact):
    """The computed volume is not the exact union's even allowing 10⁶ times its bound (a double count would be)."""
    return abs(props.volume - float(exact[0])) > 1e6 * props.error.volume


# -- meshes ----------------------------------------------------------------------

def test_two_overlapping_mesh_boxes_are_their_union():
    # A = [0,2]×[0,1]×[0,1] and B = [1,2.5]×[0.5,2]×[0.25,1.5] overlap in [1,2]×[0.5,1]×[0.25,1] (0.375):
    # the union is an asymmetric solid whose products of inertia are not zero.
    a = _mesh("a", scale=(2, 1, 1), xyz=(1, 0.5, 0.5))
    b = _mesh("b", scale=(1.5, 1.5, 1.25), xyz=(1.75, 1.25, 0.875))
    link = _link(a, b)
    exact = _signed_sum([(1, _placed_box((0, 0, 0), (2, 1, 1))), (1, _placed_box((1, 0.5, 0.25), (2.5, 2, 1.5))),
                         (-1, _placed_box((1, 0.5, 0.25), (2, 1, 1)))])
    _covers(link.props, exact)
    assert link.props.error.volume < 1e-13
    assert abs(link.checks["overlap"] - 0.375) <= 1e-13
    assert link.checks["united"] == [["a", "b"]]
    assert any("'a' and 'b' overlap by 0.375 m³; counted once" in w for w in link.warnings)


def test_a_box_primitive_unites_with_a_mesh_exactly():
    # The box primitive is 12 exact triangles: the same union as two meshes.
    a = _mesh("a", scale=(2, 1, 1), xyz=(1, 0.5, 0.5))
    b = Geometry("box", "collision", "b", pose=Pose(translation=(1.75, 1.25, 0.875)), size={"size": (1.5, 1.5, 1.25)})
    link = _link(a, b)
    exact = _signed_sum([(1, _placed_box((0, 0, 0), (2, 1, 1))), (1, _placed_box((1, 0.5, 0.25), (2.5, 2, 1.5))),
                         (-1, _placed_box((1, 0.5, 0.25), (2, 1, 1)))])
    _covers(link.props, exact)
    assert not _sum_misses(link.props, exact) and link.checks["overlap"] > 0.37


def test_disjoint_meshes_whose_boxes_meet_keep_the_exact_sum():
    # Two tetrahedra in opposite corners of overlapping boxes: x+y+z <= 1 and x+y+z >= 2.6 never meet.
    first = solids.tetrahedron()
    second = solids.tetrahedron(((1.2, 1.2, 1.2), (0.2, 1.2, 1.2), (1.2, 0.2, 1.2), (1.2, 1.2, 0.2)))
    if exact_properties(second.vertices[second.faces])["volume"] < 0:
        second = second.with_faces(second.faces[:, ::-1].copy())
    link = _link(_mesh("a", first), _mesh("b", second))
    alone = [_link(_mesh("a", first)).props, _link(_mesh("b", second)).props]
    exact = _signed_sum([(1, exact_properties(m.vertices[m.faces])) for m in (first, second)])
    _covers(link.props, exact)
    assert link.checks == {"overlap": 0.0, "duplicate_shells": 0, "unresolved_overlap": 0.0}
    assert not link.warnings
    # The sum of the parts as before: their own bounds (no placement rounding added).
    assert link.props.error.mass <= 1.01 * (alone[0].error.mass + alone[1].error.mass) + 32 * U * link.props.mass


def test_a_mesh_nested_in_another_counts_once():
    outer = _mesh("outer", scale=(4, 4, 4))
    inner = _mesh("inner", mesh=solids.posed(solids.l_bracket(), Pose(translation=(-1.5, -1.5, -0.5))))
    link = _link(outer, inner)
    _covers(link.props, _signed_sum([(1, _placed_box((-2, -2, -2), (2, 2, 2)))]))
    inner_volume = float(exact_properties(solids.l_bracket().vertices[solids.l_bracket().faces])["volume"])
    assert abs(link.checks["overlap"] - inner_volume) <= 1e-12
    assert any("inside" in w for w in link.warnings)


def test_the_same_mesh_twice_is_one_solid():
    link = _link(_mesh("a", scale=(2, 1, 1)), _mesh("b", scale=(2, 1, 1)))
    _covers(link.props, _signed_sum([(1, _placed_box((-1, -0.5, -0.5), (1, 0.5, 0.5)))]))
    assert link.checks["duplicate_shells"] == 1 and link.checks["overlap"] == pytest.approx(2.0, abs=1e-13)


@pytest.mark.parametrize("rpy", [(0.3, -0.2, 0.7), (1.1, 0.4, -2.3)])
def test_rotated_and_scaled_meshes_whose_placement_rounds(rpy):
    # Decimal scales and a rotation: placing the vertices rounds them.  Both boxes share the rotation R, so in
    # R's frame (rational R⁻¹) they are axis-aligned and their intersection is a box: the exact union of the
    # rationally placed boxes is A + B − A∩B.
    scale_a = tuple(Fraction(x) for x in ("0.3", "0.2", "0.1"))
    scale_b = tuple(Fraction(x) for x in ("0.15", "0.25", "0.3"))
    t_a, t_b = (0.1, -0.2, 0.05), (0.17, -0.13, 0.08)
    link = _link(_mesh("a", scale=scale_a, xyz=t_a, rpy=rpy), _mesh("b", scale=scale_b, xyz=t_b, rpy=rpy))
    rotation = rpy_rotation(rpy)
    r = [[Fraction(float(x)) for x in row] for row in rotation]
    offset = _solve(r, [Fraction(float(y)) - Fraction(float(x)) for x, y in zip(t_a, t_b)])   # R⁻¹ (t_b − t_a)
    box_a = ([-s / 2 for s in scale_a], [s / 2 for s in scale_a])
    box_b = ([o - s / 2 for o, s in zip(offset, scale_b)], [o + s / 2 for o, s in zip(offset, scale_b)])
    common = ([max(x, y) for x, y in zip(box_a[0], box_b[0])], [min(x, y) for x, y in zip(box_a[1], box_b[1])])
    assert all(l < h for l, h in zip(*common))
    exact = _signed_sum([(s, _placed_box(*box, rotation=rotation, translation=t_a))
                         for s, box in ((1, box_a), (1, box_b), (-1, common))])
    _covers(link.props, exact)
    assert not _sum_misses(link.props, exact)
    assert link.props.error.volume < 1e-12 * link.props.volume


def _solve(r, b):
    """``r⁻¹ b`` in rationals (Cramer's rule)."""
    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    d = det(r)
    return [det([[b[i] if k == col else r[i][k] for k in range(3)] for i in range(3)]) / d for col in range(3)]


# -- primitives ------------------------------------------------------------------

def _capsule_exact(r, length):
    """A capsule's exact ``(V, c, J)``: a cylinder and two hemispheres, π as the rational of ``math.pi``."""
    pi = Fraction(math.pi)
    r, h = Fraction(r), Fraction(length)
    cylinder = pi * r * r * h
    hemisphere = Fraction(2, 3) * pi * r ** 3
    offset = h / 2 + Fraction(3, 8) * r
    across = Fraction(2, 5) * hemisphere * r * r - hemisphere * (Fraction(3, 8) * r) ** 2 + hemisphere * offset ** 2
    transverse = cylinder * (3 * r * r + h * h) / 12 + 2 * across
    axial = cylinder * r * r / 2 + 2 * Fraction(2, 5) * hemisphere * r * r
    return cylinder + 2 * hemisphere, [0, 0, 0], [[transverse, 0, 0], [0, transverse, 0], [0, 0, axial]]


def test_a_cylinder_capped_by_two_spheres_is_a_capsule():
    # The union of a cylinder and a sphere on each end is a capsule (closed form); the sum counts two
    # hemispheres twice.  The link is the union, with bounds of rounding only.
    r, length = 0.25, 1.0
    cylinder = Geometry("cylinder", "collision", "c", size={"radius": r, "length": length})
    spheres = [Geometry("sphere", "collision", f"s{k}", pose=Pose(translation=(0, 0, z)), size={"radius": r})
               for k, z in enumerate((-0.5, 0.5))]
    link = _link(cylinder, *spheres)
    exact = _capsule_exact(r, length)
    twice = 4 / 3 * math.pi * r ** 3
    assert link.checks["unresolved_overlap"] == 0
    assert link.checks["overlap"] == pytest.approx(twice, rel=1e-12)
    _covers(link.props, exact)
    assert link.props.error.volume <= 1e-9 * link.props.volume
    assert any("overlap by 0.0654 m³" in w for w in link.warnings)


def test_two_spheres_whose_boxes_meet_but_not_they_are_decided_exactly():
    # Centres sqrt(3)·0.75 ≈ 1.3 apart, radii 0.5 and 0.6: the boxes overlap, the balls do not.
    a = Geometry("sphere", "collision", "a", size={"radius": 0.5})
    b = Geometry("sphere", "collision", "b", pose=Pose(translation=(0.75, 0.75, 0.75)), size={"radius": 0.6})
    link = _link(a, b)
    assert link.checks["unresolved_overlap"] == 0 and not link.warnings


def test_two_overlapping_spheres_are_their_union():
    a = Geometry("sphere", "collision", "a", size={"radius": 0.5})
    b = Geometry("sphere", "collision", "b", pose=Pose(translation=(0.5, 0, 0)), size={"radius": 0.5})
    link = _link(a, b)
    # The exact lens counted twice: π (4r + d)(2r − d)² / 12 with d = r.
    lens = math.pi * (4 * 0.5 + 0.5) * (2 * 0.5 - 0.5) ** 2 / 12
    assert link.checks["overlap"] == pytest.approx(lens, rel=1e-12)
    union = 2 * 4 / 3 * math.pi * 0.5 ** 3 - lens
    assert abs(link.props.volume - union) <= link.props.error.volume + 4 * U * union
    assert link.props.error.volume <= 1e-9 * union


def test_touching_primitives_add_no_warning():
    # A cylinder standing on a box, written to touch: their exact boxes meet in a face, no volume.
    box = Geometry("box", "collision", "b", size={"size": (1.0, 1.0, 0.5)})
    cylinder = Geometry("cylinder", "collision", "c", pose=Pose(translation=(0, 0, 0.75)),
                        size={"radius": 0.25, "length": 0.5})
    link = _link(box, cylinder)
    assert link.checks["unresolved_overlap"] == 0 and not link.warnings


def test_placement_far_from_the_origin_is_in_the_bound():
    # An ellipsoid-like mesh with a box nested in it, both placed 2 km from the origin with decimal scales and a
    # rotation: every placed vertex rounds by ~u·2000, far more than the integration's own rounding near the
    # part.  The union is the outer mesh, placed exactly in rationals the oracle.
    outer_mesh = solids.icosphere(2)
    scale = tuple(Fraction(x) for x in ("0.3", "0.2", "0.25"))
    xyz, rpy = (1000.1, -2000.3, 500.7), (0.3, -0.2, 0.7)
    outer = _mesh("outer", outer_mesh, scale=scale, xyz=xyz, rpy=rpy)
    inner = _mesh("inner", scale=(Fraction("0.05"),) * 3, xyz=xyz, rpy=rpy)
    link = _link(outer, inner)
    r = [[Fraction(float(x)) for x in row] for row in rpy_rotation(rpy)]
    t = [Fraction(float(x)) for x in xyz]
    points = [[sum(r[i][k] * scale[k] * Fraction(float(v[k])) for k in range(3)) + t[i] for i in range(3)]
              for v in outer_mesh.vertices]
    triangles = np.array([[points[k] for k in face] for face in outer_mesh.faces.tolist()], dtype=object)
    exact = exact_properties(triangles)
    _covers(link.props, (exact["volume"], exact["center_of_mass"], exact["inertia_com"]))
    assert link.checks["overlap"] > 0 and any("inside" in w for w in link.warnings)


def test_meshes_sharing_a_face_keep_the_sum():
    # Two cubes side by side touch on a face (no volume): the link is the plain sum, nothing said.
    link = _link(_mesh("a", xyz=(0.5, 0.5, 0.5)), _mesh("b", xyz=(1.5, 0.5, 0.5)))
    exact = _signed_sum([(1, _placed_box((0, 0, 0), (2, 1, 1)))])
    _covers(link.props, exact)
    assert link.props.volume == 2.0 and link.props.center_of_mass[0] == 1.0
    assert link.checks["overlap"] == 0 and not link.warnings



def test_copies_of_one_cylinder_are_one_cylinder(tmp_path):
    # Four copies of one cylinder: the union is one cylinder, in the link and in the robot's total.
    from massprops.robot.analyze import RobotSettings, analyze

    r, length = 0.25, 1.0
    copies = [Geometry("cylinder", "collision", f"c{k}", size={"radius": r, "length": length}) for k in range(4)]
    link = _link(*copies)
    one = math.pi * r * r * length
    props = link.props
    assert props.volume == pytest.approx(one, rel=1e-14)
    assert props.error.mass <= 1e-9 * props.mass
    axial, transverse = one * r * r / 2, one * (3 * r * r + length * length) / 12
    _covers(props, (Fraction(one), [0, 0, 0], [[transverse, 0, 0], [0, transverse, 0], [0, 0, axial]]))
    cylinder = f'<collision><geometry><cylinder radius="{r}" length="{length}"/></geometry></collision>'
    path = tmp_path / "copies.urdf"
    path.write_text(f'<robot name="r"><link name="l">{cylinder * 4}</link></robot>')
    whole = analyze(str(path), RobotSettings(command="props", density=1.0))
    assert whole["status"] == "ok" and whole["links"][0]["status"] == "ok"
    assert whole["total"]["mass"] == pytest.approx(one, rel=1e-14)
