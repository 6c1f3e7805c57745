"""Assemblies: `massprops scene` against hand-written formulas, direct integration and instancing."""

import json
import os
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import massprops.cli
from massprops.model.combine import combine_parts
from massprops.scene import assembly
from massprops.validation import solids
from massprops import mass_properties
from massprops.model.frames import Pose
from massprops.io.stl import write_binary

U = 2.0 ** -53
EULER = {"sequence": "ZYX", "angles": [30.0, -20.0, 75.0]}


def _write(directory, name, mesh):
    path = os.path.join(directory, name)
    write_binary(path, mesh.triangles)
    return path


def _toml(path, text):
    with open(path, "w") as handle:
        handle.write(text)
    return str(path)


def _run(runner, *args):
    result = runner.invoke(massprops.cli.main, ["scene", *map(str, args)])
    return result


def _json(runner, *args):
    result = _run(runner, *args, "--format", "json")
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


def _fr(values):
    return [[Fraction(float(x)) for x in row] for row in np.atleast_2d(values)]


def _matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _transpose(a):
    return [list(r) for r in zip(*a)]


TWO_PARTS = """
[parts.slab]
mesh = "slab.stl"
density = 2.5
position = [1.5, -2.0, 0.75]
rotation = {{ euler = {angles}, sequence = "{sequence}" }}

[parts.block]
mesh = "block.stl"
density = 0.75
position = [-0.5, 3.0, 1.25]
rotation = {{ quaternion = [0.5, 0.5, 0.5, 0.5] }}
"""
# (size, local center) of each box: dyadic, so the STL files hold them exactly.
BOXES = {"slab": ((2.0, 1.0, 0.5), (0.25, -0.5, 0.125)), "block": ((0.5, 1.5, 1.0), (-0.375, 0.25, 0.5))}


def _two_part_scene(tmp_path):
    for name, (size, center) in BOXES.items():
        _write(tmp_path, f"{name}.stl", solids.box(size, center))
    return _toml(tmp_path / "two.toml", TWO_PARTS.format(angles=EULER["angles"], sequence=EULER["sequence"]))


def test_two_parts_match_the_derivation_written_out(tmp_path):
    """Total mass, COM and J about the total COM from the derivation, in exact rationals."""
    result = assembly.compute_scene(assembly.load_scene(_two_part_scene(tmp_path)))
    poses = {"slab": Pose.from_euler(EULER["sequence"], EULER["angles"], translation=[1.5, -2.0, 0.75]),
             "block": Pose.from_quat([0.5, 0.5, 0.5, 0.5], translation=[-0.5, 3.0, 1.25])}
    density = {"slab": Fraction(5, 2), "block": Fraction(3, 4)}
    masses, positions, rotated = {}, {}, {}
    for name, (size, center) in BOXES.items():
        a, b, c = (Fraction(s) for s in size)
        m = density[name] * a * b * c
        local = [[m * (b * b + c * c) / 12, 0, 0], [0, m * (a * a + c * c) / 12, 0], [0, 0, m * (a * a + b * b) / 12]]
        rotation = _fr(poses[name].rotation)
        masses[name] = m
        positions[name] = [sum(rotation[i][k] * Fraction(center[k]) for k in range(3))
                           + Fraction(float(poses[name].translation[i])) for i in range(3)]
        rotated[name] = _matmul(_matmul(rotation, local), _transpose(rotation))      # A J' Aᵀ
    total = sum(masses.values())
    com = [sum(masses[n] * positions[n][i] for n in masses) / total for i in range(3)]
    inertia = [[Fraction(0)] * 3 for _ in range(3)]
    for n in masses:
        rho = [positions[n][i] - com[i] for i in range(3)]
        for i in range(3):
            for j in range(3):
                shift = masses[n] * ((rho[0] ** 2 + rho[1] ** 2 + rho[2] ** 2 if i == j else 0) - rho[i] * rho[j])
                inertia[i][j] += rotated[n][i][j] + shift
    got = result.total
    assert abs(Fraction(got.mass) - total) <= Fraction(got.error.mass)
    assert max(abs(Fraction(got.center_of_mass[i]) - com[i]) for i in range(3)) <= Fraction(got.error.center_of_mass)
    worst = max(abs(Fraction(got.inertia_com[i, j]) - inertia[i][j]) for i in range(3) for j in range(3))
    assert worst <= Fraction(got.error.inertia_com)
    assert got.error.inertia_com < 1e-13 * float(np.abs(got.inertia_com).max())
    assert abs(got.inertia_com[0, 1]) > 0.1          # the rotations make products of inertia: signs are tested


