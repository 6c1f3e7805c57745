"""``massprops robot props|check|write`` through click's CliRunner: outputs, exit codes, files written."""

import csv
import io
import json
import os
import subprocess
import sys
import textwrap

import pytest
from click.testing import CliRunner

from massprops.cli import main
from massprops.validation.robots import write_robots


@pytest.fixture(scope="module")
def urdf(tmp_path_factory):
    directory = tmp_path_factory.mktemp("cli_robots")
    expected = write_robots(directory, formats=("urdf",))
    return str(directory / expected["urdf"]["model"]), expected


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _clean_robot(tmp_path):
    path = tmp_path / "clean.urdf"
    path.write_text(textwrap.dedent("""\
        <robot name="clean">
          <link name="a">
            <inertial><origin xyz="0 0 0" rpy="0 0 0"/><mass value="6"/>
              <inertia ixx="6.5" ixy="0" ixz="0" iyy="5" iyz="0" izz="2.5"/></inertial>
            <collision><geometry><box size="1 2 3"/></geometry></collision>
          </link>
          <link name="b">
            <collision><origin xyz="0 0 1"/><geometry><sphere radius="0.5"/></geometry></collision>
          </link>
          <joint name="j" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 2"/>
            <axis xyz="1 0 0"/></joint>
        </robot>
        """), encoding="utf-8")
    return str(path)


def test_props_json_has_the_spec_keys(urdf):
    path, _ = urdf
    result = run("robot", "props", path, "--density", "2700", "--format", "json")
    assert result.exit_code == 1                                     # the open mesh's link is an error
    (model,) = json.loads(result.stdout)
    assert {"model", "format", "geometry", "links", "total"} <= model.keys()
    assert model["format"] == "urdf" and model["geometry"] == "collision"
    link = model["links"][1]
    for key in ("link", "status", "mass", "volume", "center_of_mass", "inertia_com", "principal_moments",
                "principal_axes", "error", "geometries", "declared", "diagnoses", "message"):
        assert key in link, key
    assert {"kind", "uri", "resolved_path", "resolved_by"} <= link["geometries"][0].keys()
    assert {"mass", "center_of_mass", "inertia_com"} <= model["total"].keys()
    assert {"mass", "center_of_mass", "inertia_com"} <= link["declared"].keys()
    assert "error: " in result.stderr or any(l["status"] == "error" for l in model["links"])


def test_check_exit_codes_and_strict(urdf, tmp_path):
    path, _ = urdf
    assert run("robot", "check", path).exit_code == 1                   # invalid and error links
    clean = _clean_robot(tmp_path)
    result = run("robot", "check", clean)
    assert result.exit_code == 0, result.output                          # b is only missing
    assert "missing" in result.stdout
    assert run("robot", "check", clean, "--strict").exit_code == 1


def test_check_text_names_diagnoses_and_implied_density(urdf):
    path, _ = urdf
    text = run("robot", "check", path).stdout
    assert "flipped: inertia differs by" in text and "product_sign" in text
    assert "implied density" in text
    assert "summary:" in text


def test_junit_and_csv(urdf, tmp_path):
    path, expected = urdf
    junit = tmp_path / "check.xml"
    result = run("robot", "check", path, "--format", "csv", "--junit", junit)
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    assert [r["link"] for r in rows] == list(expected["urdf"]["links"])
    assert {r["link"]: r["status"] for r in rows}["typo"] == "mismatch"
    assert {r["link"]: r["diagnoses"] for r in rows}["negative"] == "not_positive_definite triangle_inequality"
    xml = junit.read_text()
    assert 'failures="4"' in xml and 'name="negative"' in xml and "<failure" in xml


def test_write_in_place_keeps_a_backup_and_refuses_without_a_target(tmp_path):
    clean = _clean_robot(tmp_path)
    before = open(clean, "rb").read()
    assert run("robot", "write", clean).exit_code == 2
    result = run("robot", "write", clean, "--in-place", "--density", "1000")
    assert result.exit_code == 0, result.output
    assert "wrote b (was missing)" in result.stdout
    assert open(clean + ".bak", "rb").read() == before
    after = run("robot", "check", clean, "--strict")
    assert after.exit_code == 0, after.output


def test_write_principal_frame_writes_a_diagonal_with_rpy(tmp_path):
    clean = _clean_robot(tmp_path)
    out = tmp_path / "out.urdf"
    result = run("robot", "write", clean, "-o", out, "--all", "--frame", "principal", "--density", "1000")
    assert result.exit_code == 0, result.output
    text = out.read_text()
    assert 'ixy="0" ixz="0"' in text and 'iyz="0"' in text
    assert run("robot", "check", out, "--strict").exit_code == 0


def test_joints_option_moves_the_total(tmp_path):
    clean = _clean_robot(tmp_path)
    zero = json.loads(run("robot", "props", clean, "--format", "json", "--density", "1000").stdout)[0]
    turned = json.loads(run("robot", "props", clean, "--format", "json", "--density", "1000",
                            "--joints", "j=3.141592653589793").stdout)[0]
    # Half a turn about x through (0, 0, 2) carries b's center from z = 3 to z = 1.
    mass_a, mass_b = zero["links"][0]["mass"], zero["links"][1]["mass"]
    shift = turned["total"]["center_of_mass"][2] - zero["total"]["center_of_mass"][2]
    assert shift == pytest.approx(-2 * mass_b / (mass_a + mass_b), rel=1e-12)
    bad = run("robot", "props", clean, "--joints", "nope=1")
    assert bad.exit_code == 1 and "no joint 'nope'" in bad.stderr + bad.stdout


