"""A robot file is data from anyone: it never runs code, reads the environment, or reads outside its roots.

Every reproducer is generated here.  The xacro escapes are first shown to run
code through the plain ``xacro`` package (so these tests can fail), then
refused through massprops: non-zero exit, an error line, no file written.
"""

import contextlib
import io
import textwrap

import pytest

from massprops.io import obj
from massprops.robot import RobotSettings, analyze
from massprops.validation import solids
from cli_files import run, write as _write

xacro = pytest.importorskip("xacro")

_XACRO_NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
_BOX = '<collision><geometry><box size="1 2 3"/></geometry></collision>'


def _layout(tmp_path):
    """A package ``pkg`` (with package.xml and a mesh) and, beside it, an ``outside`` folder with a secret mesh."""
    package = tmp_path / "pkg"
    _write(package / "package.xml", "<package><name>pkg</name></package>")
    box = solids.box((0.1, 0.2, 0.3))
    (package / "meshes").mkdir()
    obj.write(package / "meshes" / "box.obj", box.vertices, box.faces)
    (tmp_path / "outside").mkdir()
    obj.write(tmp_path / "outside" / "secret.obj", box.vertices, box.faces)
    _write(tmp_path / "outside" / "secret.yaml", "name: SECRET_FROM_OUTSIDE\n")
    _write(tmp_path / "outside" / "part.xacro", f'<robot {_XACRO_NS}><link name="SECRET_INCLUDED">{_BOX}</link></robot>')
    return package


def _xacro(path, body):
    return _write(path, f'<robot name="r" {_XACRO_NS}>\n{textwrap.dedent(body).strip()}\n'
                        f'<link name="base">{_BOX}</link>\n</robot>\n')


def _escapes(marker):
    """Expressions that run ``touch marker`` (or write it) in plain xacro, each in another place of the file."""
    system = f"system('touch {marker}')"
    chain = "python.vars(python.int.mro()[1])['__getattribute__'](xacro.fatal, '__globals__')['os']"
    return {
        "issue": f'<link name="${{{chain}.{system}}}">{_BOX}</link>',
        "property": f'<xacro:property name="p" value="${{{chain}.{system}}}"/><link name="${{p}}">{_BOX}</link>',
        "condition": f'<xacro:if value="${{{chain}.{system} == 0}}"><link name="c">{_BOX}</link></xacro:if>',
        "macro argument": f'<xacro:macro name="m" params="n"><link name="${{n}}">{_BOX}</link></xacro:macro>'
                          f'<xacro:m n="${{{chain}.{system}}}"/>',
        "text": f'<link name="t">{_BOX}</link><gazebo>${{{chain}.{system}}}</gazebo>',
        "eval builtins": f'<xacro:property name="cmd" value="open(\'{marker}\', \'w\').write(\'x\')"/>'
                         f'<link name="$(eval ${{cmd}})">{_BOX}</link>',
        "yaml unit tag": f'<xacro:property name="y" value="${{xacro.load_yaml(\'units.yaml\')}}"/>'
                         f'<link name="${{y.angle}}">{_BOX}</link>',
    }


def _units_yaml(folder, marker):
    chain = "python.vars(python.int.mro()[1])['__getattribute__'](xacro.fatal, '__globals__')['os']"
    _write(folder / "units.yaml", f"angle: !degrees {chain}.system('touch {marker}')\n")


ESCAPES = sorted(_escapes("M"))


@pytest.mark.parametrize("name", ESCAPES)
def test_the_escape_runs_code_in_plain_xacro(tmp_path, name):
    marker = tmp_path / "pwned"
    path = _xacro(tmp_path / "r.xacro", _escapes(marker)[name])
    _units_yaml(tmp_path, marker)
    with contextlib.redirect_stderr(io.StringIO()), contextlib.suppress(Exception):
        xacro.process_file(str(path))
    assert marker.exists()