def test_two_parts_equal_direct_integration_of_the_transformed_meshes(tmp_path):
    path = _toml(tmp_path / "same.toml", TWO_PARTS.replace("density = 0.75", "density = 2.5").format(
        angles=EULER["angles"], sequence=EULER["sequence"]))
    for name, (size, center) in BOXES.items():
        _write(tmp_path, f"{name}.stl", solids.box(size, center))
    result = assembly.compute_scene(assembly.load_scene(path))
    placed = [solids.box(*BOXES[p.name]).transformed(p.pose.rotation, p.pose.translation)
              for p in result.scene.parts]
    direct = mass_properties(solids.combine(*placed), density=2.5).properties
    total = result.total
    scale = float(np.abs(direct.inertia_com).max())
    # Transforming the vertices rounds them (≈ u·|x|), which moves the direct result by ~1e-15 relative.
    assert abs(total.mass - direct.mass) <= 1e-13 * direct.mass
    assert np.abs(total.center_of_mass - direct.center_of_mass).max() <= 1e-13 * 4
    assert np.abs(total.inertia_com - direct.inertia_com).max() <= 1e-13 * scale
    for frame in (Pose(), Pose.from_euler("xyz", [10, 20, 30], translation=[3.0, -1.0, 2.0])):
        assert np.abs(total.in_frame(frame) - direct.in_frame(frame)).max() <= 1e-13 * float(
            np.abs(direct.in_frame(frame)).max())


HALVES = """
[parts.left]
mesh = "half.stl"
position = [-0.75, 0.0, 0.0]

[parts.right]
mesh = "half.stl"
position = [0.75, 0.0, 0.0]
"""


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-4, 4), min_size=3, max_size=3), st.lists(st.floats(-180, 180), min_size=3, max_size=3))
def test_box_cut_in_halves_equals_the_whole_box(tmp_path_factory, origin, angles):
    directory = tmp_path_factory.mktemp("halves")
    _write(directory, "half.stl", solids.box((1.5, 1.0, 0.5)))
    result = assembly.compute_scene(assembly.load_scene(_toml(directory / "halves.toml", HALVES)))
    whole = mass_properties(solids.box((3.0, 1.0, 0.5))).properties
    total = result.total
    assert result.stats["meshes_integrated"] == 1 and result.stats["instances"] == 2
    assert total.volume == pytest.approx(whole.volume, rel=1e-13, abs=0)
    assert np.abs(total.center_of_mass - whole.center_of_mass).max() <= 1e-13
    frame = Pose.from_euler("xyz", angles, translation=origin)
    expected = whole.in_frame(frame)
    assert np.abs(total.in_frame(frame) - expected).max() <= 1e-13 * float(np.abs(expected).max())
    assert np.abs(total.inertia_com - whole.inertia_com).max() <= 1e-13 * float(np.abs(whole.inertia_com).max())


def test_inertia_about_another_parts_frame_equals_integrating_in_that_frame(tmp_path, runner):
    bracket = solids.l_bracket(3.0, 1.0, 0.5)
    _write(tmp_path, "bracket.stl", bracket)
    _write(tmp_path, "block.stl", solids.box(*BOXES["block"]))
    path = _toml(tmp_path / "frames.toml", TWO_PARTS.replace("slab.stl", "bracket.stl").format(
        angles=EULER["angles"], sequence=EULER["sequence"]) + '\n[report]\nabout = ["block"]\n')
    obj = _json(runner, path)
    pose_i = Pose.from_euler(EULER["sequence"], EULER["angles"], translation=[1.5, -2.0, 0.75])
    pose_j = Pose.from_quat([0.5, 0.5, 0.5, 0.5], translation=[-0.5, 3.0, 1.25])
    # The bracket expressed in the block's frame: x_j = A_jᵀ (A_i x' + r_i − r_j).
    relative = pose_j.inverse().compose(pose_i)
    direct = mass_properties(bracket.transformed(relative.rotation, relative.translation), density=2.5).properties
    expected = direct.about((0.0, 0.0, 0.0))
    slab = next(p for p in obj["parts"] if p["name"] == "slab")
    got = np.array(slab["inertia_in_frames"][0]["inertia"])
    assert slab["inertia_in_frames"][0]["frame"] == "block"
    assert np.abs(got - expected).max() <= 1e-13 * float(np.abs(expected).max())
    assert abs(expected[0, 1]) > 1.0


