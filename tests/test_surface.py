"""The public surface (issue 25): unit mistakes warned of, option conflicts caught before any file is read."""

from __future__ import annotations

import json

import pytest

from massprops.cli import main
from massprops.io.stl import write_binary
from massprops.validation import solids
from untrusted_files import cube_object, write_3mf


def _cube_stl(path, side=1.0):
    write_binary(path, solids.box((side, side, side)).triangles)
    return str(path)


def _cube_3mf(path):
    write_3mf(path, [cube_object(1)], [(1, 0.0)])          # a unit cube, declared in millimetres
    return str(path)


def _warnings(output):
    return [line for line in output.splitlines() if line.startswith("warning:")]


# ---------------------------------------------------------------- units caught

def test_a_kg_per_m3_density_on_a_mesh_without_unit_is_warned_of_once_and_the_mass_kept(tmp_path, runner):
    files = [_cube_stl(tmp_path / "a.stl"), _cube_stl(tmp_path / "b.stl", 2.0)]
    out = runner.invoke(main, ["props", *files, "--density", "7850", "--format", "json"])
    assert out.exit_code == 0, out.output
    warned = [w for w in _warnings(out.stderr) if "mesh units unknown" in w]
    assert len(warned) == 1 and "--unit mm" in warned[0]
    masses = [obj["mass"] for obj in json.loads(out.stdout)]
    assert masses == [7850.0, 7850.0 * 8]                     # never changed


def test_a_g_per_cm3_density_with_a_unit_is_warned_of_and_kept(tmp_path, runner):
    path = _cube_stl(tmp_path / "a.stl", 10.0)
    out = runner.invoke(main, ["props", path, "--unit", "mm", "--density", "7.85", "--format", "json"])
    assert out.exit_code == 0, out.output
    (warned,) = _warnings(out.stderr)
    assert "lighter than cork" in warned and "--density 7850" in warned
    assert json.loads(out.stdout)[0]["mass"] == pytest.approx(7.85 * 1e-6, rel=1e-14)


def test_a_density_denser_than_any_solid_with_a_unit_is_warned_of(tmp_path, runner):
    out = runner.invoke(main, ["props", _cube_stl(tmp_path / "a.stl"), "--unit", "m", "--density", "78500000"])
    assert out.exit_code == 0, out.output
    (warned,) = _warnings(out.stderr)
    assert "denser than osmium" in warned


def test_a_file_that_declares_its_unit_gets_the_cork_warning_without_unit_option(tmp_path, runner):
    out = runner.invoke(main, ["props", _cube_3mf(tmp_path / "a.3mf"), "--density", "7.85"])
    assert out.exit_code == 0, out.output
    assert any("lighter than cork" in w for w in _warnings(out.stderr))
    assert not any("mesh units unknown" in w for w in _warnings(out.stderr))


@pytest.mark.parametrize("args", [["--density", "2.7"], [], ["--unit", "mm", "--density", "7850"],
                                  ["--mass", "5"]])
def test_plausible_densities_are_not_warned_of(tmp_path, runner, args):
    out = runner.invoke(main, ["props", _cube_stl(tmp_path / "a.stl"), *args])
    assert out.exit_code == 0, out.output
    assert _warnings(out.stderr) == []


def test_a_batch_mixing_declared_and_undeclared_units_is_warned_of(tmp_path, runner):
    _cube_stl(tmp_path / "a.stl")
    _cube_3mf(tmp_path / "b.3mf")
    out = runner.invoke(main, ["batch", str(tmp_path), "-j", "1", "-q"])
    assert out.exit_code == 0, out.output
    (warned,) = _warnings(out.stderr)
    assert "mixes units" in warned and "mm" in warned and "--unit" in warned


def test_a_batch_with_one_unit_is_not_warned_of(tmp_path, runner):
    _cube_stl(tmp_path / "a.stl")
    _cube_3mf(tmp_path / "b.3mf")
    out = runner.invoke(main, ["batch", str(tmp_path), "-j", "1", "-q", "--unit", "mm", "--density", "7850"])
    assert out.exit_code == 0, out.output
    assert _warnings(out.stderr) == []


# ---------------------------------------------------------------- option conflicts

MISSING = "no_such_dir/missing_part.stl"