@pytest.mark.parametrize("command", ["props", "check"])
@pytest.mark.parametrize("name", ESCAPES)
def test_no_xacro_escape_runs_code(tmp_path, name, command):
    marker = tmp_path / "pwned"
    package = _layout(tmp_path)
    path = _xacro(package / "urdf" / "r.urdf.xacro", _escapes(marker)[name])
    _units_yaml(package / "urdf", marker)
    result = run("robot", command, path)
    assert not marker.exists()
    assert result.exit_code == 1
    assert result.output.count("error: ") == 1
    assert "xacro " in result.output and "massprops evaluates only" in result.output
    assert " ok " not in result.output


def test_a_urdf_naming_the_xacro_namespace_is_expanded_safely(tmp_path):
    marker = tmp_path / "pwned"
    package = _layout(tmp_path)
    path = _xacro(package / "urdf" / "robot.urdf", _escapes(marker)["issue"])
    result = run("robot", "check", path)
    assert not marker.exists()
    assert result.exit_code == 1
    assert "name 'python' is not defined" in result.output and "(line 2)" in result.output


@pytest.mark.parametrize("expression", [
    "[].__class__", "xacro.fatal.__globals__", "math.__dict__", "''.join.__self__", "(lambda: 1)()",
    "[x for x in (1, 2)]", "load_yaml.__func__", "str.mro", "len.__self__", "getattr", "__import__",
    "'%s' % str.mro", "'x' * 10 ** 9", "9 ** 9 ** 9", "xacro.dotify.mro", "'a'.format",
])
def test_the_evaluator_refuses_everything_but_data(tmp_path, expression):
    package = _layout(tmp_path)
    path = _xacro(package / "urdf" / "r.xacro", f'<link name="${{{expression}}}">{_BOX}</link>')
    result = run("robot", "props", path)
    assert result.exit_code == 1
    assert result.output.startswith("error: ") and "xacro expression ${" in result.output


def test_env_needs_allow_env(tmp_path, monkeypatch):
    monkeypatch.setenv("MASSPROPS_TEST_SECRET", "SECRET_FROM_ENV")
    monkeypatch.delenv("MASSPROPS_TEST_UNSET", raising=False)
    package = _layout(tmp_path)
    refused = _xacro(package / "urdf" / "env.xacro", f'<link name="$(env MASSPROPS_TEST_SECRET)">{_BOX}</link>')
    result = run("robot", "props", refused)
    assert result.exit_code == 1
    assert "SECRET_FROM_ENV" not in result.output
    assert "$(env MASSPROPS_TEST_SECRET) (line 2): reads the environment" in result.output
    assert "--allow-env" in result.output
    allowed = run("robot", "props", refused, "--allow-env", "--density", 1)
    assert allowed.exit_code == 0 and "SECRET_FROM_ENV" in allowed.output
    cwd = _xacro(package / "urdf" / "cwd.xacro", f'<link name="$(cwd)">{_BOX}</link>')
    assert run("robot", "props", cwd).exit_code == 1
    optional = _xacro(package / "urdf" / "optenv.xacro",
                      f'<link name="$(optenv MASSPROPS_TEST_SECRET fallback)">{_BOX}</link>')
    result = run("robot", "props", optional, "--density", 1)
    assert result.exit_code == 0
    assert "SECRET_FROM_ENV" not in result.output and "fallback" in result.output
    assert "the environment is not read: the default 'fallback' is used — give --allow-env" in result.output
    assert "SECRET_FROM_ENV" in run("robot", "props", optional, "--allow-env", "--density", 1).output


def test_the_library_spells_the_keywords(tmp_path, monkeypatch):
    monkeypatch.setenv("MASSPROPS_TEST_SECRET", "SECRET_FROM_ENV")
    package = _layout(tmp_path)
    path = _xacro(package / "urdf" / "env.xacro", f'<link name="$(env MASSPROPS_TEST_SECRET)">{_BOX}</link>')
    refused = analyze(path, RobotSettings())
    assert refused["status"] == "error" and "allow_env=True" in refused["message"]
    allowed = analyze(path, RobotSettings(allow_env=True))
    assert [link["link"] for link in allowed["links"]] == ["SECRET_FROM_ENV", "base"]
    yaml = _xacro(package / "urdf" / "yaml.xacro",
                  f'<link name="${{xacro.load_yaml(\'../../outside/secret.yaml\').name}}">{_BOX}</link>')
    refused = analyze(yaml, RobotSettings())
    assert "roots=['DIR']" in refused["message"] and "SECRET_FROM_OUTSIDE" not in refused["message"]
    widened = analyze(yaml, RobotSettings(roots=(str(tmp_path / "outside"),)))
    assert widened["links"][0]["link"] == "SECRET_FROM_OUTSIDE"