def _instanced_glb(directory):
    import trimesh
    box = solids.box((1.0, 0.5, 2.0), (0.25, 0.0, -0.5))
    bracket = solids.l_bracket(2.0, 0.5, 1.0)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(box.vertices, box.faces, process=False), geom_name="box", node_name="b0")
    scene.add_geometry(trimesh.Trimesh(bracket.vertices, bracket.faces, process=False), geom_name="bracket",
                       node_name="l0")
    # Rotations by quarter turns keep every matrix entry exact in float32.
    placements = {"b1": ("box", [[0, -1, 0], [1, 0, 0], [0, 0, 1]], [2.0, 0.5, 0.0]),
                  "b2": ("box", [[1, 0, 0], [0, 0, -1], [0, 1, 0]], [-1.5, 0.0, 3.0]),
                  "l1": ("bracket", [[0, 0, 1], [1, 0, 0], [0, 1, 0]], [4.0, -2.0, 1.0]),
                  "l2": ("bracket", [[-1, 0, 0], [0, -1, 0], [0, 0, 1]], [0.0, 0.0, -3.0])}
    for node, (geometry, rotation, translation) in placements.items():
        matrix = np.eye(4)
        matrix[:3, :3], matrix[:3, 3] = rotation, translation
        scene.graph.update(frame_to=node, frame_from=scene.graph.base_frame, geometry=geometry, matrix=matrix)
    path = os.path.join(directory, "instanced.glb")
    scene.export(path)
    placements.update(b0=("box", np.eye(3), [0.0, 0.0, 0.0]), l0=("bracket", np.eye(3), [0.0, 0.0, 0.0]))
    return path, {"box": box, "bracket": bracket}, placements


def test_glb_instances_are_integrated_once_and_match_the_toml_equivalent(tmp_path, monkeypatch, runner):
    import massprops.core
    path, meshes, placements = _instanced_glb(tmp_path)
    calls = []
    real = massprops.core.integrate
    monkeypatch.setattr(massprops.core, "integrate", lambda *a, **k: calls.append(1) or real(*a, **k))
    obj = _json(runner, path)
    assert len(calls) == 2
    assert obj["stats"]["meshes_integrated"] == 2 and obj["stats"]["instances"] == 6
    lines = []
    for name, mesh in meshes.items():
        _write(tmp_path, f"{name}.stl", mesh)
    for node, (geometry, rotation, translation) in placements.items():
        rows = ", ".join("[" + ", ".join(str(float(x)) for x in row) + "]" for row in np.asarray(rotation))
        lines.append(f'[parts.{node}]\nmesh = "{geometry}.stl"\nposition = {list(translation)}\n'
                     f"rotation = {{ matrix = [{rows}] }}\n")
    toml = _json(runner, _toml(tmp_path / "same.toml", "\n".join(lines)))
    for key in ("volume", "mass", "center_of_mass", "inertia_com", "inertia_origin", "principal_moments"):
        a, b = np.array(obj["total"][key]), np.array(toml["total"][key])
        assert np.abs(a - b).max() <= 1e-14 * max(1.0, float(np.abs(b).max())), key


def test_glb_non_uniform_scale_is_applied_exactly(tmp_path, runner):
    import trimesh
    bracket = solids.l_bracket(2.0, 0.5, 1.0)
    linear = np.array([[0.0, -3.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, -0.5]]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.25], [0.0, 0.0, 1.0]])      # a quarter turn, a mirror, a stretch, a shear
    matrix = np.eye(4)
    matrix[:3, :3], matrix[:3, 3] = linear, [1.0, 2.0, 3.0]
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(bracket.vertices, bracket.faces, process=False), geom_name="l",
                       node_name="stretched", transform=matrix)
    path = os.path.join(tmp_path, "scaled.glb")
    scene.export(path)
    obj = _json(runner, path)
    direct = mass_properties(bracket.transformed(linear, [1.0, 2.0, 3.0])).properties
    part = obj["parts"][0]
    assert part["volume"] == pytest.approx(direct.volume, rel=1e-14)
    assert part["surface_area"] == pytest.approx(direct.surface_area, rel=1e-13)
    assert np.abs(np.array(part["center_of_mass_global"]) - direct.center_of_mass).max() <= 1e-14
    scale = float(np.abs(direct.inertia_com).max())
    assert np.abs(np.array(part["inertia_com_global"]) - direct.inertia_com).max() <= 1e-13 * scale
    assert np.abs(np.array(obj["total"]["inertia_com"]) - direct.inertia_com).max() <= 1e-13 * scale


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(-180, 180), min_size=3, max_size=3), st.sampled_from(["ZYX", "xyz", "ZXZ", "yzy"]))
def test_rotation_forms_round_trip(tmp_path_factory, euler, sequence):
    from scipy.spatial.transform import Rotation
    directory = tmp_path_factory.mktemp("rot")
    _write(directory, "bracket.stl", solids.l_bracket())
    rotation = Rotation.from_euler(sequence, euler, degrees=True)      # an independent implementation
    q = np.roll(rotation.as_quat(), 1)                                  # scipy gives x, y, z, w
    matrix = rotation.as_matrix()
    forms = {"q": f"{{ quaternion = {list(map(float, q))} }}",
             "e": f'{{ euler = {list(map(float, euler))}, sequence = "{sequence}" }}',
             "m": "{ matrix = [" + ", ".join(str(list(map(float, row))) for row in matrix) + "] }"}
    text = "\n".join(f'[parts.{k}]\nmesh = "bracket.stl"\nposition = [1.0, 2.0, 3.0]\nrotation = {v}\n'
                     for k, v in forms.items())
    result = assembly.compute_scene(assembly.load_scene(_toml(directory / "rot.toml", text)))
    rotations = [p.pose.rotation for p in result.parts]
    for other in rotations[1:]:
        assert np.abs(other - rotations[0]).max() <= 1e-13
    inertias = [p.inertia_com_global for p in result.parts]
    for other in inertias[1:]:
        assert np.abs(other - inertias[0]).max() <= 1e-12 * float(np.abs(inertias[0]).max())


