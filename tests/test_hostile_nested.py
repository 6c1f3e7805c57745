"""Untrusted files: nested graphs computed right or refused, bounded reading, no internal errors, safe output.

Every file is generated here (:mod:`untrusted_files`).  Volumes are checked
against exact rationals within the reported error bound.  The fuzz test runs
each case under a timer of the harness (SIGALRM): a case that never
finishes fails instead of stalling the run.
"""

from __future__ import annotations

import contextlib
import os
import signal
import struct
from fractions import Fraction

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import massprops
import untrusted_files as files
from massprops.cli import main
from massprops.model.errors import MassPropsError, MeshFormatError, MeshGeometryError, OptionError

CASE_SECONDS = 20


class CaseTimeout(BaseException):
    """Raised by the harness's timer: not an Exception, so no reader can swallow it."""


@contextlib.contextmanager
def time_limit(seconds=CASE_SECONDS):
    def expire(signum, frame):
        raise CaseTimeout(f"the case did not finish within {seconds} s")
    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _volume_is(path, expected, **kwargs):
    result = massprops.mass_properties(path, **kwargs)
    props = result.properties
    assert abs(Fraction(props.volume) - Fraction(expected)) <= Fraction(props.error.volume), (props.volume, expected)
    return result


# ---------------------------------------------------------------- silently wrong numbers

def test_a_3mf_sharing_components_between_levels_counts_every_instance(tmp_path):
    path = tmp_path / "shared.3mf"
    count = files.shared_levels_3mf(path, 6)                         # 64 cubes of 1 mm³ (trimesh kept 51)
    result = _volume_is(path, Fraction(count, 10 ** 9))
    assert result.triangles == 12 * count


def test_a_3mf_scene_places_a_shared_component_every_time(tmp_path):
    from massprops.scene.assembly import compute_scene, load_scene
    path = tmp_path / "shared.3mf"
    count = files.shared_levels_3mf(path, 4)
    scene = load_scene(str(path))
    assert len(scene.parts) == count and len(scene.meshes) == 1       # one mesh, integrated once
    total = compute_scene(scene).total
    assert abs(Fraction(total.volume) - count) <= Fraction(total.error.volume)


def test_a_vtu_with_a_voxel_integrates_it_and_refuses_unknown_cells(tmp_path):
    tetra, voxel = files.VTK_CELLS[10], files.VTK_CELLS[11]
    files.write_vtu(tmp_path / "voxel.vtu", [(10, tetra[0]), (11, voxel[0])])
    _volume_is(tmp_path / "voxel.vtu", Fraction(7, 6))               # meshio alone dropped the voxel: 1/6
    files.write_vtu(tmp_path / "unknown.vtu", [(10, tetra[0]), (255, voxel[0])])
    with pytest.raises(MeshFormatError, match="1 of VTK type 255"):
        massprops.mass_properties(tmp_path / "unknown.vtu")


def test_a_collada_graph_places_each_geometry_once_at_every_instance(tmp_path):
    from massprops.scene.assembly import compute_scene, load_scene
    path = tmp_path / "shared.dae"
    count = files.collada_shared(str(path), 6)                      # 64 disjoint unit cubes through shared nodes
    result = _volume_is(path, count)
    assert result.triangles == 12 * count
    scene = load_scene(str(path))
    assert len(scene.parts) == count and len(scene.meshes) == 1       # one geometry, integrated once
    total = compute_scene(scene).total
    assert abs(Fraction(total.volume) - count) <= Fraction(total.error.volume)


# ---------------------------------------------------------------- hangs and runaway memory

def test_nested_graphs_are_bounded_before_expansion(tmp_path):
    files.chain_3mf(tmp_path / "chain.3mf", 1000)
    files.collada_graph(str(tmp_path / "bomb.dae"), 30)              # 2**30 instances in about 1 kB
    files.collada_graph(str(tmp_path / "cycle.dae"), 3, cycle=True)
    with time_limit():
        with pytest.raises(MeshFormatError, match="nested more than 100 levels.*max_depth=N"):
            massprops.mass_properties(tmp_path / "chain.3mf")
        with pytest.raises(MeshFormatError, match="more than the limit of 100000.*max_instances=N"):
            massprops.mass_properties(tmp_path / "bomb.dae")
        with pytest.raises(MeshFormatError, match="instances itself"):
            massprops.mass_properties(tmp_path / "cycle.dae")


