"""A mismatch explains itself against the link's geometry: beyond_geometry (no density inside it gives the declared
second moments), com_outside_geometry, or non_uniform (consistent with some density inside it).

Fixtures are built here from closed forms: a box link whose declared inertial adds a spinning disc wider than
the box (a motor's rotor), one whose center of mass is outside it, and one of a dense core inside a light shell."""

import math
from fractions import Fraction as F

from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings, strategies as st

from massprops.cli import main
from massprops.robot.analyze import RobotSettings, analyze


def _cube(mass, side):
    """The central tensor of a uniform cube: m a² / 6 on the diagonal."""
    return mass * side * side / 6


def _urdf(tmp_path, name, mass, com, inertia, geometry='<box size="0.1 0.1 0.1"/>'):
    ixx, iyy, izz = inertia
    text = f"""<robot name="{name}">
  <link name="base">
    <inertial><origin xyz="{com[0]!r} {com[1]!r} {com[2]!r}"/><mass value="{mass!r}"/>
      <inertia ixx="{ixx!r}" ixy="0" ixz="0" iyy="{iyy!r}" iyz="0" izz="{izz!r}"/></inertial>
    <collision><geometry>{geometry}</geometry></collision>
  </link>
</robot>"""
    path = tmp_path / f"{name}.urdf"
    path.write_text(text)
    return str(path)


def _check(path):
    obj = analyze(path, RobotSettings(command="check"))
    (link,) = obj["links"]
    return link


def test_a_rotor_spinning_outside_the_geometry_is_beyond_it(tmp_path):
    # A 0.1 m cube of 1 kg plus a 0.5 kg disc of radius 0.3 m spinning about z: m r²/2 about z, m r²/4 across.
    box = _cube(1.0, 0.1)
    disc_axial, disc_across = 0.5 * 0.09 / 2, 0.5 * 0.09 / 4
    link = _check(_urdf(tmp_path, "rotor", 1.5, (0.0, 0.0, 0.0),
                        (box + disc_across, box + disc_across, box + disc_axial)))
    assert link["status"] == "mismatch"
    assert "beyond_geometry" in link["diagnoses"]
    assert "non_uniform" not in link["diagnoses"] and "com_outside_geometry" not in link["diagnoses"]
    assert "farther out than the link's geometry reaches" in link["message"]


def test_the_same_rotor_inside_a_wide_enough_geometry_is_not_beyond_it(tmp_path):
    # The same numbers on a 0.7 m cube: a disc of radius 0.3 fits inside, so some density gives them.
    box = _cube(1.0, 0.1)
    disc_axial, disc_across = 0.5 * 0.09 / 2, 0.5 * 0.09 / 4
    link = _check(_urdf(tmp_path, "wide", 1.5, (0.0, 0.0, 0.0),
                        (box + disc_across, box + disc_across, box + disc_axial), '<box size="0.7 0.7 0.7"/>'))
    assert link["status"] == "mismatch"
    assert link["diagnoses"] == ["non_uniform"]


def test_a_center_of_mass_outside_the_geometry(tmp_path):
    box = _cube(1.0, 0.1)
    link = _check(_urdf(tmp_path, "away", 1.0, (0.2, 0.0, 0.0), (box, box, box)))
    assert link["status"] == "mismatch"
    assert "com_outside_geometry" in link["diagnoses"]
    detail = next(d for d in link["diagnosis_details"] if d["name"] == "com_outside_geometry")
    # The cube reaches x = 0.05: the center is 0.15 m beyond it (the bound is certified, so not less).
    assert 0.149 < detail["distance"] <= 0.15


def test_a_center_of_mass_just_inside_is_not_outside(tmp_path):
    box = _cube(1.0, 0.1)
    link = _check(_urdf(tmp_path, "edge", 1.0, (0.0499, 0.0, 0.0), (box, box, box)))
    assert "com_outside_geometry" not in link["diagnoses"]