@pytest.mark.parametrize("call", ["xacro.load_yaml('/etc/hostname')", "load_yaml('../../outside/secret.yaml')",
                                  "xacro.load_yaml('$(find pkg)/../outside/secret.yaml')",
                                  "xacro.load_yaml('package://pkg/../outside/secret.yaml')"])
def test_load_yaml_is_confined(tmp_path, call):
    package = _layout(tmp_path)
    path = _xacro(package / "urdf" / "r.xacro", f'<link name="${{{call}}}">{_BOX}</link>')
    result = run("robot", "props", path, "--package", f"pkg={package}")
    assert result.exit_code == 1
    assert "outside" in result.output and "refused" in result.output and "--root DIR" in result.output
    assert "SECRET_FROM_OUTSIDE" not in result.output
    with open("/etc/hostname", encoding="utf-8") as handle:
        hostname = handle.read().strip()
    assert f"<{hostname}>" not in result.output and f"'{hostname}'" not in result.output


@pytest.mark.parametrize("spec", ["../../outside/part.xacro", "$(find pkg)/../outside/part.xacro",
                                  "package://pkg/../outside/part.xacro", "/etc/hostname"])
@pytest.mark.parametrize("optional", ["", ' optional="true"'])
def test_includes_are_confined(tmp_path, spec, optional):
    package = _layout(tmp_path)
    path = _xacro(package / "urdf" / "r.xacro", f'<xacro:include filename="{spec}"{optional}/>')
    result = run("robot", "props", path, "--package", f"pkg={package}")
    assert result.exit_code == 1
    assert "refused" in result.output and "SECRET_INCLUDED" not in result.output


def test_root_widens_the_confinement(tmp_path):
    package = _layout(tmp_path)
    path = _xacro(package / "urdf" / "r.xacro", '<xacro:include filename="../../outside/part.xacro"/>')
    result = run("robot", "props", path, "--root", tmp_path / "outside", "--density", 1)
    assert result.exit_code == 0 and "SECRET_INCLUDED" in result.output


def _mesh_robot(path, uri):
    return _write(path, f'<robot name="r"><link name="a"><collision><geometry><mesh filename="{uri}"/></geometry>'
                        f'</collision></link></robot>')


@pytest.mark.parametrize("uri", ["package://pkg/../outside/secret.obj", "../../outside/secret.obj",
                                 "file://{tmp}/outside/secret.obj", "{tmp}/outside/secret.obj",
                                 "../meshes/link.obj"])
def test_mesh_uris_are_confined(tmp_path, uri):
    package = _layout(tmp_path)
    (package / "meshes" / "link.obj").symlink_to(tmp_path / "outside" / "secret.obj")
    path = _mesh_robot(package / "urdf" / "r.urdf", uri.format(tmp=tmp_path))
    result = run("robot", "props", path, "--density", 1, "--format", "json")
    assert result.exit_code == 1
    link = __import__("json").loads(result.stdout)[0]["links"][0]
    assert link["status"] == "error" and link["mass"] is None
    assert f"resolves to {tmp_path / 'outside' / 'secret.obj'}" in link["message"]
    assert "refused" in link["message"] and "--root DIR" in link["message"]
    widened = run("robot", "props", path, "--density", 1, "--root", tmp_path / "outside")
    assert widened.exit_code == 0


def test_the_usual_layout_needs_no_package_xml(tmp_path):
    folder = tmp_path / "robot_description"
    box = solids.box((0.1, 0.2, 0.3))
    (folder / "meshes").mkdir(parents=True)
    obj.write(folder / "meshes" / "box.obj", box.vertices, box.faces)
    path = _mesh_robot(folder / "urdf" / "r.urdf", "../meshes/box.obj")
    result = run("robot", "props", path, "--density", 1)
    assert result.exit_code == 0, result.output
    assert run("robot", "props", _mesh_robot(folder / "urdf" / "far.urdf", "../../secret.obj")).exit_code == 1


