"""Overlapping primitives of a link: their union computed (each point once) with a bound at most the tolerance.

Oracles are closed forms (tests/union_oracle.py): a union cut into pieces whose moments are textbook integrals (cylinder
slabs, spherical caps, boxes), in rationals times π."""

import math
from fractions import Fraction as F

import numpy as np
import pytest

from massprops.model.frames import Pose
from massprops.robot.model import Geometry, rpy_rotation

from union_oracle import (U, box as _box, cap as _cap, central, disk_slab as _disk_slab, link as _link,
                          shifted as _shifted, within)


def _sum(*signed):
    return central(*signed)


def _holds(props, exact, tolerance=1e-9):
    """Every value within its bound of the closed form, and every bound at most the tolerance (relative)."""
    within(props, exact)
    volume, c, j = exact
    scale_j = max(abs(float(x)) for row in j for x in row)
    assert props.error.volume <= tolerance * props.volume
    assert props.error.mass <= tolerance * props.mass
    assert props.error.inertia_com <= tolerance * scale_j
    size = max(abs(float(x)) for x in c) or 1.0
    assert props.error.center_of_mass <= tolerance * size


def test_two_coaxial_cylinders():
    # r 0.3 on z ∈ [−0.5, 0.5] and r 0.2 on z ∈ [0.2, 1.2], both on the axis x = 0.1, y = −0.2.
    axis = (0.1, -0.2)
    big = Geometry("cylinder", "collision", "big", pose=Pose(translation=(*axis, 0.0)),
                   size={"radius": 0.3, "length": 1.0})
    small = Geometry("cylinder", "collision", "small", pose=Pose(translation=(*axis, 0.7)),
                     size={"radius": 0.2, "length": 1.0})
    link = _link(big, small)
    x, y = F(axis[0]), F(axis[1])
    exact = _sum((1, _disk_slab(0.3, F(-1, 2), F(1, 2), x, y)),
                 (1, _disk_slab(0.2, F(1, 2), F(0.7) + F(1, 2), x, y)))
    _holds(link.props, exact)
    assert link.checks["overlap"] == pytest.approx(math.pi * 0.04 * 0.3, rel=1e-12)
    assert link.checks["unresolved_overlap"] == 0


def test_a_sphere_inside_a_box():
    box = Geometry("box", "collision", "b", size={"size": (1.0, 0.8, 0.6)})
    ball = Geometry("sphere", "collision", "s", pose=Pose(translation=(0.2, -0.1, 0.02)), size={"radius": 0.25})
    link = _link(box, ball)
    half = [F(1, 2), F(0.8) / 2, F(0.6) / 2]
    _holds(link.props, _sum((1, _box([-h for h in half], half))))


def test_two_spheres_overlapping_in_a_lens():
    # Radii 0.5 and 0.4, centres 0.6 apart on z: the planes of the lens is z = (d² + r1² − r2²) / 2d = 0.375.
    a = Geometry("sphere", "collision", "a", size={"radius": 0.5})
    b = Geometry("sphere", "collision", "b", pose=Pose(translation=(0, 0, 0.6)), size={"radius": 0.4})
    link = _link(a, b)
    d = F(0.6)
    r1, r2 = F(0.5), F(0.4)
    plane = (d * d + r1 * r1 - r2 * r2) / (2 * d)
    exact = _sum((1, _cap(0.5, F(0), -r1, plane)), (1, _cap(0.4, d, plane, d + r2)))
    _holds(link.props, exact)


def test_two_spheres_off_the_axes_are_a_lens_too():
    # The centres differ in every coordinate: the axis through them is rounded, and the bound covers that.
    a = Geometry("sphere", "collision", "a", pose=Pose(translation=(0.1, 0.2, 0.3)), size={"radius": 0.5})
    b = Geometry("sphere", "collision", "b", pose=Pose(translation=(0.4, 0.6, 0.3)), size={"radius": 0.5})
    link = _link(a, b)
    # Centres 0.5 apart (a 3-4-5 triangle), equal radii: the lens's plane halfway; the union's volume.
    d = 0.5
    lens = math.pi * (4 * 0.5 + d) * (2 * 0.5 - d) ** 2 / 12
    union = 2 * 4 / 3 * math.pi * 0.125 - lens
    assert abs(link.props.volume - union) <= link.props.error.volume + 4 * U * union
    assert link.props.error.volume <= 1e-9 * union
    assert link.props.center_of_mass == pytest.approx([0.25, 0.4, 0.3], abs=1e-12)


