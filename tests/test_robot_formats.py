"""Each format's conventions, checked against an independent source (scipy's rotations, MuJoCo's compiler),
and the resolution of package://, model:// and relative URIs."""

import os
import sys
import textwrap

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from massprops.model.errors import MassPropsError
from massprops.io import obj
from massprops.robot.analyze import RobotSettings, analyze
from massprops.robot.load import load_model
from massprops.robot.resolve import Resolver
from massprops.validation import solids


def _write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")
    return str(path)


def _urdf_inertial(rpy):
    return f"""
    <robot name="r">
      <link name="a">
        <inertial><origin xyz="0.1 0.2 0.3" rpy="{rpy}"/><mass value="2"/>
          <inertia ixx="1" ixy="0.1" ixz="0.2" iyy="2" iyz="0.3" izz="3"/></inertial>
      </link>
    </robot>"""


def test_urdf_rpy_is_fixed_axes_xyz_and_ixy_is_the_tensor_element(tmp_path):
    rpy = (0.3, -0.5, 0.7)
    path = _write(tmp_path / "r.urdf", _urdf_inertial(" ".join(map(repr, rpy))))
    declared = load_model(path, Resolver(path)).links[0].declared
    rotation = Rotation.from_euler("xyz", rpy).as_matrix()          # extrinsic x, y, z: Rz(y) Ry(p) Rx(r)
    written = np.array([[1, 0.1, 0.2], [0.1, 2, 0.3], [0.2, 0.3, 3]])
    np.testing.assert_allclose(declared.inertia_com, rotation @ written @ rotation.T, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(declared.center_of_mass, [0.1, 0.2, 0.3])
    assert declared.mass.value == 2.0


def test_urdf_quarter_turn_swaps_the_moments(tmp_path):
    path = _write(tmp_path / "r.urdf", _urdf_inertial("0 0 1.5707963267948966"))
    declared = load_model(path, Resolver(path)).links[0].declared
    assert np.diag(declared.inertia_com) == pytest.approx([2, 1, 3], abs=1e-15)


def test_urdf_joint_chain_places_links_like_scipy(tmp_path):
    path = _write(tmp_path / "r.urdf", """
    <robot name="r">
      <link name="a"/><link name="b"/><link name="c"><collision><geometry><sphere radius="0.1"/></geometry></collision></link>
      <joint name="ab" type="revolute"><parent link="a"/><child link="b"/><origin xyz="1 0 0" rpy="0 0 0.5"/>
        <axis xyz="0 1 0"/></joint>
      <joint name="bc" type="prismatic"><parent link="b"/><child link="c"/><origin xyz="0 2 0" rpy="0.2 0 0"/>
        <axis xyz="1 0 0"/></joint>
    </robot>""")
    from massprops.robot.kinematics import link_poses
    model = load_model(path, Resolver(path))
    poses = link_poses(model, {"ab": 0.4, "bc": 0.25})
    rb = Rotation.from_euler("xyz", [0, 0, 0.5]) * Rotation.from_rotvec([0, 0.4, 0])
    rc = rb * Rotation.from_euler("xyz", [0.2, 0, 0])
    position = np.array([1, 0, 0]) + rb.apply([0, 2, 0]) + rc.apply([0.25, 0, 0])
    np.testing.assert_allclose(poses["c"].translation, position, atol=1e-15)
    np.testing.assert_allclose(poses["c"].rotation, rc.as_matrix(), atol=1e-15)


def test_a_link_that_cannot_be_read_fails_alone(tmp_path):
    path = _write(tmp_path / "r.urdf", """
    <robot name="r">
      <link name="good"><collision><geometry><box size="1 1 1"/></geometry></collision></link>
      <link name="bad"><collision><geometry><box size="1 1"/></geometry></collision></link>
      <link name="lost"><collision><geometry><mesh filename="package://nowhere/m.stl"/></geometry></collision></link>
    </robot>""")
    result = analyze(path, RobotSettings(command="props", density=1.0))
    links = {link["link"]: link for link in result["links"]}
    assert links["good"]["status"] == "ok" and links["good"]["mass"] == 1.0
    assert links["bad"]["status"] == "error" and "expected 3 numbers" in links["bad"]["message"]
    assert links["lost"]["status"] == "error" and "not found (tried:" in links["lost"]["message"]
    assert "packages=" in links["lost"]["message"]          # the library names its keyword; the CLI says --package


def _package(root, name="my_robot"):
    mesh = solids.box((0.1, 0.2, 0.3))
    folder = root / name
    (folder / "meshes").mkdir(parents=True)
    obj.write(folder / "meshes" / "box.obj", mesh.vertices, mesh.faces)
    _write(folder / "package.xml", f"<package><name>{name}</name></package>")
    return folder


def _package_robot(path, name="my_robot"):
    return _write(path, f"""
    <robot name="r"><link name="a"><collision><geometry>
      <mesh filename="package://{name}/meshes/box.obj"/></geometry></collision></link></robot>""")


def test_package_uris_resolve_by_package_xml_walking_up(tmp_path):
    folder = _package(tmp_path / "src")
    path = _package_robot(tmp_path / "src" / "my_robot_description" / "urdf" / "r.urdf")
    result = analyze(path, RobotSettings(command="props", density=1.0))
    geometry = result["links"][0]["geometries"][0]
    assert geometry["resolved_path"] == str(folder / "meshes" / "box.obj")
    assert geometry["resolved_by"] == "package.xml"
    assert result["resolutions"][0]["uri"] == "package://my_robot/meshes/box.obj"


def test_package_option_comes_first_then_the_environment(tmp_path, monkeypatch):
    found_by_walk = _package(tmp_path / "src")
    elsewhere = _package(tmp_path / "other")
    path = _package_robot(tmp_path / "src" / "urdf" / "r.urdf")
    given = analyze(path, RobotSettings(command="props", density=1.0, packages=(("my_robot", str(elsewhere)),)))
    assert given["links"][0]["geometries"][0]["resolved_by"] == "--package"
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "other"))
    env = analyze(path, RobotSettings(command="props", density=1.0))
    assert env["links"][0]["geometries"][0]["resolved_path"] == str(elsewhere / "meshes" / "box.obj")
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    walk = analyze(path, RobotSettings(command="props", density=1.0))
    assert walk["links"][0]["geometries"][0]["resolved_path"] == str(found_by_walk / "meshes" / "box.obj")


