"""Mutated bytes of every format: ``mass_properties`` gives a result or a MassPropsError, nothing else.

Format-generic: each seed file is written by an exporter and read back through
whatever reader is registered for its extension, so the test exercises the
readers of the day (numpy, C, trimesh, meshio).  A few hundred examples in all
(``FUZZ_N=2000`` per format for a longer hunt); a reader that hangs or allocates
without bound would stall the run.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import massprops
from massprops.model.errors import MassPropsError
from massprops.io.stl import write_binary
from massprops.validation import solids

_TETRA = solids.tetrahedron(((0, 0, 0), (2, 0, 0), (0, 3, 0), (0, 0, 1)))


def _seeds(folder):
    """One small valid file per format and encoding: ``{name: bytes}``."""
    import meshio
    import trimesh

    mesh = trimesh.Trimesh(_TETRA.vertices, _TETRA.faces, process=False)
    write_binary(folder / "binary.stl", _TETRA.triangles)
    mesh.export(folder / "ascii.stl", file_type="stl_ascii")
    for name, kind, extra in (("part.obj", "obj", {}), ("binary.ply", "ply", {}),
                              ("ascii.ply", "ply", {"encoding": "ascii"}), ("part.off", "off", {}),
                              ("part.glb", "glb", {}), ("part.3mf", "3mf", {}), ("part.dae", "dae", {})):
        mesh.export(folder / name, file_type=kind, **extra)
    tetra = meshio.Mesh(_TETRA.vertices, [("tetra", np.array([[0, 1, 2, 3]]))])
    meshio.write(folder / "part.vtu", tetra)
    meshio.write(folder / "part.msh", tetra, file_format="gmsh22", binary=False)
    return {path.name: path.read_bytes() for path in sorted(folder.iterdir())}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    return _seeds(tmp_path_factory.mktemp("seeds"))


_SPECIAL = st.sampled_from([b"\x00", b"\xff", b"-", b"9", b"99999999999", b"nan", b"1e308", b" ", b"\n", b"/",
                            b"\x00\x00\x00\x80", b"\xff\xff\xff\x7f", b"<", b">", b"\"", b"e"])


@st.composite
def mutated(draw, data):
    """``data`` with a few edits: bytes overwritten, inserted, deleted, a range repeated, or cut short."""
    data = bytearray(data)
    for _ in range(draw(st.integers(1, 4))):
        where = draw(st.integers(0, max(0, len(data) - 1)))
        edit = draw(st.sampled_from(["set", "insert", "delete", "repeat", "truncate"]))
        chunk = draw(st.one_of(_SPECIAL, st.binary(min_size=1, max_size=8)))
        if edit == "set":
            data[where:where + len(chunk)] = chunk
        elif edit == "insert":
            data[where:where] = chunk
        elif edit == "delete":
            del data[where:where + draw(st.integers(1, 64))]
        elif edit == "repeat":
            span = data[where:where + draw(st.integers(1, 64))]
            data[where:where] = span * draw(st.integers(1, 4))
        else:
            del data[where:]
    return bytes(data)


@pytest.mark.parametrize("name", ["binary.stl", "ascii.stl", "part.obj", "binary.ply", "ascii.ply", "part.off",
                                  "part.glb", "part.3mf", "part.dae", "part.vtu", "part.msh"])
def test_mutated_files_give_a_result_or_a_massprops_error(seeds, tmp_path, name):
    @settings(max_examples=int(os.environ.get("FUZZ_N", "30")), deadline=None, database=None,
              suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
    @given(data=st.data())
    def check(data):
        path = tmp_path / name
        path.write_bytes(data.draw(mutated(seeds[name]), label="bytes"))
        try:
            result = massprops.mass_properties(path)
        except MassPropsError as exc:
            assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        else:
            assert np.isfinite(result.properties.volume) and result.properties.volume > 0

    check()


def test_the_seeds_themselves_are_read(seeds, tmp_path):
    for name, data in seeds.items():
        (tmp_path / name).write_bytes(data)
        # A 3MF declares its length unit (millimetres unless it says otherwise): its results are SI.
        expected = 1e-9 if name.endswith(".3mf") else 1.0
        assert massprops.mass_properties(tmp_path / name).properties.volume == pytest.approx(expected, rel=1e-6), name