@pytest.mark.parametrize("args, named", [
    (["props", MISSING, "--mass", "1", "--density", "7850"], ("--density", "--mass")),
    (["props", MISSING, "--shell", "1", "--density-field", "rho"], ("--shell", "--density-field")),
    (["props", MISSING, "--shell", "1", "--density-map", "a=1"], ("--shell", "--density-map")),
    (["props", MISSING, "--density-field", "rho", "--density-map", "a=1"], ("--density-field", "--density-map")),
    (["props", MISSING, "--density", "2", "--density-field", "rho"], ("--density", "--density-field")),
    (["batch", MISSING, "--mass", "1", "--density", "2"], ("--density", "--mass")),
    (["batch", MISSING, "--timeout", "5", "--scheduler", "local"], ("--timeout", "--scheduler")),
    (["view", MISSING, "-o", "x.html", "--mass", "1", "--density", "2"], ("--density", "--mass")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--rtol", "1e-6", "--steps", "10"],
     ("--rtol", "--steps")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--compare-methods", "--out", "x.csv"],
     ("--compare-methods", "--out")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--mass", "1", "--density", "2"],
     ("--density", "--mass")),
    (["robot", "write", "missing_robot.urdf", "--all", "--links", "arm*", "-o", "x.urdf"], ("--links", "--all")),
    (["robot", "write", "missing_robot.urdf", "-o", "x.urdf", "--in-place"], ("--output", "--in-place")),
    (["props", MISSING, "--check-trimesh", "--shell", "1"], ("--check-trimesh", "--shell")),
    (["props", MISSING, "--check-trimesh", "--density-field", "rho"], ("--check-trimesh", "--density-field")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--compare-methods", "--method", "RK45"],
     ("--compare-methods", "--method")),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--compare-methods", "--rtol", "1e-6"],
     ("--compare-methods", "--rtol")),
    (["robot", "check", "missing_robot.urdf", "--declared-only", "--density", "2700"],
     ("--declared-only", "--density")),
    (["robot", "check", "missing_robot.urdf", "--declared-only", "--on-open", "hull"],
     ("--declared-only", "--on-open")),
])
def test_an_option_conflict_is_a_usage_error_before_any_file_is_read(runner, args, named):
    out = runner.invoke(main, args)
    assert out.exit_code == 2, out.output
    assert all(name in out.stderr for name in named) and "not both" in out.stderr
    assert "missing" not in out.stderr.replace("--", "")


@pytest.mark.parametrize("args, said", [
    (["props", MISSING, "--digits", "5", "--format", "json"], "--digits applies to --format text, not json"),
    (["scene", "missing_scene.toml", "--digits", "5", "--format", "csv"], "--digits applies to --format text"),
    (["props", MISSING, "--check-trimesh", "--format", "csv"], "--check-trimesh applies to --format text"),
    (["spin", MISSING, "--omega", "1", "0", "0", "--duration", "1", "--torque-frame", "world"],
     "--torque-frame needs --torque"),
])
def test_an_option_that_does_not_apply_is_a_usage_error_before_any_file_is_read(runner, args, said):
    out = runner.invoke(main, args)
    assert out.exit_code == 2, out.output
    assert said in out.stderr and "missing" not in out.stderr.replace("--", "")


def test_the_options_that_do_apply_together_still_run(tmp_path, runner):
    path = _cube_stl(tmp_path / "a.stl")
    assert runner.invoke(main, ["props", path, "--digits", "5", "--format", "text"]).exit_code == 0
    out = runner.invoke(main, ["spin", path, "--omega", "0,0,1", "--duration", "0.1", "--samples", "2",
                               "--torque", "0,0,1", "--torque-frame", "world", "--out", str(tmp_path / "t.csv")])
    assert out.exit_code == 0, out.output
    # a unit cube (I = 1/6 about every axis) spun up about z: ω_z(t) = 1 + T t / I, exactly 1.6 at t = 0.1
    header, _, last = (tmp_path / "t.csv").read_text().splitlines()
    assert float(dict(zip(header.split(","), last.split(",")))["wz"]) == pytest.approx(1.6, rel=1e-12)


# ---------------------------------------------------------------- one option language

def _json_out(runner, args):
    out = runner.invoke(main, args)
    assert out.exit_code == 0, out.output
    return out.stdout


def _without_times(objs):
    return [{k: v for k, v in o.items() if k != "elapsed_s"} for o in objs]