def test_the_graph_limits_are_options(runner, tmp_path):
    files.chain_3mf(tmp_path / "chain.3mf", 150)
    files.collada_shared(str(tmp_path / "shared.dae"), 7)            # 128 instances
    deep = runner.invoke(main, ["props", str(tmp_path / "chain.3mf")])
    assert deep.exit_code == 1 and "nested more than 100 levels" in deep.output and "--max-depth N" in deep.output
    raised = runner.invoke(main, ["props", str(tmp_path / "chain.3mf"), "--max-depth", "151", "--format", "json"])
    assert raised.exit_code == 0 and '"volume": 1e-09' in raised.output
    urdf = tmp_path / "robot.urdf"
    urdf.write_text('<robot name="r"><link name="a"><collision><geometry><mesh filename="shared.dae"/></geometry>'
                    '</collision></link></robot>')
    for command, target in ((["props"], "shared.dae"), (["batch", "-q"], "shared.dae"), (["scene"], "shared.dae"),
                            (["view", "-o", str(tmp_path / "shared.png")], "shared.dae"),
                            (["robot", "props"], "robot.urdf")):
        many = runner.invoke(main, [*command, str(tmp_path / target), "--max-instances", "100"])
        assert many.exit_code == 1 and "places at least 128 geometries" in many.output and "--max-instances N" in many.output
        assert runner.invoke(main, [*command, str(tmp_path / target), "--max-instances", "128"]).exit_code == 0
    with pytest.raises(OptionError, match="max_depth must be a positive whole number"):
        massprops.mass_properties(tmp_path / "chain.3mf", max_depth=0)


def test_depth_counts_a_shared_component_met_first_higher_up(tmp_path):
    # Found by the structure-aware fuzz: object 3 holds the cube (level 2) and object 2, which holds the cube
    # again (level 3); the cube, counted once, was not walked again, and its depth below object 2 was missed.
    path = tmp_path / "shared.3mf"
    files.write_3mf(path, [files.cube_object(1), files.components_object(2, [(1, 0.0)]),
                           files.components_object(3, [(1, 0.0), (2, 2.0)])], [(3, 0.0)])
    with pytest.raises(MeshFormatError, match="nested more than 2 levels"):
        massprops.mass_properties(path, max_depth=2)
    _volume_is(path, Fraction(2, 10 ** 9), max_depth=3)
    dae = tmp_path / "shared.dae"
    files.collada_graph(str(dae), 1)                 # top -> n1 -> n0 (3 levels), and trimesh's node0 (1)
    text = dae.read_text().replace('<node id="top"><instance_node url="#n1"/>',
                                   '<node id="top"><instance_node url="#n0"/><instance_node url="#n1"/>')
    dae.write_text(text)
    with pytest.raises(MeshFormatError, match="nested more than 2 levels"):
        massprops.mass_properties(dae, max_depth=2)
    _volume_is(dae, 1, max_depth=3)


def test_a_3mf_component_cycle_is_refused(tmp_path):
    path = tmp_path / "cycle.3mf"
    files.write_3mf(path, [files.components_object(1, [(2, 0.0)]), files.components_object(2, [(1, 0.0)])],
                    [(1, 0.0)])
    with time_limit(), pytest.raises(MeshFormatError, match="contains itself"):
        massprops.mass_properties(path)


@pytest.mark.parametrize("name", ["part.ply", "part.glb", "part.dae", "part.vtu", "mujoco.msh"])
def test_sparse_files_of_every_format_are_refused_before_reading(tmp_path, name):
    path = tmp_path / name
    _seed(path)
    with open(path, "r+b") as f:
        f.truncate(10 * 10 ** 9)                                     # 10 GB, almost all of it a hole
    with time_limit(), pytest.raises(MeshFormatError, match="sparse"):
        massprops.mass_properties(path)


def _compressed_vtu(path, points, compression):
    import meshio
    import numpy as np
    meshio.write(path, meshio.Mesh(points, [("tetra", np.array([[0, 1, 2, 3]]))]), compression=compression)
    return path


@pytest.mark.parametrize("compression", ["zlib", "lzma"])
def test_compressed_vtu_blocks_are_read(tmp_path, compression):
    _volume_is(_compressed_vtu(tmp_path / "part.vtu", files.VTK_CELLS[10][0], compression), Fraction(1, 6))