def test_http_uris_are_refused_and_every_try_is_logged(tmp_path):
    resolver = Resolver(str(tmp_path / "r.urdf"), environ={})
    with pytest.raises(MassPropsError, match="local files only"):
        resolver.require("https://example.com/m.stl")
    with pytest.raises(MassPropsError, match=r"not found \(tried: .*package\.xml|not found \(tried"):
        resolver.require("package://absent/m.stl")
    assert [r["uri"] for r in resolver.resolutions()] == ["https://example.com/m.stl", "package://absent/m.stl"]


def test_xacro_expands_with_find_through_our_resolver(tmp_path):
    pytest.importorskip("xacro")
    folder = _package(tmp_path)
    path = _write(tmp_path / "r.urdf.xacro", """
    <robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
      <xacro:property name="side" value="0.5"/>
      <xacro:macro name="part" params="name">
        <link name="${name}"><collision><geometry><box size="${side} ${side} ${2 * side}"/></geometry></collision>
        </link>
      </xacro:macro>
      <xacro:part name="first"/>
      <link name="mesh_link"><collision><geometry>
        <mesh filename="file://$(find my_robot)/meshes/box.obj"/></geometry></collision></link>
    </robot>""")
    result = analyze(path, RobotSettings(command="props", density=1.0, packages=(("my_robot", str(folder)),)))
    links = {link["link"]: link for link in result["links"]}
    assert links["first"]["mass"] == 0.25
    assert links["mesh_link"]["mass"] == pytest.approx(0.006, rel=1e-15)
    assert result["writable"] is True           # written into its .xacro files (tests/test_robot_write_sources.py)


def test_sdf_pose_forms_agree(tmp_path):
    from massprops.robot.sdf import parse_pose
    from lxml import etree
    quarter = [etree.fromstring(text) for text in (
        "<pose>1 2 3 0 0 1.5707963267948966</pose>",
        '<pose degrees="true">1 2 3 0 0 90</pose>',
        '<pose rotation_format="quat_xyzw">1 2 3 0 0 0.7071067811865476 0.7071067811865476</pose>')]
    poses = [parse_pose(p, "x", "pose") for p in quarter]
    for pose in poses:
        np.testing.assert_allclose(pose.rotation, Rotation.from_euler("z", 90, degrees=True).as_matrix(), atol=1e-15)
        np.testing.assert_array_equal(pose.translation, [1, 2, 3])


def test_sdf_relative_to_chains_and_refuses_cycles(tmp_path):
    good = _write(tmp_path / "m.sdf", """
    <sdf version="1.9"><model name="m">
      <frame name="f1"><pose>1 0 0 0 0 1.5707963267948966</pose></frame>
      <frame name="f2" attached_to="f1"><pose relative_to="f1">0 1 0 0 0 0</pose></frame>
      <link name="a"><pose relative_to="f2">0 0 1 0 0 0</pose>
        <collision name="c"><geometry><sphere><radius>0.1</radius></sphere></geometry></collision></link>
    </model></sdf>""")
    link = load_model(good, Resolver(good)).links[0]
    np.testing.assert_allclose(link.pose_in_parent.translation, [0, 0, 1], atol=1e-15)     # 1,0,0 + Rz(90°)(0,1,0)
    bad = _write(tmp_path / "bad.sdf", """
    <sdf version="1.9"><model name="m">
      <frame name="f1" attached_to="f2"/><frame name="f2" attached_to="f1"/>
      <link name="a"><pose relative_to="f1"/></link>
    </model></sdf>""")
    with pytest.raises(MassPropsError, match="cycle"):
        load_model(bad, Resolver(bad))