def test_only_what_is_asked_is_computed(tmp_path, monkeypatch):
    import massprops.core
    import massprops.model.properties
    _write(tmp_path, "slab.stl", solids.box(*BOXES["slab"]))
    _write(tmp_path, "block.stl", solids.box(*BOXES["block"]))
    orders, eigen = [], []
    real_integrate, real_principal = massprops.core.integrate, massprops.model.properties.principal
    monkeypatch.setattr(massprops.core, "integrate",
                        lambda *a, order=2, **k: orders.append(order) or real_integrate(*a, order=order, **k))
    monkeypatch.setattr(massprops.model.properties, "principal", lambda *a, **k: eigen.append(1) or real_principal(*a, **k))
    base = TWO_PARTS.format(angles=EULER["angles"], sequence=EULER["sequence"])
    mass_only = _toml(tmp_path / "mass.toml", base + '\n[report]\nquantities = ["mass"]\nprincipal = "none"\n')
    result = assembly.compute_scene(assembly.load_scene(mass_only))
    assert orders == [0, 0] and result.total.inertia_com is None and result.total.center_of_mass is None
    assert result.stats["quantities_computed"] == ["mass"] and result.stats["principal_decompositions"] == 0
    from click.testing import CliRunner
    obj = _json(CliRunner(), mass_only)
    assert "inertia_com" not in obj["total"] and "principal_moments" not in obj["total"] and eigen == []
    orders.clear()
    inertia = _toml(tmp_path / "inertia.toml", base + '\n[report]\nquantities = ["inertia"]\nprincipal = false\n')
    obj = _json(CliRunner(), inertia)
    assert orders == [2, 2] and eigen == [] and "principal_moments" not in obj["total"]
    obj = _json(CliRunner(), inertia, "--only", "principal")
    assert len(eigen) == 3 == obj["stats"]["principal_decompositions"] and "principal_axes" in obj["total"]
    assert "inertia_com" not in obj["parts"][0] and "principal_axes" in obj["parts"][0]


def test_csv_and_text_outputs(tmp_path, runner):
    from massprops.report import CSV_COLUMNS
    path = _two_part_scene(tmp_path)
    csv = _run(runner, path, "--format", "csv")
    assert csv.exit_code == 0
    lines = csv.stdout.splitlines()
    assert lines[0] == ",".join(CSV_COLUMNS)
    assert [line.split(",")[0] for line in lines[1:]] == [f"{path}#slab", f"{path}#block", f"{path}#total"]
    text = _run(runner, path)
    assert text.exit_code == 0 and "part slab" in text.stdout and "principal moments" in text.stdout


def test_sample_scene_runs_and_reuses_the_bolt(runner):
    sample = os.path.join(os.path.dirname(__file__), "..", "sample_meshes", "scene", "arm.toml")
    obj = _json(runner, sample)
    assert obj["stats"]["instances"] == 5 and obj["stats"]["meshes_integrated"] == 4
    assert obj["total"]["mass"] == pytest.approx(sum(p["mass"] for p in obj["parts"]), rel=1e-15)
    assert [f["frame"] for f in obj["total"]["inertia_in_frames"]] == ["tool", "mount", "post"]
    light = _json(runner, sample, "--only", "mass,center_of_mass")
    assert light["stats"]["moment_order"] == 1 and light["stats"]["principal_decompositions"] == 0
    assert "inertia_in_frames" not in light["total"] and "inertia_com" not in light["parts"][0]
    assert light["total"]["center_of_mass"] == obj["total"]["center_of_mass"]


