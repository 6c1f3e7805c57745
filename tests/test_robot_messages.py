"""Robot messages are written for the shell: options as options, no Python class names, reprs or keyword
syntax, units on volumes (SI after the file's scale), each said once, model-level warnings once per model.

Every fixture is generated here; each is made to trigger a refusal or a warning, and the test first checks
that it did (so the scan below scans something)."""

import json
import re

import numpy as np
import pytest

from massprops.io import obj
from massprops.validation import solids
from cli_files import run, write as _write

_XACRO_NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
# What a message for the shell never contains: a class, a repr, a Python keyword argument or a placeholder.
_PYTHON = [re.compile(p) for p in (
    r"<class '", r"\bobject at 0x", r"Traceback", r"\b\w*Error\b(?!s)", r"\w+=\{'", r"\w+=\['",
    r"(?<![-\w])(packages|roots|config_path|xacro_args|repair|declared_only|allow_env|mass_policy|on_open|"
    r"density|massless)=", r"\(tried: nowhere\)", r"\{(package|root|density|config|mass_policy|xacro_arg)[}=]",
    r"(?<!\w)(None|True|False)(?!\w)")]


def _box_obj(path, size=(0.1, 0.2, 0.3), offset=(0.0, 0.0, 0.0)):
    box = solids.box(size)
    obj.write(path, box.vertices + np.asarray(offset), box.faces)
    return path


def _two_shells(path):
    """Two 10 × 10 × 10 cubes (file units) overlapping in a 5 × 10 × 10 slab: 500 units³ counted twice."""
    a, b = solids.box((10, 10, 10)), solids.box((10, 10, 10))
    vertices = np.vstack([a.vertices, b.vertices + [5.0, 0.0, 0.0]])
    faces = np.vstack([a.faces, b.faces + len(a.vertices)])
    obj.write(path, vertices, faces)
    return path


def _fixtures(root):
    """``{name: (command arguments, what its output must show)}``: each a refusal or a warning."""
    package = root / "demo_description"
    meshes = package / "meshes"
    meshes.mkdir(parents=True)
    _box_obj(meshes / "box.obj")
    _box_obj(meshes / "shifted.obj", offset=(0.05, 0.0, 0.0))
    _two_shells(meshes / "shells.obj")
    urdf = package / "urdf"
    mesh = '<collision><geometry><mesh filename="{}"{}/></geometry></collision>'
    inertial = ('<inertial><mass value="{}"/><inertia ixx="{}" ixy="0" ixz="0" iyy="{}" iyz="0" izz="{}"/>'
                '</inertial>')
    robot = _write(urdf / "robot.urdf", f"""
        <robot name="demo">
          <link name="overlapping">{mesh.format("../meshes/box.obj", "")}{mesh.format("../meshes/shifted.obj", "")}</link>
          <link name="shells">{mesh.format("../meshes/shells.obj", ' scale="0.001 0.001 0.001"')}</link>
          <link name="bare1"><collision><geometry><box size="1 1 1"/></geometry></collision></link>
          <link name="bare2"><collision><geometry><sphere radius="0.5"/></geometry></collision></link>
          <link name="lost">{mesh.format("package://nowhere/m.stl", "")}</link>
          <link name="escape">{mesh.format("../../../outside.obj", "")}</link>
          <link name="bad">{inertial.format(1, 1, 1, 3)}<collision><geometry><box size="1 1 1"/></geometry>
            </collision></link>
          <link name="off">{inertial.format(1, 0.5, 0.4, 0.3)}<collision><geometry><box size="1 2 3"/></geometry>
            </collision></link>
        </robot>""")
    _box_obj(root / "outside.obj")
    find = _write(urdf / "find.xacro", f'<robot name="f" {_XACRO_NS}><xacro:include filename="$(find ghost)/x.xacro"/>'
                                       '</robot>')
    arg = _write(urdf / "arg.xacro", f'<robot name="a" {_XACRO_NS}><link name="$(arg robot_name)"/></robot>')
    env = _write(urdf / "env.xacro", f'<robot name="e" {_XACRO_NS}><link name="$(env HOME)"/></robot>')
    for other in ("a", "b"):
        _write(root / "src" / other / "package.xml", "<package><name>dup</name></package>")
        _box_obj(root / "src" / other / "m.obj")
    _write(root / "src" / "r" / "package.xml", "<package><name>r</name></package>")
    ambiguous = _write(root / "src" / "r" / "urdf" / "r.urdf",
                       f'<robot name="r"><link name="a">{mesh.format("package://dup/m.obj", "")}</link></robot>')
    return {
        "robot check": (["robot", "check", robot], ["overlap by 0.003 m³", "overlap by 500 mm³", "no density given", "not found",
                                                     "refused", "A + B >= C", "inertia differs"]),
        "robot props": (["robot", "props", robot], ["overlap by 0.003 m³", "no density given",
                                                     "--mass-policy keep"]),
        "find": (["robot", "check", find], ["$(find ghost)", "--package NAME=DIR"]),
        "arg": (["robot", "props", arg], ["robot_name", "--xacro-arg NAME=VALUE"]),
        "env": (["robot", "props", env], ["$(env HOME)", "--allow-env"]),
        "ambiguous": (["robot", "props", ambiguous, "--density", 1], ["is ambiguous", "--package NAME=DIR"]),
    }


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("messages")
    pytest.importorskip("xacro")
    out = {}
    for name, (args, shown) in _fixtures(root).items():
        text = run(*args)
        data = run(*args, "--format", "json")
        out[name] = (text.output, data, shown)
    return out