def test_points_and_vectors_take_commas_or_spaces_alike_in_props(tmp_path, runner):
    path = _cube_stl(tmp_path / "a.stl", 2.0)
    spaced = json.loads(_json_out(runner, ["props", path, "--translate", "1", "-2", "3", "--about", "0", "0", "4",
                                           "--omega", "0", "0", "1", "--format", "json"]))
    commas = json.loads(_json_out(runner, ["props", path, "--translate", "1,-2,3", "--about", "0,0,4",
                                           "--omega=0,0,1", "--format", "json"]))
    assert _without_times(spaced) == _without_times(commas)
    obj = commas[0]
    assert obj["pose"]["translation"] == [1.0, -2.0, 3.0]
    assert obj["inertia_about"][0]["point"] == [0.0, 0.0, 4.0]
    # a 2-cube of density 1: Izz about its centre is m (a² + b²) / 12 = 8 · 8 / 12; ω = (0, 0, 1)
    assert obj["angular_momentum"]["local"] == pytest.approx([0.0, 0.0, 64 / 12], abs=1e-12)


def test_a_point_with_two_numbers_is_a_usage_error(tmp_path, runner):
    out = runner.invoke(main, ["props", MISSING, "--about", "1,2"])
    assert out.exit_code == 2 and "X,Y,Z or X Y Z" in out.stderr


def test_batch_translate_takes_spaces_too(tmp_path, runner):
    path = _cube_stl(tmp_path / "a.stl")
    rows = [_json_out(runner, ["batch", path, "-q", "-j", "1", "--format", "jsonl", "--translate", *form])
            for form in (["5", "6", "7"], ["5,6,7"])]
    objs = [json.loads(r) for r in rows]
    assert objs[0]["pose"]["translation"] == objs[1]["pose"]["translation"] == [5.0, 6.0, 7.0]


def test_spin_vectors_take_spaces_or_commas(tmp_path, runner):
    path = _cube_stl(tmp_path / "a.stl")
    base = ["spin", path, "--duration", "0.5", "--samples", "3", "--steps", "10"]
    _json_out(runner, base + ["--omega", "1", "2", "3", "--torque", "0", "0", "1", "--out", str(tmp_path / "s.csv")])
    _json_out(runner, base + ["--omega", "1,2,3", "--torque", "0,0,1", "--out", str(tmp_path / "c.csv")])
    spaced, commas = ((tmp_path / name).read_text() for name in ("s.csv", "c.csv"))
    assert spaced == commas
    header, first = spaced.splitlines()[:2]
    start = dict(zip(header.split(","), map(float, first.split(","))))
    assert [start["wx"], start["wy"], start["wz"]] == [1.0, 2.0, 3.0]


@pytest.mark.parametrize("fmt", ["text", "json", "jsonl", "csv"])
def test_props_writes_every_format(tmp_path, runner, fmt):
    files = [_cube_stl(tmp_path / "a.stl"), _cube_stl(tmp_path / "b.stl", 2.0)]
    text = _json_out(runner, ["props", *files, "--format", fmt, "--only", "volume"])
    if fmt == "json":
        assert [o["volume"] for o in json.loads(text)] == [1.0, 8.0]
    elif fmt == "jsonl":
        assert [json.loads(line)["volume"] for line in text.splitlines()] == [1.0, 8.0]
    elif fmt == "csv":
        assert [line.split(",")[4] for line in text.splitlines()[1:]] == ["1.0", "8.0"]
    else:
        assert "volume                 1 " in text and "density 1)" in text


def test_batch_only_leaves_the_other_columns_empty(tmp_path, runner):
    _cube_stl(tmp_path / "a.stl", 2.0)
    text = _json_out(runner, ["batch", str(tmp_path), "-q", "-j", "1", "--only", "volume,center_of_mass"])
    header, row = text.splitlines()
    cells = dict(zip(header.split(","), row.split(",")))
    assert cells["volume"] == "8.0" and cells["cx"] == "0.0"
    assert cells["mass"] == cells["Ixx"] == cells["I1"] == ""
    jsonl = json.loads(_json_out(runner, ["batch", str(tmp_path), "-q", "-j", "1", "--format", "jsonl",
                                          "--only", "mass"]))
    assert jsonl["mass"] == 8.0 and "inertia_com" not in jsonl and "center_of_mass" not in jsonl


def test_batch_only_refuses_an_unknown_quantity(runner):
    out = runner.invoke(main, ["batch", MISSING, "--only", "colour"])
    assert out.exit_code == 2 and "colour" in out.stderr


SCENE = """
[parts.a]
mesh = "a.stl"
position = [1, 0, 0]

[parts.b]
mesh = "b.stl"
position = [-1, 0, 0]
"""