@pytest.mark.parametrize("edit, fragment", [
    (lambda t: t.replace('mesh = "block.stl"', 'mesh = "missing.stl"'), "part 'block': no such file"),
    (lambda t: t.replace("density = 2.5", "dencity = 2.5"), "part 'slab': unknown key 'dencity'"),
    (lambda t: t.replace('sequence = "ZYX"', 'sequence = "ZQX"'), "part 'slab': Euler sequence"),
    (lambda t: t.replace("quaternion = [0.5, 0.5, 0.5, 0.5]", "axis = [1, 0, 0]"), "part 'block': cannot read"),
    (lambda t: t.replace("0.5, 0.5, 0.5, 0.5]", "0.5, 0.5, 0.5, \"x\"]"), "part 'block': cannot read"),
    (lambda t: t.replace("0.5, 0.5, 0.5, 0.5]", "0.5, 0.5, 0.5]"), "part 'block': a quaternion needs 4"),
    (lambda t: t + "\n[report]\nabout = [\"nowhere\"]\n", "unknown frame or part 'nowhere'"),
    (lambda t: t + "\n[frames.f]\npart = \"ghost\"\n", "frame 'f': is attached to unknown part 'ghost'"),
    (lambda t: t + "\n[report]\nunit = \"furlong\"\n", "unknown unit 'furlong'"),
    (lambda t: t + "\n[parts.x\n", "not valid TOML"),
])
def test_bad_scenes_say_what_and_where(tmp_path, runner, edit, fragment):
    path = _two_part_scene(tmp_path)
    with open(path) as handle:
        text = handle.read()
    _toml(path, edit(text))
    result = _run(runner, path)
    assert result.exit_code == 1
    assert fragment in result.stderr and "Traceback" not in result.output
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1


def test_a_bad_part_mesh_names_the_part_and_its_file(tmp_path, runner):
    from badfiles import make_bad_files
    bad = make_bad_files(tmp_path)
    open_mesh = next(p for p in bad if p.endswith("open.stl"))
    _write(tmp_path, "slab.stl", solids.box(*BOXES["slab"]))
    path = _toml(tmp_path / "bad.toml", f'[parts.good]\nmesh = "slab.stl"\n\n[parts.leaky]\nmesh = "{open_mesh}"\n')
    result = _run(runner, path)
    assert result.exit_code == 1
    assert "part 'leaky'" in result.stderr and open_mesh in result.stderr and bad[open_mesh] in result.stderr


def test_bad_scene_graphs_are_refused_with_the_node_named(tmp_path, runner):
    import trimesh
    box = solids.box((1.0, 2.0, 3.0))
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(box.vertices, box.faces[:-1], process=False), geom_name="lid",
                       node_name="open_box")
    leaky = os.path.join(tmp_path, "leaky.glb")
    scene.export(leaky)
    result = _run(runner, leaky)
    assert result.exit_code == 1 and "part 'open_box'" in result.stderr and "open" in result.stderr
    garbage = tmp_path / "garbage.glb"
    garbage.write_bytes(b"glTF not really")
    result = _run(runner, garbage)
    assert result.exit_code == 1 and "cannot parse" in result.stderr and str(garbage) in result.stderr
    result = _run(runner, _write(tmp_path, "part.stl", box))
    assert result.exit_code == 1 and "unknown scene format" in result.stderr


def test_3mf_scene_matches_its_glb(tmp_path, runner):
    """A 3MF scene graph (trimesh's reader, which needs lxml) gives the GLB's totals."""
    glb, _, _ = _instanced_glb(tmp_path)
    three_mf = tmp_path / "instanced.3mf"
    import trimesh
    trimesh.load(glb, process=False).export(three_mf)
    from_glb, from_3mf = _json(runner, glb), _json(runner, three_mf)
    assert from_3mf["stats"]["instances"] == 6
    for key in ("mass", "center_of_mass", "inertia_com"):
        a, b = np.array(from_3mf["total"][key]), np.array(from_glb["total"][key])
        assert np.abs(a - b).max() <= 1e-13 * max(1.0, float(np.abs(b).max())), key


# -- many instances in compact form --------------------------------------------------------------------------

def _random_placements(count, seed):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(count, 4)), rng.uniform(-50, 50, size=(count, 3))


def _tables(mesh, quats, positions, prefix):
    return "".join(f'[parts.{prefix}{k}]\nmesh = "{mesh}"\ndensity = 2.5\nposition = {positions[k].tolist()}\n'
                   f"rotation = {{ quaternion = {quats[k].tolist()} }}\n\n" for k in range(len(quats)))


