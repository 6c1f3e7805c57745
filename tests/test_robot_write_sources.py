"""``robot write`` reaches every file: an MJCF scene's included robot, a xacro file's literal inertials (in the
file that writes them), macro-made inertials named with their macro, and ``--expand``.  Each round trip is
checked by ``robot check`` (every written link ``ok``) and every byte outside the ``<inertial>`` elements
is compared with the original."""

import json
import re

import pytest

from cli_files import run, write as _write

_INERTIAL = re.compile(rb"\s*<inertial\b(?:[^>]*/>|.*?</inertial>)", re.S)
_XACRO_NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


def _outside_inertials(data):
    return _INERTIAL.sub(b"", data)


def _statuses(path, *args):
    result = run("robot", "check", path, "--format", "json", *args)
    (model,) = json.loads(result.stdout)
    return {link["link"]: link["status"] for link in model["links"]}


def _scene(tmp_path):
    """scene.xml includes arm.xml, which includes hand.xml (MuJoCo: paths relative to the main file)."""
    _write(tmp_path / "robot" / "hand.xml", """
        <mujocoinclude>
          <body name="finger" pos="0 0 0.2">
            <joint name="f" type="slide" axis="0 1 0"/>
            <geom type="box" size="0.01 0.02 0.04"/>
          </body>
        </mujocoinclude>""")
    _write(tmp_path / "robot" / "arm.xml", """
        <mujocoinclude>
          <body name="base" pos="0 0 0.1">
            <geom type="box" size="0.1 0.2 0.3"/>
            <body name="arm" pos="0 0 0.5">
              <joint name="j" type="hinge" axis="1 0 0"/>
              <inertial pos="0 0 0" mass="2" diaginertia="1 1 1"/>
              <geom type="capsule" size="0.05 0.2"/>
              <include file="robot/hand.xml"/>
            </body>
          </body>
        </mujocoinclude>""")
    return _write(tmp_path / "scene.xml", """
        <mujoco model="scene">
          <worldbody>
            <geom type="plane" size="1 1 0.1"/>
            <include file="robot/arm.xml"/>
          </worldbody>
        </mujoco>""")


def test_an_mjcf_scene_writes_into_the_included_files(tmp_path):
    pytest.importorskip("mujoco")
    scene = _scene(tmp_path)
    files = [scene, tmp_path / "robot" / "arm.xml", tmp_path / "robot" / "hand.xml"]
    before = {f: f.read_bytes() for f in files}
    assert _statuses(scene) == {"base": "missing", "arm": "mismatch", "finger": "missing"}
    refused = run("robot", "write", scene, "--all", "-o", tmp_path / "out.xml")
    assert refused.exit_code == 1 and "--in-place" in refused.output and not (tmp_path / "out.xml").exists()
    result = run("robot", "write", scene, "--all", "--in-place")
    assert result.exit_code == 0, result.output
    assert "wrote finger in " + str(tmp_path / "robot" / "hand.xml") in result.output
    assert f"{tmp_path / 'robot' / 'arm.xml'} (backup" in result.output
    assert scene.read_bytes() == before[scene]                       # the scene holds no body: untouched
    for f in files[1:]:
        after = f.read_bytes()
        assert after != before[f] and _outside_inertials(after) == _outside_inertials(before[f])
        assert (f.parent / (f.name + ".bak")).read_bytes() == before[f]
    assert _statuses(scene) == {"base": "ok", "arm": "ok", "finger": "ok"}