def test_a_capsule_through_a_box_face():
    # The box [−0.5, 0.5]³; a capsule on z (r 0.2, cylinder z ∈ [0.3, 0.9]) enters through the top face.
    box = Geometry("box", "collision", "b", size={"size": (1.0, 1.0, 1.0)})
    capsule = Geometry("capsule", "collision", "c", pose=Pose(translation=(0.1, 0.05, 0.6)),
                       size={"radius": 0.2, "length": 0.6})
    link = _link(box, capsule)
    x, y = F(0.1), F(0.05)
    half = [F(1, 2)] * 3
    exact = _sum((1, _box([-h for h in half], half)),
                 (1, _disk_slab(0.2, F(1, 2), F(0.6) + F(0.3), x, y)),
                 (1, _shifted(_cap(0.2, F(0.6) + F(0.3), F(0.6) + F(0.3), F(0.6) + F(0.3) + F(0.2)), (x, y, F(0)))))
    _holds(link.props, exact)
    assert any("overlap by 0.0419 m³" in w for w in link.warnings)    # 0.008π + 0.016π/3 m³


def test_crossing_cylinders_are_bounded_honestly_when_the_refinement_stops(monkeypatch):
    # Two cylinders of radius r crossing at right angles (a Steinmetz solid 16r³/3 in common): no closed form
    # is used, the grid stops at its budget (made small here to keep the test fast), and the bound still holds
    # and says so.
    import massprops.robot.curved as curved
    monkeypatch.setattr(curved, "_CELL_BUDGET", 300_000)
    r = 0.2
    a = Geometry("cylinder", "collision", "a", size={"radius": r, "length": 1.0})
    b = Geometry("cylinder", "collision", "b", pose=Pose(rotation=np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])),
                 size={"radius": r, "length": 1.0})
    link = _link(a, b)
    union = 2 * math.pi * r * r - 16 * r ** 3 / 3
    assert abs(link.props.volume - union) <= link.props.error.volume
    assert link.props.error.volume < 0.05 * union
    assert any("not the 1e-09 asked" in w for w in link.warnings)
    # Asking for less stops sooner without the warning.
    loose = _link(a, b, tolerance=0.2)
    assert abs(loose.props.volume - union) <= loose.props.error.volume
    assert not any("asked" in w for w in loose.warnings)


def test_a_box_with_two_half_cylinders_along_its_edges_is_bounded_across():
    # A quadruped's face: a box 0.11 × 0.14 × 0.18 with cylinders (r 0.09) along x centred on its faces
    # y = ±0.07, which also overlap each other inside the box.  Three solids meet, all prisms along x: exact in
    # x, refined across.  The union is the box plus two half cylinders: (0.14 · 0.18 + π 0.09²) · 0.11.
    across = Pose(rpy_rotation((0, math.pi / 2, 0)))
    box = Geometry("box", "collision", "b", size={"size": (0.11, 0.14, 0.18)})
    cylinders = [Geometry("cylinder", "collision", f"c{k}", pose=Pose(across.rotation, translation=(0, y, 0)),
                          size={"radius": 0.09, "length": 0.11}) for k, y in enumerate((0.07, -0.07))]
    link = _link(box, *cylinders, tolerance=1e-3)
    union = (0.14 * 0.18 + math.pi * 0.09 ** 2) * 0.11
    assert abs(link.props.volume - union) <= link.props.error.volume + 4 * U * union
    assert link.props.error.volume <= 1e-3 * union
    assert link.props.center_of_mass == pytest.approx([0, 0, 0], abs=link.props.error.center_of_mass + 1e-15)


def test_the_cli_asks_for_a_tolerance_and_says_when_it_was_not_reached(tmp_path, monkeypatch):
    from click.testing import CliRunner

    import massprops.robot.curved as curved
    from massprops.cli import main
    monkeypatch.setattr(curved, "_CELL_BUDGET", 200_000)
    cylinder = '<collision><origin rpy="{}"/><geometry><cylinder radius="0.2" length="1"/></geometry></collision>'
    path = tmp_path / "cross.urdf"
    path.write_text(f'<robot name="r"><link name="l">{cylinder.format("0 0 0")}{cylinder.format("1.5 0 0")}'
                    "</link></robot>")
    strict = CliRunner().invoke(main, ["robot", "props", str(path), "--density", "1000"])
    assert strict.exit_code == 0, strict.output
    assert "not the 1e-09 asked (--tolerance)" in strict.output
    loose = CliRunner().invoke(main, ["robot", "props", str(path), "--density", "1000", "--tolerance", "0.3"])
    assert loose.exit_code == 0 and "asked" not in loose.output
    refused = CliRunner().invoke(main, ["robot", "props", str(path), "--tolerance", "0"])
    assert refused.exit_code == 2