def test_compact_instances_equal_the_same_parts_as_tables(tmp_path, runner):
    _write(tmp_path, "bracket.stl", solids.l_bracket(3.0, 1.0, 0.5))
    _write(tmp_path, "block.stl", solids.box(*BOXES["block"]))
    brackets, blocks = _random_placements(7, 1), _random_placements(5, 2)
    with open(tmp_path / "brackets.csv", "w") as handle:
        handle.write("# placements of the bracket\nqw, qx, qy, qz, x, y, z, name\n\n")
        handle.writelines(",".join(repr(float(v)) for v in (*q, *p)) + f",br{k}\n"
                          for k, (q, p) in enumerate(zip(*brackets)))
    compact = _toml(tmp_path / "compact.toml",
                    '[parts.br]\nmesh = "bracket.stl"\ndensity = 2.5\ninstances = "brackets.csv"\n\n'
                    f'[parts.bl]\nmesh = "block.stl"\ndensity = 2.5\npositions = {blocks[1].tolist()}\n'
                    f"quaternions = {blocks[0].tolist()}\n\n"
                    '[frames.tip]\npart = "br3"\nposition = [1.0, 2.0, 3.0]\n\n[report]\nabout = ["tip", "bl[4]"]\n')
    frames = '[frames.tip]\npart = "br3"\nposition = [1.0, 2.0, 3.0]\n\n[report]\nabout = ["tip", "bl4"]\n'
    tables = _toml(tmp_path / "tables.toml", _tables("bracket.stl", *brackets, "br")
                   + _tables("block.stl", *blocks, "bl") + frames)
    ours, theirs = _json(runner, compact), _json(runner, tables)
    assert ours["stats"]["instances"] == 12 and ours["stats"]["meshes_integrated"] == 2
    assert [p["name"] for p in ours["parts"]] == [f"br{k}" for k in range(7)] + [f"bl[{k}]" for k in range(5)]
    for key in ("volume", "mass", "center_of_mass", "inertia_com", "inertia_origin", "principal_moments"):
        a, b = np.array(ours["total"][key]), np.array(theirs["total"][key])
        assert np.abs(a - b).max() <= 1e-14 * float(np.abs(b).max()), key
    for a, b in zip(ours["total"]["inertia_in_frames"], theirs["total"]["inertia_in_frames"]):
        assert np.abs(np.array(a["inertia"]) - b["inertia"]).max() <= 1e-14 * float(np.abs(b["inertia"]).max())
    for a, b in zip(ours["parts"], theirs["parts"]):
        assert np.abs(np.array(a["inertia_com_global"]) - b["inertia_com_global"]).max() <= 1e-14 * float(
            np.abs(b["inertia_com_global"]).max())