def test_a_compressed_vtu_inflating_past_the_limit_is_refused(tmp_path):
    import numpy as np
    points = np.zeros((3_000_000, 3))                   # 72 MB of zeros in a file of about 100 kB
    points[:4] = files.VTK_CELLS[10][0]
    path = _compressed_vtu(tmp_path / "bomb.vtu", points, "zlib")
    with time_limit(), pytest.raises(MeshFormatError, match="inflate to more than 67.1 MB"):
        massprops.mass_properties(path)


def test_header_counts_are_checked_against_the_file_before_reading(tmp_path):
    # A 600-byte GLB whose POSITION accessor has no buffer view and 1e9 items: trimesh allocated 12 GB of zeros
    # (24 GB resident before it was killed).
    files.write_glb(tmp_path / "zeros.glb", count=10 ** 9, placeholder=True)
    # A MuJoCo .msh whose counts call for 1.2 GB in 64 bytes; a binary PLY header of 1e9 vertices on 200 bytes.
    (tmp_path / "counts.msh").write_bytes(struct.pack("<4i", 10 ** 8, 0, 0, 4) + bytes(48))
    (tmp_path / "header.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty "
                                          b"float x\nproperty float y\nproperty float z\nend_header\n" + bytes(200))
    # Gmsh 2.2 and 4.1 headers of 1e8 nodes on 70 bytes (meshio allocated 3.2 GB for them before reading).
    (tmp_path / "gmsh22.msh").write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n100000000\n1 0 0 0\n$EndNodes\n")
    (tmp_path / "gmsh41.msh").write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 100000000 1 100000000\n"
                                         "3 1 0 1\n1\n0 0 0\n$EndNodes\n")
    # A Gmsh file numbering a node 2e7 (meshio allocates a table up to it: 8 GB for a node numbered 2e9).
    (tmp_path / "tags.msh").write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"
                                       "20000000 0 0 1\n$EndNodes\n$Elements\n1\n1 4 2 0 1 1 2 3 20000000\n"
                                       "$EndElements\n")
    said = {"zeros.glb": "12.0 GB of zeros from a file of", "tags.msh": "numbers a node 20000000, more than 8388608",
            "counts.msh": "call for 1200000064 bytes, the file has 64",
            "header.ply": "1000000000 vertex elements, which need at least 12.0 GB",
            "gmsh22.msh": "declares 100000000 nodes, more than its 70 bytes", "gmsh41.msh": "declares 100000000 nodes"}
    for name, message in said.items():
        with time_limit(), pytest.raises(MeshFormatError, match=message):
            massprops.mass_properties(tmp_path / name)
    files.write_glb(tmp_path / "small.glb", count=4, placeholder=True)      # 48 bytes of zeros: a flat mesh
    with pytest.raises(MeshGeometryError):
        massprops.mass_properties(tmp_path / "small.glb")


def _seed(path):
    import meshio
    import numpy as np
    import trimesh
    if path.name.startswith("gmsh"):
        meshio.write(path, meshio.Mesh(files.TETRA, [("tetra", np.array([[0, 1, 2, 3]]))]), file_format="gmsh22",
                     binary=False)
    elif path.suffix == ".vtk":
        meshio.write(path, meshio.Mesh(files.TETRA, [("tetra", np.array([[0, 1, 2, 3]]))]))
    elif path.suffix == ".msh":
        with open(path, "wb") as f:
            f.write(struct.pack("<4i", 4, 0, 0, 4) + files.TETRA.tobytes() + files.TETRA_FACES.astype("<i4").tobytes())
    elif path.suffix == ".vtu":
        files.write_vtu(path, [(10, files.VTK_CELLS[10][0])])
    else:
        trimesh.Trimesh(files.TETRA, files.TETRA_FACES, process=False).export(path)


def test_an_mjcf_include_that_is_a_fifo_is_refused(runner, tmp_path):
    os.mkfifo(tmp_path / "included.xml")                            # MuJoCo would block opening it
    (tmp_path / "robot.xml").write_text('<mujoco><worldbody><body name="b"><geom type="box" size="1 1 1"/></body>'
                                        '</worldbody><include file="included.xml"/></mujoco>')
    with time_limit():
        result = runner.invoke(main, ["robot", "props", str(tmp_path / "robot.xml")])
    assert result.exit_code == 1 and "named pipe (FIFO)" in result.output and "Traceback" not in result.output


# ---------------------------------------------------------------- internal errors

