"""Curved primitives overlapping meshes: their union, computed through inner and outer polyhedra with a bound that
holds and shrinks with --tolerance.

Oracles are closed forms (tests/union_oracle.py: a cube plus the parts of a sphere, cylinder or capsule outside it: cylinder
slabs and spherical caps, in rationals times π) or exact sums."""

import math
from fractions import Fraction as F

import pytest

from massprops.model.frames import Pose
from massprops.robot.model import Geometry
from massprops.validation import solids

from union_oracle import (PI, U, box as _box, cap as _cap, central, disk_slab as _disk_slab, link as _link,
                          shifted as _shifted, within as _holds)

CUBE = solids.cube()       # [-1/2, 1/2]³, outward


@pytest.fixture(autouse=True)
def _no_time_budget(monkeypatch):
    """The refinement's time budget depends on the machine: these tests ask only what the triangles reach."""
    import massprops.robot.overlap as overlap
    monkeypatch.setattr(overlap, "_TIME_BUDGET", math.inf)


def _mesh(scale=None, xyz=(0, 0, 0)):
    return Geometry("mesh", "collision", "hull", pose=Pose(translation=xyz), mesh=CUBE, scale=scale)


def _sum(*raws):
    return central(*((1, r) for r in raws))


HALF = F(1, 2)
CUBE_RAW = _box([-HALF] * 3, [HALF] * 3)


def test_a_sphere_centred_on_a_mesh_face_adds_its_upper_half():
    ball = Geometry("sphere", "collision", "ball", pose=Pose(translation=(0.1, 0.05, 0.5)), size={"radius": 0.3})
    x, y = F(0.1), F(0.05)
    exact = _sum(CUBE_RAW, _cap(0.3, HALF, HALF, HALF + F(0.3), x, y))
    loose = _link(_mesh(), ball, tolerance=1e-2)
    tight = _link(_mesh(), ball, tolerance=1e-4)
    assert _holds(loose.props, exact) <= 1e-2
    assert _holds(tight.props, exact) <= 1e-4
    assert tight.props.error.volume < loose.props.error.volume / 10
    assert tight.checks["unresolved_overlap"] == 0 and tight.checks["united"] == [["hull", "ball"]]
    assert tight.checks["overlap"] == pytest.approx(2 / 3 * math.pi * 0.027, rel=1e-4)
    assert any("'hull' and 'ball' overlap by about 0.0565 m³; counted once" in w for w in tight.warnings)


def test_a_cylinder_through_a_mesh_slab():
    # The slab [−1, 1]² × [−0.1, 0.1]; a cylinder (r 0.2) on z ∈ [−0.45, 0.55] through it, off its centre.
    slab = _mesh(scale=(2.0, 2.0, 0.2))
    rod = Geometry("cylinder", "collision", "rod", pose=Pose(translation=(0.1, 0.2, 0.05)),
                   size={"radius": 0.2, "length": 1.0})
    x, y, tenth = F(0.1), F(0.2), F(0.2) / 2
    low, high = F(0.05) - HALF, F(0.05) + HALF
    exact = _sum(_box([-F(1), -F(1), -tenth], [F(1), F(1), tenth]), _disk_slab(0.2, low, -tenth, x, y),
                 _disk_slab(0.2, tenth, high, x, y))
    coarse = _link(slab, rod, tolerance=1e-3)
    fine = _link(slab, rod, tolerance=1e-4)
    assert _holds(coarse.props, exact) <= 1e-3
    assert _holds(fine.props, exact) <= 1e-4
    assert fine.props.error.mass < coarse.props.error.mass / 4
    assert not any("asked" in w for w in fine.warnings)


def test_a_capsule_whose_end_is_inside_a_mesh():
    # The cube; a capsule on z (r 0.2, its cylinder on z ∈ [0.3, 0.9]): its lower cap and the cylinder up to the
    # top face are inside the cube.
    capsule = Geometry("capsule", "collision", "arm", pose=Pose(translation=(0.1, 0.05, 0.6)),
                       size={"radius": 0.2, "length": 0.6})
    x, y, top = F(0.1), F(0.05), F(0.6) + F(0.3)
    exact = _sum(CUBE_RAW, _disk_slab(0.2, HALF, top, x, y), _cap(0.2, top, top, top + F(0.2), x, y))
    coarse = _link(_mesh(), capsule, tolerance=1e-2)
    fine = _link(_mesh(), capsule, tolerance=1e-3)
    assert _holds(coarse.props, exact) <= 1e-2
    assert _holds(fine.props, exact) <= 1e-3
    assert fine.props.error.mass < coarse.props.error.mass