def test_many_compact_instances_against_the_closed_form(tmp_path):
    """2,000 cubes at integer points, unrotated: exact mass, COM and inertia of point masses plus cubes."""
    _write(tmp_path, "cube.stl", solids.box((1.0, 1.0, 1.0)))
    positions = np.random.default_rng(4).integers(-100, 100, size=(2000, 3))
    with open(tmp_path / "cubes.csv", "w") as handle:
        handle.write("x,y,z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in positions))
    result = assembly.compute_scene(assembly.load_scene(_toml(
        tmp_path / "cubes.toml", '[parts.cube]\nmesh = "cube.stl"\ninstances = "cubes.csv"\n'
                                 '[report]\nparts = false\n')))
    n = Fraction(len(positions))
    com = [Fraction(int(s)) / n for s in positions.sum(axis=0)]
    rho = [[Fraction(int(v)) - com[i] for i, v in enumerate(p)] for p in positions]
    second = [[sum(r[i] * r[j] for r in rho) for j in range(3)] for i in range(3)]
    trace = sum(second[i][i] for i in range(3))
    inertia = [[(n / 6 + trace if i == j else 0) - second[i][j] for j in range(3)] for i in range(3)]
    total = result.total
    assert result.stats["instances"] == 2000 and result.stats["meshes_integrated"] == 1 and result.parts == ()
    assert abs(Fraction(total.mass) - n) <= Fraction(total.error.mass)
    assert max(abs(Fraction(total.center_of_mass[i]) - com[i]) for i in range(3)) <= Fraction(
        total.error.center_of_mass)
    assert max(abs(Fraction(total.inertia_com[i, j]) - inertia[i][j]) for i in range(3) for j in range(3)) <= \
        Fraction(total.error.inertia_com)


@pytest.mark.parametrize("rows, fragment", [
    ("x,y,z\n1,2,3\n4,abc,5\n", "line 3: y = 'abc' is not a number"),
    ("x,y,z\n1,2,3\n\n4,5\n", "line 4: 2 columns, the header has 3"),
    ("x,y,z,qw,qx\n1,2,3,1,0\n", "line 1: cannot read the header"),
    ("x,y,zz\n1,2,3\n", "line 1: cannot read the header"),
    ("x,y,z,qw,qx,qy,qz\n1,2,3,1,0,0,0\n1,2,3,0,0,0,0\n", "line 3: a quaternion of zero length"),
    ("x,y,z\n1,2,3\n1,nan,3\n", "line 3: a value is not finite"),
    ("name,x,y,z\na,1,2,3\nb,1,2,3\na,4,5,6\n", "line 4: the name 'a' is used twice"),
    ("name,x,y,z\na,1,2,3\n,1,2,3\n", "line 3: the name is empty"),
    ("# nothing\nx,y,z\n", "no instances"),
])
def test_bad_instance_rows_name_the_file_and_line(tmp_path, runner, rows, fragment):
    csv = tmp_path / "bolts.csv"
    csv.write_text(rows)
    error = _refused(runner, tmp_path, 'instances = "bolts.csv"')
    assert error.startswith(f"error: {csv}: part 'bolts': ") and fragment in error


def _refused(runner, directory, keys):
    """stderr of a scene whose one part ``bolts`` has ``keys``: one error line, exit 1."""
    _write(directory, "block.stl", solids.box(*BOXES["block"]))
    result = _run(runner, _toml(directory / "s.toml", f'[parts.bolts]\nmesh = "block.stl"\n{keys}\n'))
    assert result.exit_code == 1 and "Traceback" not in result.output
    assert result.stderr.startswith("error: ") and result.stderr.count("\n") == 1
    return result.stderr


@pytest.mark.parametrize("keys, fragment", [
    ("positions = [[1, 2, 3], [4, 5]]", "positions entry 1 is not 3 finite numbers"),
    ("positions = [[1, 2, 3], [4, 5, true]]", "positions entry 1 is not 3 finite numbers"),
    ("positions = [[1, 2, 3]]\nquaternions = [[1, 0, 0, 0], [1, 0, 0, 0]]", "quaternions has 2 entries but"),
    ("positions = [[1, 2, 3]]\nquaternions = [[0, 0, 0, 0]]", "entry 0: a quaternion of zero length"),
    ("quaternions = [[1, 0, 0, 0]]", "quaternions needs positions"),
    ("positions = [[1, 2, 3]]\nposition = [1, 2, 3]", "not both"),
    ('positions = [[1, 2, 3]]\ninstances = "x.csv"', "not both"),
    ('instances = "missing.csv"', "no such file"),
])
def test_bad_inline_instances_say_what(tmp_path, runner, keys, fragment):
    error = _refused(runner, tmp_path, keys)
    assert "part 'bolts': " in error and fragment in error


# -- volume-mesh parts with per-cell densities ---------------------------------------------------------------

def test_volume_mesh_parts_with_density_map_and_field(tmp_path, runner):
    """A two-material bar (two unit cubes: steel x < 1, aluminium) placed twice, by groups and by a field."""
    import meshio
    from test_volume import kuhn_tets
    steel_rho, aluminium_rho = Fraction(7850), Fraction(2700)
    points, tets = kuhn_tets([(0, 0, 0), (1, 0, 0)])
    steel = points[tets].mean(axis=1)[:, 0] < 1
    tags = np.where(steel, 1, 2)
    meshio.write(str(tmp_path / "bar.msh"), meshio.Mesh(
        points, [("tetra", tets)], cell_data={"gmsh:physical": [tags], "gmsh:geometrical": [tags]},
        field_data={"steel": np.array([1, 3]), "aluminium": np.array([2, 3])}), file_format="gmsh22", binary=False)
    rho = np.where(steel, float(steel_rho), float(aluminium_rho))
    meshio.write(str(tmp_path / "bar.vtu"), meshio.Mesh(points, [("tetra", tets)], cell_data={"rho": [rho]}))
    path = _toml(tmp_path / "bars.toml", f"""
[parts.mapped]
mesh = "bar.msh"
density_map = {{ steel = {float(steel_rho)}, aluminium = {float(aluminium_rho)} }}
position = [0.0, 0.0, 0.0]

[parts.field]
mesh = "bar.vtu"
density_field = "rho"
position = [0.0, 0.0, 1.0]
rotation = {{ quaternion = [0.0, 1.0, 0.0, 0.0] }}

[parts.uniform]
mesh = "bar.msh"
density = 1000
position = [5.0, 0.0, 0.0]
""")
    obj = _json(runner, path, "--density", "1")
    assert obj["stats"]["meshes_read"] == 2 and obj["stats"]["meshes_integrated"] == 3
    mass = steel_rho + aluminium_rho
    cx = (steel_rho / 2 + aluminium_rho * 3 / 2) / mass
    shift = steel_rho * (Fraction(1, 2) - cx) ** 2 + aluminium_rho * (Fraction(3, 2) - cx) ** 2
    expected = np.diag([float(mass / 6), float(mass / 6 + shift), float(mass / 6 + shift)])
    mapped, field, uniform = obj["parts"]
    for part in (mapped, field):
        assert part["mass"] == pytest.approx(float(mass), rel=1e-15)
        assert np.abs(np.array(part["center_of_mass"]) - [float(cx), 0.5, 0.5]).max() <= 1e-14
        assert np.abs(np.array(part["inertia_com"]) - expected).max() <= 1e-13 * float(mass)
    assert uniform["mass"] == pytest.approx(2000.0, rel=1e-15)
    # The field part is turned half about x and lifted by 1: it sits in y ∈ [-1, 0], z ∈ [0, 1].
    assert np.abs(np.array(field["center_of_mass_global"]) - [float(cx), -0.5, 0.5]).max() <= 1e-14
    assert obj["total"]["mass"] == pytest.approx(float(2 * mass + 2000), rel=1e-15)


@pytest.mark.parametrize("keys, fragment", [
    ('density_field = "rho"\ndensity = 3', "give density or density_field, not both"),
    ('density_map = { steel = "heavy" }', "cannot read density_map"),
    ('density_field = "rho"', "need a volume mesh"),
])
def test_bad_cell_density_keys(tmp_path, runner, keys, fragment):
    error = _refused(runner, tmp_path, keys)
    assert "part 'bolts': " in error and fragment in error


def test_npy_instances_equal_csv_instances(tmp_path):
    _write(tmp_path, "block.stl", solids.box(*BOXES["block"]))
    quats, positions = _random_placements(6, 3)
    np.save(tmp_path / "blocks.npy", np.column_stack([positions, quats]))
    np.save(tmp_path / "moved.npy", positions)
    np.save(tmp_path / "flat.npy", positions.ravel())
    with open(tmp_path / "blocks.csv", "w") as handle:
        handle.write("x,y,z,qw,qx,qy,qz\n" + "".join(",".join(map(repr, row)) + "\n"
                                                   for row in np.column_stack([positions, quats]).tolist()))
    totals = {}
    for name in ("blocks.npy", "blocks.csv", "moved.npy"):
        scene = assembly.load_scene(_toml(tmp_path / "s.toml", f'[parts.b]\nmesh = "block.stl"\ninstances = "{name}"\n'))
        totals[name] = assembly.compute_scene(scene).total
    assert np.array_equal(totals["blocks.npy"].inertia_com, totals["blocks.csv"].inertia_com)
    assert not np.allclose(totals["moved.npy"].inertia_com, totals["blocks.csv"].inertia_com)
    from massprops.model.errors import MeshFormatError
    with pytest.raises(MeshFormatError, match=r"part 'b': an array of shape \(18,\)") as caught:
        assembly.load_scene(_toml(tmp_path / "s.toml", '[parts.b]\nmesh = "block.stl"\ninstances = "flat.npy"\n'))
    assert caught.value.path == str(tmp_path / "flat.npy")


def test_sample_flange_lists_its_bolts_in_a_csv_file(runner):
    sample = os.path.join(os.path.dirname(__file__), "..", "sample_meshes", "scene", "flange.toml")
    obj = _json(runner, sample)
    assert obj["stats"]["instances"] == 9 and obj["stats"]["meshes_integrated"] == 2 and obj["parts"] == []
    each = _json(runner, sample, "--only", "mass")
    bolt = mass_properties(os.path.join(os.path.dirname(sample), "bolt.stl"), density=7850, unit="mm").properties
    plate = mass_properties(os.path.join(os.path.dirname(sample), "plate.stl"), density=2700, unit="mm").properties
    assert each["total"]["mass"] == pytest.approx(plate.mass + 8 * bolt.mass, rel=1e-15)
    # Eight bolts on a circle about z: the total's COM is on the z axis.
    assert np.abs(np.array(obj["total"]["center_of_mass"][:2])).max() <= 1e-15


def test_parts_without_mass_have_no_center_of_mass():
    from massprops.model.errors import MeshGeometryError
    from massprops.model.properties import MassProperties
    part = massprops.mass_properties(solids.box()).properties
    massless = MassProperties(part.volume, 0.0, 0.0, part.surface_area, part.center_of_mass, part.inertia_com * 0.0,
                              part.error)
    with pytest.raises(MeshGeometryError, match="no center of mass"):
        combine_parts([massless, massless])