def test_an_sdf_including_itself_is_one_line(runner, tmp_path):
    folder = tmp_path / "loop"
    folder.mkdir()
    (folder / "model.config").write_text('<model><name>loop</name><sdf version="1.9">model.sdf</sdf></model>')
    sdf = ('<sdf version="1.9"><model name="loop"><link name="a"><inertial><mass>1</mass></inertial></link>'
           '<include><uri>model://loop</uri><name>inner</name></include></model></sdf>')
    (folder / "model.sdf").write_text(sdf)
    result = runner.invoke(main, ["robot", "props", str(folder / "model.sdf")], env={"GZ_SIM_RESOURCE_PATH": str(tmp_path)})
    assert result.exit_code == 1 and "includes itself" in result.output and "internal error" not in result.output


@pytest.mark.parametrize("kind", sorted(files.GLTF_TYPES))
def test_gltf_positions_must_be_vec3(tmp_path, kind):
    path = tmp_path / "part.glb"
    files.write_glb(path, kind)
    if kind == "VEC3":
        _volume_is(path, Fraction(1, 6))
    else:
        with pytest.raises(MeshFormatError, match=f"shape \\(4, {files.GLTF_TYPES[kind]}\\)|shape \\(4, \\d, \\d\\)"):
            massprops.mass_properties(path)


def test_a_collada_unit_beyond_double_range(tmp_path):
    path = tmp_path / "part.dae"
    files.collada_graph(str(path), 0)
    text = path.read_text()
    path.write_text(text.replace("<asset>", '<asset><unit meter="1e400"/>', 1))
    with pytest.raises(MeshFormatError, match="outside the range"):
        massprops.mass_properties(path)


def test_a_collada_tag_that_is_no_xml_name(tmp_path):
    # Found by the byte fuzz: lxml recovers "<c2026-11-27T05:32:05>" as a tag that lxml's QName then rejects
    # (ValueError: Invalid tag name).
    path = tmp_path / "part.dae"
    files.collada_graph(str(path), 0)
    path.write_text(path.read_text().replace("<created>", "<c2026-11-27T05:32:05.566542</created><created>", 1))
    try:
        _volume_is(path, 1)                       # recovered: the cube, as the file still says
    except MassPropsError as exc:
        assert str(exc).startswith(str(path))


def _tetra_obj(path, x, y, z):
    """A tetrahedron with legs x, y, z along the axes (volume xyz/6)."""
    path.write_text(f"v 0 0 0\nv {x!r} 0 0\nv 0 {y!r} 0\nv 0 0 {z!r}\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    return path


@pytest.mark.parametrize("legs, said", [
    ((1e308, 1e308, 1e308), "too large for double precision .its volume would overflow.: its box is 1e\\+308 by 1e\\+308 by 1e\\+308 mesh "
                            "units, a volume up to 1e\\+924"),
    ((1e308, 1.0, 1.0), "too large for double precision .its volume would overflow.: its box is 1e\\+308 by 1 by 1 mesh units"),
    ((1e200, 1e-100, 1.0), "span too many orders of magnitude .* box is 1e\\+200 by 1e-100 by 1"),
    ((1e-150, 1e-150, 1e-10), "too small for double precision .its volume would underflow.: its box is 1e-150 by 1e-150 by 1e-10 mesh units, "
                              "a volume of at most 1e-310"),
])
def test_a_part_outside_the_range_is_refused_naming_it(tmp_path, legs, said):
    # Before: an OverflowError from core/frame.py, or "zero volume" for parts that are not flat.
    with pytest.raises(MeshGeometryError, match=said):
        massprops.mass_properties(_tetra_obj(tmp_path / "part.obj", *legs))


def test_results_below_the_smallest_normal_double(tmp_path):
    path = _tetra_obj(tmp_path / "tiny.obj", 1e-90, 1e-90, 1e-90)
    # The volume, 1.7e-289 m³, is normal: integrated, within its bound of the exact value.
    result = massprops.mass_properties(path, unit="um", only="volume")
    exact = Fraction(1e-90) ** 3 / 6 / 10 ** 18
    assert abs(Fraction(result.properties.volume) - exact) <= Fraction(result.properties.error.volume)
    # Its inertia, about 1e-470 kg·m², is not (before: 0, and a warning that the principal moment was negative).
    with pytest.raises(MeshGeometryError, match="the inertia is below 2.2e-308"):
        massprops.mass_properties(path, unit="um")
    with pytest.raises(MeshGeometryError, match="the volume, mass and inertia are below 2.2e-308"):
        massprops.mass_properties(_tetra_obj(tmp_path / "tinier.obj", 1e-100, 1e-100, 1e-100), unit="um")


def test_a_3mf_of_many_items_too_small_for_doubles(tmp_path):
    # Before: IndexError.  1000 cubes of 1e-150 µm: volumes of 1e-450 µm³.
    path = tmp_path / "tiny.3mf"
    files.write_3mf(path, [files.cube_object(1, side=1e-150)], [(1, 3e-150 * k) for k in range(1000)], unit="micron")
    with pytest.raises(MeshGeometryError, match="too small for double precision"):
        massprops.mass_properties(path)


# ---------------------------------------------------------------- safe output

def test_file_content_in_messages_is_escaped(runner, tmp_path):
    path = tmp_path / "title.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv \x1b]0;PWNED\x07 0 0\x0b\x85\nf 1 2 3\n")
    for args in (["props", str(path)], ["batch", str(path), "-q"], ["props", str(path), "--format", "json"]):
        result = runner.invoke(main, args)
        text = result.stdout + result.stderr
        assert "\x1b" not in text and "\x07" not in text and "\x0b" not in text and "\x85" not in text
        assert "\\x1b]0;PWNED\\x07 0 0" in text                   # ESC and BEL shown; VT and NEL break no line
        assert len([line for line in result.stderr.splitlines() if line]) <= 1


