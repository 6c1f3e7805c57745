"""Readers the solid needs: COLLADA with its unit and up axis, MuJoCo's binary .msh, 3MF units,
volume cells with bent faces, and what props and batch say about files they do not read."""

import json
import zipfile
from fractions import Fraction

import numpy as np
import pytest

from massprops.cli import main
from massprops import mass_properties
from massprops.model.errors import MeshFormatError
from massprops.mesh.volume import VolumeMesh
from massprops.validation import solids
from oracle import exact_properties
from test_solid import box, within_bounds


def scaled(exact, factor, rotation=None):
    """The exact values of the same body with lengths times ``factor`` (a Fraction), optionally turned."""
    rotation = np.eye(3, dtype=int) if rotation is None else rotation
    com = [sum(int(rotation[i][k]) * exact["center_of_mass"][k] for k in range(3)) * factor for i in range(3)]
    inertia = [[sum(int(rotation[i][k]) * int(rotation[j][l]) * exact["inertia_com"][k][l]
                    for k in range(3) for l in range(3)) * factor ** 5 for j in range(3)] for i in range(3)]
    return {"volume": exact["volume"] * factor ** 3, "center_of_mass": com, "inertia_com": inertia}


PART = box((0.5, 1.0, -2.0), (2.5, 4.0, 3.0))          # 2 × 3 × 5, off the origin


def _collada(path, mesh, meter, up):
    positions = " ".join(repr(float(x)) for x in mesh.vertices.ravel())
    indices = " ".join(str(int(i)) for i in mesh.faces.ravel())
    path.write_text(f"""<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="centimeter" meter="{meter}"/><up_axis>{up}</up_axis></asset>
  <library_geometries><geometry id="part"><mesh>
    <source id="part-positions"><float_array id="part-array" count="{mesh.vertices.size}">{positions}</float_array>
      <technique_common><accessor source="#part-array" count="{len(mesh.vertices)}" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
      </accessor></technique_common></source>
    <vertices id="part-vertices"><input semantic="POSITION" source="#part-positions"/></vertices>
    <triangles count="{len(mesh.faces)}"><input semantic="VERTEX" source="#part-vertices" offset="0"/>
      <p>{indices}</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="scene"><node id="node">
    <instance_geometry url="#part"/></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
""")


def test_collada_in_centimetres_with_y_up_is_applied(tmp_path):
    path = tmp_path / "part.dae"
    _collada(path, PART, "0.01", "Y_UP")
    result = mass_properties(path)
    # Y up turned to z up: x' = x, y' = -z, z' = y; centimetres: SI lengths are 1/100.
    turn = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    within_bounds(result.properties, scaled(exact_properties(PART.triangles), Fraction(1, 100), turn))
    assert result.properties.unit == "cm"
    assert any("up_axis" in w for w in result.warnings) and any("unit meter" in w for w in result.warnings)


def test_collada_with_an_unnamed_unit_is_scaled_to_metres(tmp_path):
    path = tmp_path / "part.dae"
    _collada(path, PART, "0.5", "Z_UP")
    result = mass_properties(path)
    within_bounds(result.properties, scaled(exact_properties(PART.triangles), Fraction(1, 2)))


def _mujoco(path, vertices, faces, normals=0, texcoords=0):
    counts = np.array([len(vertices), normals, texcoords, len(faces)], dtype="<i4")
    with open(path, "wb") as f:
        f.write(counts.tobytes())
        f.write(np.asarray(vertices, dtype="<f4").tobytes())
        f.write(np.zeros(3 * normals + 2 * texcoords, dtype="<f4").tobytes())
        f.write(np.asarray(faces, dtype="<i4").tobytes())


def test_mujoco_binary_msh(tmp_path):
    mesh = solids.l_bracket(3.0, 1.0, 0.7)
    vertices = (mesh.vertices + [0.1, -0.3, 0.7]).astype(np.float32)
    path = tmp_path / "bracket.msh"
    _mujoco(path, vertices, mesh.faces, normals=len(vertices), texcoords=5)
    result = mass_properties(path)
    within_bounds(result.properties, exact_properties(vertices.astype(np.float64)[mesh.faces]))
    assert result.source_dtype == "float32"