def test_a_folder_name_outside_the_roots_is_no_package(tmp_path):
    # package://NAME by a folder called NAME above the model: only inside the roots (else package://etc/passwd).
    package = _layout(tmp_path)
    path = _mesh_robot(package / "urdf" / "r.urdf", "package://outside/secret.obj")
    result = run("robot", "props", path, "--density", 1)
    assert result.exit_code == 1
    assert "not found" in result.output and f"the folder {tmp_path / 'outside'} is outside" in result.output
    assert run("robot", "props", path, "--density", 1, "--root", tmp_path).exit_code == 0


# -- benign files expand exactly as the xacro package expands them -------------------------------

def _benign(tmp_path):
    package = tmp_path / "demo_description"
    _write(package / "package.xml", "<package><name>demo_description</name></package>")
    _write(package / "config" / "arm.yaml", """
        link_lengths: [0.4, 0.3]
        mass: {upper: 2.5, lower: 1.25}
        offset: !degrees 90
        name: demo
    """)
    _write(package / "urdf" / "common.xacro", f"""
        <robot {_XACRO_NS}>
          <xacro:property name="M_PI" value="3.1415926535897931"/>
          <xacro:macro name="box_inertial" params="m x y z *origin">
            <inertial><xacro:insert_block name="origin"/><mass value="${{m}}"/>
              <inertia ixx="${{m * (y*y + z*z) / 12}}" ixy="0" ixz="0" iyy="${{m * (x*x + z*z) / 12}}" iyz="0"
                       izz="${{m * (x*x + y*y) / 12}}"/></inertial>
          </xacro:macro>
        </robot>""")
    _write(package / "urdf" / "arm.urdf.xacro", f"""
        <?xml version="1.0"?>
        <robot name="demo" {_XACRO_NS}>
          <xacro:arg name="prefix" default="left_"/>
          <xacro:arg name="use_tool" default="true"/>
          <xacro:include filename="$(find demo_description)/urdf/common.xacro"/>
          <xacro:include filename="sub/ns.xacro" ns="sub"/>
          <xacro:property name="cfg" value="${{xacro.load_yaml('$(find demo_description)/config/arm.yaml')}}"/>
          <xacro:property name="width" value="0.05"/>
          <xacro:property name="xyz" value="0.1 0.2 0.3"/>
          <xacro:property name="table" value="${{dict_like}}" lazy_eval="true"/>
          <xacro:property name="sizes" value="${{[width, 2 * width, cfg['link_lengths'][0]]}}"/>
          <xacro:macro name="segment" params="name length:=0.3 mass:=^|1.0 *origin">
            <link name="$(arg prefix)${{name}}">
              <xacro:box_inertial m="${{mass}}" x="${{width}}" y="${{width}}" z="${{length}}">
                <xacro:insert_block name="origin"/>
              </xacro:box_inertial>
              <collision><origin xyz="0 0 ${{length / 2}}" rpy="${{pi / 2 if length > 0.35 else 0}} 0 0"/>
                <geometry><box size="${{width}} ${{width}} ${{length}}"/></geometry></collision>
            </link>
          </xacro:macro>
          <xacro:segment name="upper" length="${{cfg.link_lengths[0]}}" mass="${{cfg.mass.upper}}">
            <origin xyz="0 0 ${{cfg['link_lengths'][0] / 2}}"/>
          </xacro:segment>
          <xacro:segment name="lower" length="${{cfg.link_lengths[1]}}" mass="${{cfg['mass']['lower']}}">
            <origin xyz="${{xyz.split(' ')[0]}} 0 ${{-0.5 * cfg.link_lengths[1]}}"/>
          </xacro:segment>
          <xacro:if value="$(arg use_tool)">
            <link name="tool"><collision><geometry>
              <mesh filename="package://demo_description/meshes/tool.stl" scale="${{0.001}} 1e-3 0.001"/>
            </geometry></collision></link>
          </xacro:if>
          <xacro:unless value="${{len(sizes) == 3 and not (width > 1)}}"><link name="never"/></xacro:unless>
          <joint name="elbow" type="revolute">
            <parent link="$(arg prefix)upper"/><child link="$(arg prefix)lower"/>
            <origin xyz="0 0 ${{cfg.link_lengths[0]}}" rpy="${{radians(90)}} ${{cfg.offset}} ${{atan2(1, 1)}}"/>
            <axis xyz="0 1 0"/>
            <limit lower="${{-pi}}" upper="${{math.pi}}" effort="${{max(10, 2 ** 3)}}" velocity="${{round(sqrt(2), 3)}}"/>
          </joint>
          <gazebo reference="$(arg prefix)upper"><material>${{str(cfg.name).upper()}}</material>
            <mu1>$(eval 0.5 * 2)</mu1><id>${{sub.part_id + 1}}</id><m>${{sizes[1:]}}</m><s>${{'%.3f' % width}}</s>
          </gazebo>
        </robot>""")
    _write(package / "urdf" / "sub" / "ns.xacro", f"""
        <robot {_XACRO_NS}><xacro:property name="part_id" value="41"/></robot>""")
    return package


