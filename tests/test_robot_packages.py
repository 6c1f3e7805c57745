"""package:// and $(find) as a ROS user expects them: the rules in order, trees without package.xml,
ambiguity listed, and the folder-name rule still confined (package://etc/passwd finds nothing)."""


import pytest

from massprops.io import obj
from massprops.robot import RobotSettings, analyze
from massprops.validation import solids
from cli_files import run, write as _write


def _mesh(path, size=(0.1, 0.2, 0.3)):
    path.parent.mkdir(parents=True, exist_ok=True)
    box = solids.box(size)
    obj.write(path, box.vertices, box.faces)
    return path


def _robot(path, *uris):
    links = "".join(f'<link name="l{k}"><collision><geometry><mesh filename="{uri}"/></geometry></collision></link>'
                    for k, uri in enumerate(uris))
    return _write(path, f'<robot name="r">{links}</robot>')


def _geometries(path, **settings):
    result = analyze(path, RobotSettings(command="props", density=1.0, **settings))
    assert result["status"] == "ok", result.get("message")
    return result, [(link["status"], link["geometries"][0]) for link in result["links"]]


def _tree(tmp_path):
    """robots/foo_description (the model) and robots/bar_description beside it, no package.xml anywhere."""
    robots = tmp_path / "robots"
    _mesh(robots / "foo_description" / "meshes" / "a.obj")
    _mesh(robots / "bar_description" / "meshes" / "b.obj", (0.3, 0.3, 0.3))
    model = _robot(robots / "foo_description" / "urdf" / "foo.urdf", "package://foo_description/meshes/a.obj",
                   "package://bar_description/meshes/b.obj")
    return robots, model


def test_a_ros_like_tree_without_package_xml_resolves(tmp_path):
    robots, model = _tree(tmp_path)
    result, found = _geometries(model)
    assert [status for status, _ in found] == ["ok", "ok"]
    assert [g["resolved_by"] for _, g in found] == ["folder name", "folder name"]
    assert found[1][1]["resolved_path"] == str(robots / "bar_description" / "meshes" / "b.obj")
    assert [link["mass"] for link in result["links"]] == pytest.approx([0.006, 0.027], rel=1e-12)
    # One warning per package found by its name, at the model's level (not one per geometry).
    named = [w for w in result["warnings"] if "found by its name" in w]
    assert len(named) == 2 and not any("found by its name" in w for link in result["links"]
                                       for w in link["warnings"])


def test_xacro_find_reaches_a_sibling_package(tmp_path):
    pytest.importorskip("xacro")
    robots, _ = _tree(tmp_path)
    _write(robots / "bar_description" / "urdf" / "part.xacro",
           '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="part"><collision><geometry>'
           '<box size="1 2 3"/></geometry></collision></link></robot>')
    model = _write(robots / "foo_description" / "urdf" / "foo.urdf.xacro",
                   '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                   '<xacro:include filename="$(find bar_description)/urdf/part.xacro"/></robot>')
    result = run("robot", "props", model, "--density", 1)
    assert result.exit_code == 0, result.output
    assert "part " in result.output and "6 " in result.output


@pytest.mark.parametrize("uri", ["package://etc/passwd", "package://outside/secret.obj"])
def test_the_folder_name_rule_stays_inside_the_tree(tmp_path, uri):
    robots, _ = _tree(tmp_path)
    _mesh(tmp_path / "outside" / "secret.obj")                  # beside the tree, not in it
    model = _robot(robots / "foo_description" / "urdf" / "evil.urdf", uri)
    result, found = _geometries(model)
    (status, geometry), = found
    assert status == "error" and geometry["resolved_path"] is None
    assert "not found" in result["links"][0]["message"]


def test_the_home_folder_is_never_a_package(tmp_path, monkeypatch):
    robots, model = _tree(tmp_path)
    monkeypatch.setenv("HOME", str(robots / "bar_description"))
    _, found = _geometries(model)
    assert [status for status, _ in found] == ["ok", "error"]
    monkeypatch.setenv("HOME", str(robots))                    # the tree is the home folder: no tree rule at all
    _, found = _geometries(model)
    assert [g["resolved_by"] for _, g in found] == ["folder name", None]
    monkeypatch.setenv("HOME", str(tmp_path))                  # a tree inside the home folder is the usual case
    _, found = _geometries(model)
    assert [g["resolved_by"] for _, g in found] == ["folder name", "folder name"]


def test_an_install_prefix_share_folder_holds_packages(tmp_path):
    share = tmp_path / "prefix" / "share"
    _mesh(share / "example-robot-data" / "robots" / "arm" / "meshes" / "a.obj")
    _mesh(share / "tools" / "meshes" / "t.obj")
    model = _robot(share / "example-robot-data" / "robots" / "talos" / "robots" / "talos.urdf",
                   "package://example-robot-data/robots/arm/meshes/a.obj", "package://tools/meshes/t.obj",
                   "package:///example-robot-data/robots/arm/meshes/a.obj")
    _, found = _geometries(model)
    assert [status for status, _ in found] == ["ok", "ok", "ok"]
    assert {g["resolved_by"] for _, g in found} == {"folder name"}


def test_an_ambiguous_package_lists_its_candidates(tmp_path):
    src = tmp_path / "src"
    for folder in ("a", "b"):
        _write(src / folder / "package.xml", "<package><name>dup</name></package>")
        _mesh(src / folder / "meshes" / "x.obj")
    _write(src / "robot" / "package.xml", "<package><name>robot</name></package>")
    model = _robot(src / "robot" / "urdf" / "r.urdf", "package://dup/meshes/x.obj")
    result = run("robot", "props", model, "--density", 1)
    assert result.exit_code == 1
    line = next(line for line in result.output.splitlines() if "is ambiguous:" in line)
    assert str(src / "a") in line and str(src / "b") in line and "--package NAME=DIR" in line
    chosen = run("robot", "props", model, "--density", 1, "--package", f"dup={src / 'b'}", "--format", "json")
    assert chosen.exit_code == 0 and '"resolved_by": "--package"' in chosen.output
    # Only one of them holds the file: no ambiguity.
    (src / "a" / "meshes" / "x.obj").unlink()
    assert run("robot", "props", model, "--density", 1).exit_code == 0


def test_gz_sim_resource_path_finds_a_package(tmp_path, monkeypatch):
    _mesh(tmp_path / "resources" / "gadget" / "meshes" / "g.obj")
    _write(tmp_path / "model" / "package.xml", "<package><name>model</name></package>")
    model = _robot(tmp_path / "model" / "urdf" / "m.urdf", "package://gadget/meshes/g.obj")
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(tmp_path / "resources"))
    _, found = _geometries(model)
    assert found[0][0] == "ok" and found[0][1]["resolved_by"] == "GZ_SIM_RESOURCE_PATH"
    monkeypatch.delenv("GZ_SIM_RESOURCE_PATH")
    _, found = _geometries(model)
    assert found[0][0] == "error"