# ---------------------------------------------------------------- structure-aware fuzz

@st.composite
def nested_3mf(draw):
    """A DAG of component levels over one cube, placed disjointly; sometimes a cycle or a missing object.

    Returns ``(objects, top, instances or None, depth)``: the meshes the top object places, and its levels.
    """
    levels = draw(st.integers(0, 5))
    objects, counts, depths, width = [files.cube_object(1)], {1: 1}, {1: 1}, 1.0
    ids = [1]
    for k in range(levels):
        members = draw(st.lists(st.sampled_from(ids), min_size=1, max_size=3))
        ident = len(counts) + 1
        objects.append(files.components_object(ident, [(m, 2.0 * j * width) for j, m in enumerate(members)]))
        counts[ident] = sum(counts[m] for m in members)
        depths[ident] = 1 + max(depths[m] for m in members)
        width *= 6.0
        ids.append(ident)
    fault = draw(st.sampled_from([None, None, None, "cycle", "missing"]))
    top = draw(st.sampled_from(ids[-2:]))
    if fault == "cycle":
        objects.append(files.components_object(len(counts) + 1, [(len(counts) + 2, 0.0)]))
        objects.append(files.components_object(len(counts) + 2, [(len(counts) + 1, 0.0)]))
        top = len(counts) + 1
    elif fault == "missing":
        top = 999
    return objects, top, counts.get(top), depths.get(top)


# Every format's seed, made sparse: a 4 GB file that is all hole after its first bytes.
SPARSE = ["part.ply", "part.glb", "part.dae", "part.vtu", "mujoco.msh", "gmsh.msh", "part.stl", "part.obj",
          "part.off", "part.3mf", "part.vtk"]


@st.composite
def case(draw):
    """``(kind, spec, limits)``: what to write, and the graph limits to read it with."""
    kind = draw(st.sampled_from(["3mf", "dae", "shared dae", "glb", "vtu", "sparse"]))
    limits = {}
    if kind in ("3mf", "dae", "shared dae") and draw(st.booleans()):
        limits = {"max_instances": draw(st.integers(1, 40)), "max_depth": draw(st.integers(1, 8))}
    if kind == "3mf":
        return kind, draw(nested_3mf()), limits
    if kind == "dae":
        return kind, (draw(st.sampled_from([0, 1, 2, 3, 5, 25, 30])), draw(st.booleans())), limits
    if kind == "shared dae":
        return kind, draw(st.integers(0, 6)), limits
    if kind == "glb":
        return kind, (draw(st.sampled_from(sorted(files.GLTF_TYPES))),
                      draw(st.sampled_from([0, 1, 3, 4, 5, 10 ** 6, 10 ** 9])), draw(st.booleans())), limits
    if kind == "vtu":
        return kind, draw(st.lists(st.sampled_from([10, 11, 12, 13, 14, 42, 255, 2]), min_size=1, max_size=5)), limits
    return kind, draw(st.sampled_from(SPARSE)), limits