def test_sdf_auto_inertial_scales_to_the_given_mass(tmp_path):
    path = _write(tmp_path / "m.sdf", """
    <sdf version="1.11"><model name="m"><link name="a">
      <inertial auto="true"><mass>3</mass></inertial>
      <collision name="c"><density>500</density><geometry><box><size>0.1 0.2 0.3</size></box></geometry></collision>
    </link></model></sdf>""")
    link = analyze(path, RobotSettings(command="check"))["links"][0]
    assert link["status"] == "ok" and link["mass"] == 3.0
    assert link["inertia_com"][0][0] == pytest.approx(3 / 12 * (0.04 + 0.09), rel=1e-15)


def test_sdf_world_includes_a_model_by_model_uri(tmp_path, monkeypatch):
    from massprops.validation.robots import write_robots
    write_robots(tmp_path / "models", formats=("sdf",))
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(tmp_path / "models"))
    path = _write(tmp_path / "world.sdf", """
    <sdf version="1.11"><world name="w">
      <include><uri>model://massprops_robot</uri><name>arm</name><pose>1 0 0 0 0 0</pose></include>
    </world></sdf>""")
    result = analyze(path, RobotSettings(command="check"))
    names = [link["link"] for link in result["links"]]
    assert "arm::base_link" in names and "arm::bracket" in names
    statuses = {link["link"]: link["status"] for link in result["links"]}
    assert statuses["arm::bracket"] == "ok" and statuses["arm::flipped"] == "mismatch"


def _mjcf(tmp_path, body):
    return _write(tmp_path / "m.xml", f"""
    <mujoco model="m"><worldbody>{body}</worldbody></mujoco>""")


def test_mjcf_fullinertia_order_and_euler_degrees(tmp_path):
    pytest.importorskip("mujoco")
    path = _mjcf(tmp_path, """
      <body name="a"><joint type="hinge"/>
        <inertial pos="0 0 0" mass="1" fullinertia="1 2 3 0.1 0.2 0.3"/>
        <geom type="box" size="0.1 0.2 0.3" euler="0 0 90"/>
      </body>""")
    link = load_model(path, Resolver(path)).links[0]
    np.testing.assert_array_equal(link.declared.inertia_com, [[1, 0.1, 0.2], [0.1, 2, 0.3], [0.2, 0.3, 3]])
    # euler in degrees by default: the box turned a quarter about z has its x and y edges swapped.
    result = analyze(path, RobotSettings(command="props", density=1000.0))["links"][0]
    box = 1000 * 0.2 * 0.4 * 0.6 / 12
    assert np.diag(result["inertia_com"]) == pytest.approx([box * (0.2 ** 2 + 0.6 ** 2), box * (0.4 ** 2 + 0.6 ** 2),
                                                           box * (0.2 ** 2 + 0.4 ** 2)], rel=1e-14)


def test_mjcf_without_mujoco_is_one_line_naming_the_extra(tmp_path, monkeypatch):
    path = _mjcf(tmp_path, '<body name="a"><geom type="sphere" size="0.1"/></body>')
    monkeypatch.setitem(sys.modules, "mujoco", None)
    result = analyze(path, RobotSettings(command="props"))
    assert result["status"] == "error"
    assert "mujoco" in result["message"] and 'pip install "massprops[robot]"' in result["message"]
    assert "\n" not in result["message"]


def test_mjcf_missing_mesh_fails_its_body_only(tmp_path):
    pytest.importorskip("mujoco")
    path = _mjcf(tmp_path, """
      <body name="good"><geom type="sphere" size="0.1"/></body>
      <body name="lost"><geom type="mesh" mesh="gone"/></body>""")
    text = open(path).read().replace("<worldbody>", '<asset><mesh name="gone" file="gone.stl"/></asset><worldbody>')
    open(path, "w").write(text)
    result = analyze(path, RobotSettings(command="props"))
    links = {link["link"]: link for link in result["links"]}
    assert links["good"]["status"] == "ok"
    assert links["lost"]["status"] == "error" and "gone.stl" in links["lost"]["message"]


def test_not_a_robot_description(tmp_path):
    path = _write(tmp_path / "x.xml", "<scene><thing/></scene>")
    result = analyze(path, RobotSettings(command="check"))
    assert result["status"] == "error" and "<scene>" in result["message"]
    missing = analyze(str(tmp_path / "none.urdf"), RobotSettings(command="check"))
    assert missing["status"] == "error" and "no such file" in missing["message"]
    assert os.path.basename(missing["model"]) == "none.urdf"


def test_a_link_whose_geometry_has_no_mass_is_an_error_not_a_crash(tmp_path):
    path = _write(tmp_path / "m.sdf", """
    <sdf version="1.9"><model name="m"><link name="l"><collision name="c"><density>0</density>
      <geometry><box><size>1 1 1</size></box></geometry></collision></link></model></sdf>""")
    link = analyze(path, RobotSettings(command="props"))["links"][0]
    assert link["status"] == "error" and "total mass is 0" in link["message"]
