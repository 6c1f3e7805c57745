"""Hostile inputs: special files, lying sizes, archives, third-party readers that exit or print.

Each is refused with one line naming the file (no traceback, no hang, bounded
memory), and the good files given with it are still reported.
"""

from __future__ import annotations

import os
import socket
import stat
import zipfile

import numpy as np
import pytest

import massprops
from massprops.cli import main
from massprops.model.errors import MeshFormatError, MeshGeometryError, MeshReadError, OutputError
from massprops.validation import solids


def _props(runner, *args):
    return runner.invoke(main, ["props", *map(str, args)])


def _one_error_line(result, path, fragment):
    lines = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert "Traceback" not in result.output
    assert len([line for line in lines if str(path) in line]) == 1, result.stderr
    assert any(fragment in line for line in lines), result.stderr


# ---------------------------------------------------------------- special files

@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes on this platform")
def test_a_fifo_is_refused_without_opening_it(runner, tmp_path, box):
    fifo = tmp_path / "part.stl"
    os.mkfifo(fifo)                      # opening it would block until a writer came: the test would hang
    result = _props(runner, fifo, box, "--format", "csv")
    assert result.exit_code == 1
    _one_error_line(result, fifo, "named pipe (FIFO), not a regular file")
    assert result.stdout.splitlines()[1].startswith(box)


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero on this platform")
@pytest.mark.parametrize("name", ["zero.obj", "zero.stl", "zero.ply", "zero.vtu"])
def test_a_link_to_dev_zero_is_refused(runner, tmp_path, box, name):
    link = tmp_path / name
    os.symlink("/dev/zero", link)        # read, it never ends: memory would run out
    result = _props(runner, link, box)
    assert result.exit_code == 1
    _one_error_line(result, link, "character device (a link to /dev/zero)")
    assert "volume" in result.stdout


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes on this platform")
def test_files_a_gltf_names_are_checked_too(tmp_path):
    import json
    gltf = {"asset": {"version": "2.0"}, "buffers": [{"uri": "part.bin", "byteLength": 36}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}], "nodes": [{"mesh": 0}],
            "scenes": [{"nodes": [0]}], "scene": 0}
    (tmp_path / "part.gltf").write_text(json.dumps(gltf))
    os.mkfifo(tmp_path / "part.bin")                      # trimesh would block reading it
    with pytest.raises(MeshFormatError, match="buffer 'part.bin': is a named pipe"):
        massprops.mass_properties(tmp_path / "part.gltf")
    os.remove(tmp_path / "part.bin")
    (tmp_path / "part.bin").write_bytes(b"\0" * 12)
    with pytest.raises(MeshFormatError, match="buffer 'part.bin' holds 12 bytes, the glTF says 36"):
        massprops.mass_properties(tmp_path / "part.gltf")


@pytest.mark.skipif(not hasattr(socket, "AF_UNIX"), reason="no Unix sockets on this platform")
def test_a_socket_is_refused(tmp_path):
    path = tmp_path / "s.stl"
    server = socket.socket(socket.AF_UNIX)
    try:
        server.bind(str(path))
        assert stat.S_ISSOCK(os.stat(path).st_mode)
        with pytest.raises(MeshReadError, match="is a socket, not a regular file"):
            massprops.mass_properties(path)
    finally:
        server.close()


def test_a_dangling_link_and_a_directory(tmp_path):
    os.symlink(tmp_path / "gone.stl", tmp_path / "link.stl")
    with pytest.raises(MeshReadError, match="symbolic link to a missing file"):
        massprops.mass_properties(tmp_path / "link.stl")
    (tmp_path / "dir.stl").mkdir()
    with pytest.raises(MeshReadError, match="is a directory"):
        massprops.mass_properties(tmp_path / "dir.stl")