def _refused(count, depth, limits):
    """Whether a graph placing ``count`` meshes ``depth`` levels deep exceeds ``limits`` (or the defaults)."""
    return count > limits.get("max_instances", 100_000) or depth > limits.get("max_depth", 100)


def _write_case(tmp_path, kind, spec, limits):
    """Write the case's file; return (path, expected volume in the file's SI result, or None: must be refused)."""
    if kind == "3mf":
        objects, top, count, depth = spec
        path = tmp_path / "case.3mf"
        files.write_3mf(path, objects, [(top, 0.0)])
        return path, None if count is None or _refused(count, depth, limits) else Fraction(count, 10 ** 9)
    if kind == "dae":
        levels, cycle = spec
        path = tmp_path / "case.dae"
        files.collada_graph(str(path), levels, cycle=cycle)
        # Every instance coincides (2**levels, and trimesh's own node): one cube.  Nodes: top, n{levels} ... n0.
        return path, None if cycle or _refused(2 ** levels + 1, levels + 2, limits) else Fraction(1)
    if kind == "shared dae":
        path = tmp_path / "case.dae"
        count = files.collada_shared(str(path), spec)          # nodes: top, then s{k} and a wrapper per level
        return path, None if _refused(count, 2 * spec + 2, limits) else Fraction(count)
    if kind == "glb":
        path = tmp_path / "case.glb"
        files.write_glb(path, *spec)
        return path, Fraction(1, 6) if spec == ("VEC3", 4, False) else None
    if kind == "vtu":
        path = tmp_path / "case.vtu"
        files.write_vtu(path, [(t, files.VTK_CELLS.get(t, files.VTK_CELLS[11])[0]) for t in spec])
        known = all(t in files.VTK_CELLS for t in spec)
        return path, sum(files.VTK_CELLS[t][1] for t in spec) if known else None
    path = tmp_path / spec
    _seed(path)
    with open(path, "r+b") as f:
        f.truncate(1 << 32)
    return path, None


def _outcome(path, limits, sender):
    """In the child: ``("ok", volume, bound)``, ``("refused", message)`` or ``("bug", what)``."""
    try:
        props = massprops.mass_properties(path, **limits).properties
        sender.send(("ok", props.volume, props.error.volume))
    except MassPropsError as exc:
        sender.send(("refused", str(exc)))
    except BaseException as exc:  # noqa: BLE001 - anything else is what the test looks for
        sender.send(("bug", f"{type(exc).__name__}: {exc}"))


def isolated(path, limits, seconds=CASE_SECONDS):
    """The outcome of reading ``path``, computed in a forked child that is killed after ``seconds``.

    A case that never finishes (a hang in Python or in compiled code) fails the test; memory a
    case allocates is returned to the system with the child.
    """
    import multiprocessing
    context = multiprocessing.get_context("fork")
    receiver, sender = context.Pipe(duplex=False)
    child = context.Process(target=_outcome, args=(path, limits, sender))
    child.start()
    sender.close()
    child.join(seconds)
    if child.is_alive():
        child.kill()
        child.join()
        raise CaseTimeout(f"{path.name} did not finish within {seconds} s")
    if not receiver.poll():
        return "bug", f"the child died with exit code {child.exitcode} and said nothing"
    return receiver.recv()


TRIED = {}


def test_structure_aware_mutations_give_the_exact_result_or_a_massprops_error(tmp_path):
    @settings(max_examples=int(os.environ.get("FUZZ_N", "100")), deadline=None, database=None,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(spec=case())
    def check(spec):
        kind, detail, limits = spec
        for old in tmp_path.iterdir():
            old.unlink()
        path, expected = _write_case(tmp_path, kind, detail, limits)
        TRIED[kind] = TRIED.get(kind, 0) + 1
        outcome = isolated(path, limits)
        assert outcome[0] != "bug", (spec, outcome)
        if outcome[0] == "refused":
            assert outcome[1].startswith(str(path)) and "\n" not in outcome[1]
            assert expected is None, (spec, outcome[1])
            return
        _, volume, bound = outcome
        assert expected is not None, (spec, volume)
        assert abs(Fraction(volume) - expected) <= Fraction(bound), (spec, volume)

    check()
    print(f"structure-aware fuzz: {sum(TRIED.values())} files tried: {TRIED}")
    assert sum(TRIED.values()) >= 1