def test_open_mesh_options(urdf):
    path, _ = urdf

    def open_link(*options):
        result = run("robot", "props", path, "--density", "2700", "--format", "json", *options)
        return [l for l in json.loads(result.stdout)[0]["links"] if l["link"] == "open_part"][0]

    assert open_link()["status"] == "error"
    hull = open_link("--on-open", "hull")
    assert hull["status"] == "ok" and hull["volume"] == pytest.approx(0.05 ** 3, rel=1e-14)
    assert any("convex hull" in w for w in hull["warnings"])
    sheet = open_link("--on-open", "shell:0.001")
    # 11 of the cube's 12 triangles: 5.5 faces of 0.05², 1 mm thick.
    assert sheet["status"] == "ok" and sheet["volume"] == pytest.approx(5.5 * 0.05 ** 2 * 0.001, rel=1e-12)
    skipped = open_link("--on-open", "skip")
    assert skipped["status"] == "no-geometry"
    assert run("robot", "props", path, "--on-open", "melt").exit_code == 2


def test_config_sets_materials_masses_policies_and_packages(urdf, tmp_path):
    path, _ = urdf
    package = os.path.join(os.path.dirname(os.path.dirname(path)))
    moved = tmp_path / "elsewhere.urdf"
    moved.write_text(open(path).read())
    config = tmp_path / "robot.toml"
    config.write_text(textwrap.dedent(f"""
        [packages]
        massprops_robot = "{package}"
        [materials]
        steel = 7850
        [links."base_*"]
        material = "steel"
        [links."sensor"]
        mass = 0.5
        """))
    result = json.loads(run("robot", "props", moved, "--config", config, "--format", "json").stdout)[0]
    links = {l["link"]: l for l in result["links"]}
    assert links["base_link"]["density"] == 7850 and links["base_link"]["mass"] == pytest.approx(7850 * 0.012)
    assert links["sensor"]["mass"] == 0.5
    assert links["bracket"]["geometries"][0]["resolved_by"] == "config [packages]"
    bad = tmp_path / "bad.toml"
    bad.write_text('[links."a"]\nmaterial = "unobtainium"\n')
    failed = run("robot", "props", moved, "--config", bad)
    assert failed.exit_code == 1 and "unobtainium" in failed.output


def test_declared_only_reads_no_mesh(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text("""<robot name="r"><link name="a">
      <inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.3"/></inertial>
      <collision><geometry><mesh filename="package://gone/m.stl"/></geometry></collision></link></robot>""")
    result = run("robot", "check", path, "--declared-only", "--format", "json")
    link = json.loads(result.stdout)[0]["links"][0]
    assert link["status"] == "invalid" and link["diagnoses"] == ["triangle_inequality"]
    assert link["geometries"][0]["resolved_path"] is None


def test_several_models_in_parallel_keep_their_order(urdf, tmp_path):
    path, _ = urdf
    clean = _clean_robot(tmp_path)
    result = run("robot", "check", clean, path, clean, "--format", "json", "-j", "2")
    models = [m["model"] for m in json.loads(result.stdout)]
    assert models == [clean, path, clean]


def test_a_bad_model_is_one_line_and_the_others_are_reported(tmp_path):
    clean = _clean_robot(tmp_path)
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot><link name='a'>")
    result = run("robot", "check", bad, clean)
    assert result.exit_code == 1
    assert f"error: {bad}: not well-formed XML" in result.output
    assert "clean.urdf" in result.stdout and "Traceback" not in result.output


def test_props_on_a_mesh_imports_no_robot_package(tmp_path):
    from massprops.io.stl import write_binary
    from massprops.validation import solids
    path = tmp_path / "box.stl"
    write_binary(path, solids.box().triangles)
    probe = ("import json, sys\nfrom click.testing import CliRunner\nimport massprops.cli\n"
             "r = CliRunner().invoke(massprops.cli.main, ['props', sys.argv[1]])\n"
             "print(json.dumps([r.exit_code, sorted(m for m in ('mujoco', 'xacro', 'collada', 'lxml', "
             "'massprops.robot') if m in sys.modules)]))")
    done = subprocess.run([sys.executable, "-c", probe, str(path)], capture_output=True, text=True, check=True,
                          env={**os.environ, "PYTHONPATH": os.path.dirname(os.path.dirname(__file__))})
    assert json.loads(done.stdout) == [0, []]


def test_geometry_choice_and_repair(tmp_path):
    from massprops.io import obj
    from massprops.validation import solids
    box = solids.box((0.1, 0.1, 0.1))
    faces = box.faces.copy()
    faces[0] = faces[0][::-1]                       # one face wound the wrong way: refused unless --repair
    obj.write(tmp_path / "twisted.obj", box.vertices, faces)
    path = tmp_path / "r.urdf"
    path.write_text("""<robot name="r"><link name="a">
      <visual><geometry><box size="1 1 1"/></geometry></visual>
      <collision><geometry><mesh filename="twisted.obj"/></geometry></collision></link></robot>""")

    def link(*options):
        result = run("robot", "props", path, "--density", "1", "--format", "json", *options)
        return json.loads(result.stdout)[0]["links"][0]

    assert link()["status"] == "error" and "--repair" in link()["message"]
    repaired = link("--repair")
    assert repaired["status"] == "ok" and repaired["volume"] == pytest.approx(0.001, rel=1e-14)
    assert link("--geometry", "visual")["volume"] == 1.0
    assert link("--geometry", "auto", "--repair")["volume"] == pytest.approx(0.001, rel=1e-14)


def test_xacro_without_the_package_is_one_line(tmp_path, monkeypatch):
    path = tmp_path / "r.urdf.xacro"
    path.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"/></robot>')
    monkeypatch.setitem(sys.modules, "xacro", None)
    result = run("robot", "check", path)
    assert result.exit_code == 1
    assert result.output.strip().count("\n") == 0 and 'pip install "massprops[robot]"' in result.output