def test_a_sphere_inside_a_mesh_is_the_mesh():
    ball = Geometry("sphere", "collision", "ball", pose=Pose(translation=(0.1, 0.0, -0.05)), size={"radius": 0.2})
    link = _link(_mesh(), ball)
    assert _holds(link.props, _sum(CUBE_RAW)) <= 1e-9
    assert link.checks["overlap"] == pytest.approx(4 / 3 * math.pi * 0.008, rel=1e-9)


def test_a_mesh_inside_a_cylinder_is_the_cylinder_without_tessellation():
    # The cube inside a cylinder of radius 1 and length 1: their top and bottom faces touch.
    drum = Geometry("cylinder", "collision", "drum", size={"radius": 1.0, "length": 1.0})
    link = _link(drum, _mesh())
    exact = _sum(_disk_slab(1, -HALF, HALF, F(0), F(0)))
    assert _holds(link.props, exact) <= 1e-12
    assert any("mesh 'hull' lies inside cylinder 'drum' (1 m³): counted once" in w for w in link.warnings)


def test_a_sphere_apart_from_a_mesh_whose_box_it_meets_is_summed():
    # The ball near the cube's corner: boxes meet, the solids do not (0.433 from centre to corner > 0.3).
    ball = Geometry("sphere", "collision", "ball", pose=Pose(translation=(0.75, 0.75, 0.75)), size={"radius": 0.3})
    link = _link(_mesh(), ball)
    r, c = F(0.3), F(0.75)
    sxx = PI * 4 * r ** 5 / 15
    sphere = _shifted((PI * 4 * r ** 3 / 3, [F(0)] * 3, [[sxx, 0, 0], [0, sxx, 0], [0, 0, sxx]]), (c, c, c))
    assert _holds(link.props, _sum(CUBE_RAW, sphere)) <= 1e-12
    assert link.checks["overlap"] == 0 and link.warnings == ()


def test_the_cli_shows_the_united_mass(tmp_path, runner):
    from massprops.cli import main
    from massprops.io.stl import write_binary
    write_binary(tmp_path / "cube.stl", CUBE.triangles)
    (tmp_path / "r.urdf").write_text(
        '<robot name="r"><link name="body"><collision><geometry><mesh filename="cube.stl"/></geometry></collision>'
        '<collision><origin xyz="0 0 0.5"/><geometry><sphere radius="0.3"/></geometry></collision></link></robot>')
    result = runner.invoke(main, ["robot", "props", str(tmp_path / "r.urdf"), "--density", "1000",
                                  "--tolerance", "1e-3"])
    assert result.exit_code == 0, result.output
    united = 1000 * (1 + 2 / 3 * math.pi * 0.027)            # 1056.549 kg; counted whole it would be 1113.1 kg
    assert f"{united:.6g}"[:6] in result.output
    assert "overlap by about 0.056" in result.output and "counted once" in result.output


@pytest.mark.parametrize("kind, size, above", [
    # An ellipsoid centred on the cube's top face: its upper half, 2/3 π abc.
    ("ellipsoid", {"radii": (0.2, 0.3, 0.25)}, 2 * PI * F(0.2) * F(0.3) * F(0.25) / 3),
    # A cone (base r 0.2 at z = 0.2, apex at z = 0.8) through the top face: the cone above it, r 0.1 and 0.3 high.
    ("cone", {"radius": 0.2, "length": 0.6}, PI * (F(0.2) * (F(0.8) - HALF) / F(0.6)) ** 2 * (F(0.8) - HALF) / 3),
    # A capsule of length 0 (a sphere) centred on the face.
    ("capsule", {"radius": 0.2, "length": 0.0}, 2 * PI * F(0.2) ** 3 / 3)])
def test_other_curved_primitives_on_a_mesh_face(kind, size, above):
    solid = Geometry(kind, "collision", "p", pose=Pose(translation=(0.1, 0.05, 0.5)), size=size)
    link = _link(_mesh(), solid, tolerance=1e-3)
    union = 1 + above
    assert abs(F(link.props.volume) - union) <= F(link.props.error.volume) + F(4 * U) * union
    assert link.props.error.volume <= 1e-3 * float(union)