def test_a_sparse_text_file_is_refused_before_it_is_parsed(tmp_path):
    path = tmp_path / "sparse.obj"
    with open(path, "wb") as f:
        f.write(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
        f.truncate(1 << 30)              # a 1 GiB hole: NUL bytes no text mesh holds
    if os.stat(path).st_blocks * 512 >= os.stat(path).st_size or not hasattr(os, "SEEK_HOLE"):
        pytest.skip("this file system stores no holes")
    with pytest.raises(MeshFormatError, match="sparse"):
        massprops.mass_properties(path)


# ---------------------------------------------------------------- lying sizes and archives

def _zip_bomb(path, unpacked):
    """A 3MF-named zip whose one member inflates to ``unpacked`` bytes of spaces (about 1000:1)."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        with archive.open("3D/3dmodel.model", "w", force_zip64=True) as member:
            block = b" " * (1 << 20)
            for _ in range(unpacked >> 20):
                member.write(block)


def test_a_zip_bomb_is_refused_before_it_is_unpacked(runner, tmp_path, box):
    bomb = tmp_path / "bomb.3mf"
    _zip_bomb(bomb, 256 << 20)
    assert os.path.getsize(bomb) < 1 << 20
    result = _props(runner, bomb, box)
    assert result.exit_code == 1
    _one_error_line(result, bomb, "the archive unpacks to 268.4 MB")
    assert "--max-unpacked BYTES" in result.stderr          # the command line names the option
    with pytest.raises(MeshFormatError, match=r"max_unpacked=BYTES"):  # the library the keyword
        massprops.mass_properties(bomb)


def test_the_unpack_limit_can_be_raised(tmp_path):
    archive = tmp_path / "small.3mf"
    _zip_bomb(archive, 80 << 20)         # beyond the default floor (64 MiB) and 100x its size
    with pytest.raises(MeshFormatError, match="unpacks to"):
        massprops.mass_properties(archive)
    # raised: the bytes reach the 3MF reader, which finds no model in the spaces
    with pytest.raises(MeshFormatError) as raised:
        massprops.mass_properties(archive, max_unpacked=100 << 20)
    assert "unpacks to" not in str(raised.value)


def test_a_ply_header_claiming_more_than_the_file_holds(tmp_path):
    import trimesh
    mesh = trimesh.Trimesh(solids.box().vertices, solids.box().faces, process=False)
    for encoding in ("binary", "ascii"):
        path = tmp_path / f"{encoding}.ply"
        mesh.export(path, encoding=encoding)
        path.write_bytes(path.read_bytes().replace(b"element vertex 8", b"element vertex 800000000", 1))
        with pytest.raises(MeshFormatError, match="PLY header says 800000000 vertex elements"):
            massprops.mass_properties(path)


def test_instances_files_are_checked_like_meshes(runner, tmp_path, box):
    header = np.lib.format.header_data_from_array_1_0(np.zeros((1, 7)))
    header["shape"] = (10 ** 9, 7)       # 56 GB declared; numpy would allocate it before reading
    with open(tmp_path / "lie.npy", "wb") as f:
        np.lib.format.write_array_header_1_0(f, header)
        f.write(b"\0" * 56)
    links = {"lie.npy": "the .npy header says shape (1000000000, 7)"}
    if os.path.exists("/dev/zero"):
        os.symlink("/dev/zero", tmp_path / "zero.csv")
        links["zero.csv"] = "character device"
    for name, fragment in links.items():
        (tmp_path / "s.toml").write_text(f'[parts.a]\nmesh = "{box}"\ninstances = "{name}"\n')
        result = runner.invoke(main, ["scene", str(tmp_path / "s.toml")])
        assert result.exit_code == 1 and fragment in result.stderr and "Traceback" not in result.output


# ---------------------------------------------------------------- third-party readers

def _volume_meshes(folder):
    """Broken volume meshes on which meshio prints, then calls sys.exit(1) (or raises)."""
    import meshio
    tetra = meshio.Mesh(solids.tetrahedron().vertices, [("tetra", np.array([[0, 1, 2, 3]]))])
    meshio.write(folder / "whole.vtu", tetra)
    (folder / "cut.vtu").write_bytes((folder / "whole.vtu").read_bytes()[:300])
    (folder / "version.msh").write_text("$MeshFormat\n9.9 0 8\n$EndMeshFormat\n")
    (folder / "empty_block.inp").write_text("*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D4\n")
    return [folder / name for name in ("cut.vtu", "version.msh", "empty_block.inp")]


def test_readers_that_exit_or_print_give_one_line_and_the_rest_are_reported(runner, tmp_path, box):
    bad = _volume_meshes(tmp_path)
    result = _props(runner, *bad, box, "--format", "csv")
    assert result.exit_code == 1
    for path in bad:
        _one_error_line(result, path, "")
    lines = result.stdout.splitlines()
    assert lines[0].startswith("file,status,") and len(lines) == 2 and lines[1].startswith(box)
    assert "Couldn't read file" in result.stderr and "Error: Couldn't" not in result.stderr


def test_meshio_exit_is_a_mesh_format_error_in_the_library(tmp_path):
    cut, *_ = _volume_meshes(tmp_path)
    with pytest.raises(MeshFormatError, match="cannot parse the file .meshio"):
        massprops.mass_properties(cut)


def test_degenerate_volume_meshes(tmp_path):
    import meshio
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]] * 2, float)     # top face on the bottom one
    meshio.write(tmp_path / "flat.vtu", meshio.Mesh(square, [("hexahedron", np.arange(8)[None])]))
    with pytest.raises(MeshGeometryError, match="zero volume"):
        massprops.mass_properties(tmp_path / "flat.vtu")
    *_, empty = _volume_meshes(tmp_path)
    with pytest.raises(MeshFormatError, match="no volume cells and no surface cells"):
        massprops.mass_properties(empty)


def test_a_mesh_spanning_more_than_the_largest_double():
    vertices = [(-1e308, 0, 0), (1e308, 0, 0), (0, 1, 0), (0, 0, 1)]
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    with pytest.raises(MeshGeometryError, match="spans more than the largest double"):
        massprops.mass_properties((vertices, faces))


# ---------------------------------------------------------------- output

@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full on this platform")
def test_a_full_disk_is_one_line(tmp_path, box):
    import subprocess
    import sys
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "massprops", "props", box], stdout=full,
                              stderr=subprocess.PIPE, text=True, env=env)
    assert done.returncode == 1
    assert done.stderr.startswith("error: ") and "No space left on device" in done.stderr
    assert len(done.stderr.splitlines()) == 1                 # no traceback, nothing "ignored" at exit
    from massprops.batch.run import run_batch
    os.symlink("/dev/full", tmp_path / "report.csv")       # the state file goes beside it, in tmp_path
    with pytest.raises(OutputError, match="cannot write the report .No space left"):
        run_batch([box], output=str(tmp_path / "report.csv"), jobs=1)


def test_a_part_spanning_1e297_with_coordinates_below_its_resolution(tmp_path):
    # Found by the fuzz test: the bound on the snapped coordinates squared a move of ~1e237 (OverflowError).
    path = tmp_path / "huge.off"
    path.write_text("OFF\n4 4 0\n0 1e297 0\n2 0 0\n0 3 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    try:
        result = massprops.mass_properties(path)
    except massprops.MassPropsError:
        return                              # a one-line refusal is fine; any other exception is not
    assert result.properties.volume > 0


def test_a_zip_whose_directory_names_an_unknown_version(tmp_path):
    # Found by the fuzz test: zipfile raises NotImplementedError for a "version needed" it does not know.
    import trimesh
    path = tmp_path / "part.3mf"
    box = solids.box((1.0, 2.0, 3.0))
    trimesh.Trimesh(box.vertices, box.faces).export(path, file_type="3mf")
    data = bytearray(path.read_bytes())
    directory = data.index(b"PK\x01\x02")
    data[directory + 6:directory + 8] = (110).to_bytes(2, "little")        # version needed to extract: 11.0
    path.write_bytes(bytes(data))
    with pytest.raises(massprops.MassPropsError):
        massprops.mass_properties(path)