def _plain(path, package, mappings=None):
    from xacro import substitution_args
    original = substitution_args._eval_find
    substitution_args._eval_find = lambda name: str(package)
    try:
        with contextlib.redirect_stderr(io.StringIO()):
            return xacro.process_file(str(path), mappings=dict(mappings or {})).toxml(encoding="utf-8")
    finally:
        substitution_args._eval_find = original


@pytest.mark.parametrize("mappings", [{}, {"prefix": "right_", "use_tool": "false"}])
def test_benign_xacro_expands_as_the_xacro_package_does(tmp_path, mappings):
    from massprops.robot.resolve import Resolver
    from massprops.robot.xacro_safe import expand_xacro
    package = _benign(tmp_path)
    path = package / "urdf" / "arm.urdf.xacro"
    plain = _plain(path, package, mappings)
    ours, warnings = expand_xacro(path, Resolver(str(path), {"demo_description": str(package)}, environ={}),
                                  mappings)
    assert ours == plain
    assert warnings == ()
    assert b"DEMO" in ours and b"1.0" in ours and b'effort="10"' in ours and b"<id>42</id>" in ours


def test_the_hooks_are_restored(tmp_path):
    from xacro import substitution_args
    package = _layout(tmp_path)
    before = (xacro.safe_eval, xacro._global_symbols, xacro.parse, xacro.eval_extension, xacro.abs_filename_spec,
              substitution_args._eval, substitution_args._eval_env, substitution_args._eval_find)
    run("robot", "props", _xacro(package / "urdf" / "r.xacro", _escapes(tmp_path / "m")["issue"]))
    run("robot", "props", _xacro(package / "urdf" / "ok.xacro", ""), "--density", 1)
    after = (xacro.safe_eval, xacro._global_symbols, xacro.parse, xacro.eval_extension, xacro.abs_filename_spec,
             substitution_args._eval, substitution_args._eval_env, substitution_args._eval_find)
    assert all(a is b for a, b in zip(before, after))


def test_evaluate_admits_data_operations():
    from massprops.robot.xacro_safe import evaluate
    names = {"a": 2, "s": "1 2 3", "d": {"k": [1, 2, 3]}}
    cases = {"a ** 3 // 3 % 5": 2, "-a if a > 1 and not a == 3 else 0": -2, "d['k'][-1]": 3,
             "s.split(' ')[1:]": ["2", "3"], "float(s.split()[2]) / 2": 1.5, "1 < a <= 2": True,
             "'%s-%d' % ('x', a)": "x-2", "(1, [2], {'a': 1})": (1, [2], {"a": 1}), "3 in d['k']": True,
             "min(abs(-4), 5) + len(s) + round(2.5)": 11, "radians(180) == pi": True}
    for expression, expected in cases.items():
        assert evaluate(expression, names.__getitem__) == expected, expression