@pytest.mark.parametrize("fmt", ["json", "jsonl", "csv", "text"])
def test_scene_writes_every_format_and_only(tmp_path, runner, fmt):
    _cube_stl(tmp_path / "a.stl")
    _cube_stl(tmp_path / "b.stl")
    (tmp_path / "s.toml").write_text(SCENE)
    text = _json_out(runner, ["scene", str(tmp_path / "s.toml"), "--format", fmt, "--only", "mass"])
    if fmt == "jsonl":
        blocks = [json.loads(line) for line in text.splitlines()]
        assert [b["name"] for b in blocks] == ["a", "b", "total"]
        assert [b["mass"] for b in blocks] == [1.0, 1.0, 2.0]
        assert all("inertia_com" not in b for b in blocks)
    elif fmt == "json":
        assert json.loads(text)["total"]["mass"] == 2.0
    elif fmt == "csv":
        assert [line.split(",")[5] for line in text.splitlines()[1:]] == ["1.0", "1.0", "2.0"]
    else:
        assert text.count(", density 1)") == 2 and text.count(", mean density 1)") == 1      # parts, total


ROBOT = "sample_meshes/robot/massprops_robot/urdf/robot.urdf"


@pytest.mark.parametrize("command", ["props", "check"])
def test_robot_writes_jsonl_one_model_a_line(runner, command):
    import os
    root = os.path.join(os.path.dirname(__file__), "..")
    model = os.path.join(root, ROBOT)
    out = runner.invoke(main, ["robot", command, model, "--format", "jsonl", "--declared-only"]
                        if command == "check" else ["robot", "props", model, "--format", "jsonl"])
    assert out.exit_code in (0, 1), out.output           # the sample robot has an invalid link on purpose
    (line,) = out.stdout.splitlines()
    obj = json.loads(line)
    assert obj["model"] == model and obj["links"]
    if command == "props":
        assert obj["default_density"] == 1000.0


def test_help_states_the_density_defaults(runner):
    assert "Default 1, so mass = volume" in " ".join(runner.invoke(main, ["props", "--help"]).output.split())
    assert "Default 1000" in " ".join(runner.invoke(main, ["robot", "props", "--help"]).output.split())


# ---------------------------------------------------------------- no SPEC in user output

@pytest.mark.parametrize("command", [["props"], ["scene"], ["batch"], ["spin"], ["view"], ["compare"], ["check"],
                                     ["solids"], ["regress"], ["accuracy"], ["robot"], ["robot", "props"],
                                     ["robot", "check"], ["robot", "write"], []])
def test_help_cites_no_document_users_do_not_have(runner, command):
    out = runner.invoke(main, [*command, "--help"])
    assert out.exit_code == 0 and "Usage" in out.output
    assert "SPEC" not in out.output


def test_degenerate_axes_point_to_the_conventions_page(tmp_path, runner):
    import os
    text = _json_out(runner, ["props", _cube_stl(tmp_path / "a.stl")])
    assert "SPEC" not in text and "docs/conventions.md" in text
    root = os.path.join(os.path.dirname(__file__), "..")
    assert os.path.exists(os.path.join(root, "docs", "conventions.md"))


# ---------------------------------------------------------------- small things

def test_a_complete_batch_leaves_no_state_file_and_an_interrupted_one_does(tmp_path, runner):
    from massprops.batch import run as batch
    folder = tmp_path / "parts"
    folder.mkdir()
    for k in range(3):
        _cube_stl(folder / f"p{k}.stl", 1.0 + k)
    out = tmp_path / "report.csv"
    result = runner.invoke(main, ["batch", str(folder), "-o", str(out), "-j", "1", "-q"])
    assert result.exit_code == 0 and out.exists()
    assert not (tmp_path / "report.csv.state.jsonl").exists()

    def interrupt(outcome):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        batch.run_batch(batch.expand_inputs([str(folder)]), output=str(out), jobs=1, on_outcome=interrupt)
    assert (tmp_path / "report.csv.state.jsonl").exists()        # what --resume needs
    result = runner.invoke(main, ["batch", str(folder), "-o", str(out), "-j", "1", "--resume"])
    assert result.exit_code == 0 and "2 computed" in result.stderr
    assert (tmp_path / "report.csv.state.jsonl").exists()        # kept by a --resume run, for the next one