def test_a_dense_core_in_a_light_shell_is_non_uniform(tmp_path):
    # A 0.2 m cube of density 1 around a 0.1 m core of density 10: J = Σ ρ_k (a_k⁵/6) as differences of cubes.
    shell, core = F(1), F(10)
    mass = shell * F(8, 1000) + (core - shell) * F(1, 1000)
    moment = shell * F(8, 1000) * F(4, 100) / 6 + (core - shell) * F(1, 1000) * F(1, 100) / 6
    link = _check(_urdf(tmp_path, "core", float(mass), (0.0, 0.0, 0.0), (float(moment),) * 3,
                        '<box size="0.2 0.2 0.2"/>'))
    assert link["status"] == "mismatch"
    assert link["diagnoses"] == ["non_uniform"]
    assert "consistent with some non-uniform density inside the geometry" in link["message"]


def test_the_text_ends_with_what_causes_each_diagnosis(tmp_path):
    box = _cube(1.0, 0.1)
    path = _urdf(tmp_path, "rotor", 1.5, (0.0, 0.0, 0.0), (box + 0.01125, box + 0.01125, box + 0.0225))
    result = CliRunner().invoke(main, ["robot", "check", path])
    assert result.exit_code == 0, result.output
    last = result.output.rstrip().splitlines()[-1]
    assert last.strip().startswith("beyond_geometry: usually rotor inertia")
    assert "`massprops robot write`" in last


def test_a_mismatch_on_a_sphere_link_is_explained(tmp_path):
    # A 0.1 m sphere whose declared moments are those of a hollow shell (2/3 m r²): more spread than the
    # uniform ball's 2/5 m r², but still inside the ball, so non_uniform.
    r = 0.1
    shell = 2 / 3 * 1.0 * r * r
    link = _check(_urdf(tmp_path, "ball", 1.0, (0.0, 0.0, 0.0), (shell,) * 3, f'<sphere radius="{r}"/>'))
    assert link["status"] == "mismatch" and link["diagnoses"] == ["non_uniform"]
    # Twice that spread cannot be inside it: ∫|x|² dm = tr(J)/2 = 2 m r² exceeds the m r² of any mass in the ball.
    link = _check(_urdf(tmp_path, "ball2", 1.0, (0.0, 0.0, 0.0), (2 * shell,) * 3, f'<sphere radius="{r}"/>'))
    assert "beyond_geometry" in link["diagnoses"]
    assert math.isfinite(link["diagnosis_details"][0]["ratio"])


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(st.floats(0.1, 10.0), st.floats(-0.99, 0.99), st.floats(-0.99, 0.99),
                          st.floats(-0.99, 0.99)), min_size=1, max_size=6))
def test_point_masses_inside_the_geometry_are_never_beyond_it(tmp_path, masses):
    # Any masses inside the box (within 99% of its half extents) are some density inside it: neither certified
    # diagnosis may name them, whatever their spread.
    half = (0.05, 0.1, 0.2)
    m = F(0)
    first = [F(0)] * 3
    second = [[F(0)] * 3 for _ in range(3)]
    for weight, *where in masses:
        w = F(weight)
        x = [F(where[k]) * F(half[k]) for k in range(3)]
        m += w
        for a in range(3):
            first[a] += w * x[a]
            for b in range(3):
                second[a][b] += w * x[a] * x[b]
    c = [f / m for f in first]
    central = [[second[a][b] - m * c[a] * c[b] for b in range(3)] for a in range(3)]
    trace = sum(central[k][k] for k in range(3))
    j = [[(trace if a == b else 0) - central[a][b] for b in range(3)] for a in range(3)]
    if min(j[0][0], j[1][1], j[2][2]) <= 0:
        return
    text = f"""<robot name="p"><link name="base">
    <inertial><origin xyz="{float(c[0])!r} {float(c[1])!r} {float(c[2])!r}"/><mass value="{float(m)!r}"/>
      <inertia ixx="{float(j[0][0])!r}" ixy="{float(j[0][1])!r}" ixz="{float(j[0][2])!r}" iyy="{float(j[1][1])!r}"
               iyz="{float(j[1][2])!r}" izz="{float(j[2][2])!r}"/></inertial>
    <collision><geometry><box size="0.1 0.2 0.4"/></geometry></collision></link></robot>"""
    path = tmp_path / "points.urdf"
    path.write_text(text)
    link = _check(str(path))
    assert "beyond_geometry" not in link["diagnoses"]
    assert "com_outside_geometry" not in link["diagnoses"]