def test_a_truncated_mujoco_msh_is_refused_with_its_byte_count(tmp_path):
    path = tmp_path / "cut.msh"
    _mujoco(path, PART.vertices, PART.faces)
    path.write_bytes(path.read_bytes()[:-4])
    with pytest.raises(MeshFormatError, match=r"call for \d+ bytes, the file has \d+"):
        mass_properties(path)


def test_gmsh_msh_still_goes_to_meshio(tmp_path):
    import meshio
    points = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.0, 2, 0], [0.0, 0, 3]])
    path = tmp_path / "tet.msh"
    meshio.write(path, meshio.Mesh(points, [("tetra", np.array([[0, 1, 2, 3]]))]), file_format="gmsh22",
                 binary=False)
    assert mass_properties(path).properties.volume == pytest.approx(1.0, rel=1e-15)


def test_3mf_unit_inch_is_applied(tmp_path):
    import trimesh
    path = tmp_path / "part.3mf"
    trimesh.Trimesh(PART.vertices, PART.faces, process=False).export(path)
    with zipfile.ZipFile(path) as archive:
        contents = {name: archive.read(name) for name in archive.namelist()}
    model = next(name for name in contents if name.endswith(".model"))
    contents[model] = contents[model].replace(b'unit="millimeter"', b'unit="inch"')
    assert b'unit="inch"' in contents[model]
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in contents.items():
            archive.writestr(name, data)
    result = mass_properties(path)
    within_bounds(result.properties, scaled(exact_properties(PART.triangles), Fraction(254, 10000)))
    assert any("inch" in w for w in result.warnings)


def test_a_hexahedron_with_a_bent_face_says_how_far_the_volume_can_differ():
    points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1.25], [0, 1, 1]],
                      dtype=float)
    result = mass_properties(VolumeMesh(points, (("hexahedron", np.arange(8)[None]),)))
    # Split through node 4: z = 1 + y/4 and z = 1 + x/4 over the two halves; the trilinear top is
    # z = 1 + xy/4.  Volumes 1 + 1/12 and 1 + 1/16: they differ by det/12 = (1/4)/12 = 1/48.
    assert result.properties.volume == pytest.approx(1 + 1 / 12, rel=1e-15)
    assert result.checks["nonplanar_faces"] == 1
    assert any(f"by up to {1 / 48:.3g}" in w for w in result.warnings)
    flat = points.copy()
    flat[6, 2] = 1.0
    assert mass_properties(VolumeMesh(flat, (("hexahedron", np.arange(8)[None]),))).warnings == ()


def test_props_names_an_unsupported_format_and_a_conversion(runner, tmp_path):
    path = tmp_path / "part.step"
    path.write_text("ISO-10303-21;\n")
    result = runner.invoke(main, ["props", str(path)])
    assert result.exit_code == 1
    assert "STEP CAD model" in result.stderr and "export STL" in result.stderr


def test_batch_counts_what_it_skipped_by_extension(runner, tmp_path):
    from massprops.io.stl import write_binary
    write_binary(tmp_path / "a.stl", PART.triangles)
    for name in ("robot.urdf", "other.urdf", "look.mtl", "README"):
        (tmp_path / name).write_text("x")
    result = runner.invoke(main, ["batch", str(tmp_path), "-o", str(tmp_path / "out.csv")])
    assert result.exit_code == 0, result.output
    assert "skipped 2 .urdf, 1 (none), 1 .mtl" in result.stderr


def test_json_checks_say_what_was_resolved(runner, tmp_path):
    from massprops.io.stl import write_binary
    path = tmp_path / "two.stl"
    write_binary(path, np.concatenate([PART.triangles, box((2.0, 3.0, 2.0), (3.0, 5.0, 4.0)).triangles]))
    obj = json.loads(runner.invoke(main, ["props", "--format", "json", str(path)]).output)[0]
    assert obj["checks"]["overlap"] == pytest.approx(0.5 * 1.0 * 1.0)
    assert obj["checks"]["duplicate_shells"] == 0 and obj["checks"]["self_intersection"] == "none"
    one = tmp_path / "one.stl"
    write_binary(one, PART.triangles)
    off = json.loads(runner.invoke(main, ["props", "--format", "json", "--no-self-intersection", str(one)]).output)
    assert off[0]["checks"]["self_intersection"] == "not checked"