def test_a_closed_hole_of_one_face_is_said_in_the_singular():
    import massprops
    box = solids.box((1.0, 2.0, 3.0))
    result = massprops.mass_properties((box.vertices, box.faces[1:]), repair=True)
    assert result.warnings == ("closed holes with 1 new face",) and result.volume == 6.0


def test_a_volume_mesh_is_described_by_its_cells(tmp_path, runner):
    from untrusted_files import VTK_CELLS, write_vtu
    path = tmp_path / "two.vtu"
    write_vtu(path, [(12, VTK_CELLS[12][0]), (10, VTK_CELLS[10][0])])
    out = runner.invoke(main, ["props", str(path), "--only", "volume"])
    assert out.exit_code == 0, out.output
    header = out.stdout.splitlines()[0]
    assert "2 cells" in header and "hexahedron" in header and "tetra" in header and "triangle" not in header
    assert out.stdout.splitlines()[1].split()[:2] == ["volume", "1.16666666666667"]


_CLASS_NAME = __import__("re").compile(r"\b[A-Z][A-Za-z0-9]*(?:Error|Exception|Warning)\b|BadZipFile|NoneType|"
                                       r"Traceback")


def _hostile_files(folder):
    from badfiles import make_bad_files
    from untrusted_files import chain_3mf, collada_graph, write_glb
    files = list(make_bad_files(folder))
    for name, text in (("garbage.dae", "garbage"), ("no_nodes.dae", '<COLLADA><asset><unit meter="x"/></asset>'
                                                                    "</COLLADA>"), ("garbage.3mf", "PK garbage"),
                       ("garbage.glb", "glTF garbage"), ("garbage.ply", "ply\nformat ascii 1.0\nelement vertex x\n"),
                       ("garbage.vtu", "<VTKFile><UnstructuredGrid>"), ("garbage.msh", "$MeshFormat\n9 9 9\n")):
        (folder / name).write_text(text)
        files.append(str(folder / name))
    collada_graph(folder / "cycle.dae", 2, cycle=True)
    write_glb(folder / "mat4.glb", kind="MAT4")
    write_glb(folder / "short.glb", count=40)
    chain_3mf(folder / "deep.3mf", 300)
    return files + [str(folder / n) for n in ("cycle.dae", "mat4.glb", "short.glb", "deep.3mf")]


def test_no_refusal_of_the_hostile_corpus_names_a_python_class(tmp_path, runner):
    folder = tmp_path / "bad"
    folder.mkdir()
    files = _hostile_files(folder)
    out = runner.invoke(main, ["props", *files])
    assert out.exit_code == 1
    lines = out.stderr.splitlines()
    assert sum(line.startswith("error: ") for line in lines) >= len(files) - 2      # (a few may be readable)
    named = [line for line in lines if _CLASS_NAME.search(line)]
    assert named == []


def test_scene_and_spin_warn_of_a_kg_per_m3_density_without_unit(tmp_path, runner):
    _cube_stl(tmp_path / "a.stl")
    (tmp_path / "s.toml").write_text('[parts.a]\nmesh = "a.stl"\n')
    for args in (["scene", str(tmp_path / "s.toml")],
                 ["spin", str(tmp_path / "a.stl"), "--omega", "0,0,1", "--duration", "0.1", "--samples", "2"]):
        warned = runner.invoke(main, [*args, "--density", "7850"])
        assert warned.exit_code == 0, warned.output
        assert [w for w in _warnings(warned.stderr) if "--unit mm" in w] != []
        plain = runner.invoke(main, [*args, "--density", "7850", "--unit", "mm"])
        assert plain.exit_code == 0 and _warnings(plain.stderr) == []
        assert "density 7850 kg/m³" in plain.stdout


def test_view_takes_points_with_spaces(tmp_path, runner):
    path = _cube_stl(tmp_path / "a.stl")
    out = tmp_path / "a.png"
    result = runner.invoke(main, ["view", path, "-o", str(out), "--translate", "1", "2", "3", "--about", "0", "0", "1"])
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 0


def test_props_warns_of_files_that_mix_declared_and_undeclared_units(tmp_path, runner):
    files = [_cube_stl(tmp_path / "a.stl"), _cube_3mf(tmp_path / "b.3mf")]
    out = runner.invoke(main, ["props", *files, "--format", "csv"])
    assert out.exit_code == 0, out.output
    assert [w for w in _warnings(out.stderr) if "mixes units" in w] != []
    assert _warnings(runner.invoke(main, ["props", *files, "--unit", "mm"]).stderr) == []