@pytest.mark.parametrize("name", ["robot check", "robot props", "find", "arg", "env", "ambiguous"])
def test_each_fixture_says_what_it_should_in_shell_words(outputs, name):
    text, data, shown = outputs[name]
    for expected in shown:
        assert expected in text, (expected, text)
    messages = text.splitlines()
    if data.stdout.strip():
        for model in json.loads(data.stdout):
            messages += [model.get("message") or "", *model.get("warnings", [])]
            for link in model["links"]:
                messages += [link["message"], *link["warnings"],
                             *(d["message"] for d in link.get("diagnosis_details", []))]
    messages += data.stderr.splitlines() if data.stderr_bytes is not None else []
    for message in messages:
        for pattern in _PYTHON:
            assert not pattern.search(message), (pattern.pattern, message)


@pytest.mark.parametrize("name", ["robot check", "robot props"])
def test_each_message_once_and_model_warnings_once(outputs, name):
    text, data, _ = outputs[name]
    said = [line for line in text.splitlines() if line.startswith("  warning:") or line.startswith("error:")]
    assert len(said) == len(set(said)), said
    assert sum("no density given" in line for line in said) == 1
    (model,) = json.loads(data.stdout)
    assert not any("no density given" in w for link in model["links"] for w in link["warnings"])
    density = next(w for w in model["warnings"] if "no density given" in w)
    assert "'bare1'" in density and "'bare2'" in density
    # check keeps the declared masses already: it does not suggest the policy in force.
    assert ("--mass-policy keep" in density) == (name == "robot props")


def test_overlaps_are_in_si_after_the_scale(outputs):
    _, data, _ = outputs["robot check"]
    (model,) = json.loads(data.stdout)
    links = {link["link"]: link for link in model["links"]}
    # Two 0.1 × 0.2 × 0.3 boxes 0.05 apart along x: 0.05 × 0.2 × 0.3 = 3e-3 m³ counted twice.
    assert links["overlapping"]["checks"]["overlap"] == pytest.approx(0.05 * 0.2 * 0.3, rel=1e-12)
    # The file's cubes overlap by 500 units³; at scale 0.001 that is 5e-7 m³ (500 mm³).
    assert links["shells"]["checks"]["overlap"] == pytest.approx(500 * 1e-9, rel=1e-12)
    assert any("overlap by 500 mm³; counted once" in w for w in links["shells"]["warnings"])