def _xacro_package(tmp_path):
    package = tmp_path / "demo"
    _write(package / "package.xml", "<package><name>demo</name></package>")
    _write(package / "urdf" / "parts.xacro", f"""
        <robot {_XACRO_NS}>
          <xacro:macro name="box_inertial" params="m x y z">
            <inertial><mass value="${{m}}"/><inertia ixx="${{m*(y*y+z*z)/12}}" ixy="0" ixz="0"
              iyy="${{m*(x*x+z*z)/12}}" iyz="0" izz="${{m*(x*x+y*y)/12}}"/></inertial>
          </xacro:macro>
          <xacro:macro name="finger" params="side">
            <link name="${{side}}_finger">
              <inertial><mass value="0.1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
              <collision><geometry><box size="0.01 0.02 0.05"/></geometry></collision>
            </link>
          </xacro:macro>
          <link name="included_link">
            <inertial>
              <mass value="2"/>
              <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>
            </inertial>
            <collision><geometry><box size="0.1 0.2 0.3"/></geometry></collision>
          </link>
        </robot>""")
    return _write(package / "urdf" / "robot.urdf.xacro", f"""
        <?xml version="1.0"?>
        <robot name="demo" {_XACRO_NS}>
          <xacro:include filename="$(find demo)/urdf/parts.xacro"/>
          <xacro:property name="side" value="0.3"/>
          <link name="base">
            <inertial>
              <origin xyz="0 0 0" rpy="0 0 0"/>
              <mass value="3"/>
              <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>
            </inertial>
            <collision><geometry><box size="${{side}} 0.2 0.1"/></geometry></collision>
          </link>
          <link name="bare">
            <collision><geometry><cylinder radius="0.05" length="0.2"/></geometry></collision>
          </link>
          <link name="macro_inertial">
            <xacro:box_inertial m="1" x="0.1" y="0.1" z="0.1"/>
            <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
          </link>
          <xacro:finger side="left"/>
          <joint name="j1" type="fixed"><parent link="base"/><child link="bare"/></joint>
          <joint name="j2" type="fixed"><parent link="base"/><child link="macro_inertial"/></joint>
          <joint name="j3" type="fixed"><parent link="base"/><child link="left_finger"/></joint>
          <joint name="j4" type="fixed"><parent link="base"/><child link="included_link"/></joint>
        </robot>""")


def test_xacro_literal_inertials_are_written_where_they_are(tmp_path):
    pytest.importorskip("xacro")
    model = _xacro_package(tmp_path)
    parts = model.parent / "parts.xacro"
    before = {f: f.read_bytes() for f in (model, parts)}
    assert _statuses(model, "--density", 1000) == {"included_link": "mismatch", "base": "mismatch",
                                                   "bare": "missing", "macro_inertial": "mismatch",
                                                   "left_finger": "mismatch"}
    result = run("robot", "write", model, "--all", "--in-place", "--density", 1000)
    assert result.exit_code == 1                                     # two links asked for could not be written
    assert "wrote included_link in " + str(parts) in result.output
    for f in (model, parts):
        after = f.read_bytes()
        assert after != before[f] and _outside_inertials(after) == _outside_inertials(before[f])
        assert b"${" in after or f == parts                          # the xacro expressions stay as they were
    assert b'<box size="${side} 0.2 0.1"/>' in model.read_bytes()
    left = {line.split(":")[0][5:]: line for line in result.output.splitlines() if line.startswith("left ")}
    assert "macro call <xacro:box_inertial> (robot.urdf.xacro line 17, defined in parts.xacro line 2)" \
        in left["macro_inertial"]
    assert "made by the macro 'finger' (parts.xacro line 6, params: side" in left["left_finger"]
    for line in left.values():
        assert "--expand" in line and '<mass value="' in line and "{expand}" not in line
    statuses = _statuses(model, "--density", 1000)
    assert {name: statuses[name] for name in ("included_link", "base", "bare")} == dict.fromkeys(
        ("included_link", "base", "bare"), "ok")
    assert statuses["macro_inertial"] == statuses["left_finger"] == "mismatch"


def test_xacro_expand_writes_the_expanded_urdf(tmp_path):
    pytest.importorskip("xacro")
    model = _xacro_package(tmp_path)
    before = model.read_bytes()
    out = tmp_path / "expanded.urdf"
    assert run("robot", "write", model, "--all", "--in-place", "--expand").exit_code == 2
    result = run("robot", "write", model, "--all", "-o", out, "--expand", "--density", 1000)
    assert result.exit_code == 0, result.output
    assert model.read_bytes() == before and b"<xacro:" not in out.read_bytes() and b"${" not in out.read_bytes()
    assert set(_statuses(out, "--package", f"demo={model.parent.parent}").values()) == {"ok"}
