"""`massprops batch`: one row per file, the same values as `props`, resume, process pool and Dask."""

from __future__ import annotations

import csv
import io
import json
import os
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings as hsettings, strategies as st

import massprops.cli
from massprops.batch import run as batch
from massprops.validation import solids
from massprops.io.stl import write_binary
from badfiles import make_bad_files
from oracle import exact_properties

# typed from the SPEC, not taken from the code under test
SPEC_HEADER = ("file,status,message,triangles,volume,mass,cx,cy,cz,Ixx,Iyy,Izz,Ixy,Ixz,Iyz,I1,I2,I3,"
               "a1x,a1y,a1z,a2x,a2y,a2z,a3x,a3y,a3z,err_volume,err_inertia,elapsed_s")


def _tilted(mesh, seed):
    """The mesh moved off the axes, so every product of inertia is non-zero (a sign error shows)."""
    from conftest import random_rotation
    return mesh.transformed(random_rotation(seed), np.array([0.5, -1.25, 2.0]))


def _trimesh(mesh):
    import trimesh
    return trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)


def _write_good_files(folder):
    """One closed solid per format; returns ``{path: mesh}``."""
    meshes = {
        "binary.stl": _tilted(solids.l_bracket(3.0, 1.0, 0.5), 1),
        "ascii.stl": _tilted(solids.tetrahedron(((0, 0, 0), (2, 0, 0), (0, 3, 0), (0, 0, 1))), 2),
        "part.obj": _tilted(solids.regular_prism(7, 1.5, 0.75), 3),
        "part.ply": _tilted(solids.box((1.0, 2.0, 3.0)), 4),
        "part.off": _tilted(solids.icosphere(1, 2.0), 5),
    }
    paths = {os.path.join(folder, name): mesh for name, mesh in meshes.items()}
    for path, mesh in paths.items():
        if path.endswith("binary.stl"):
            write_binary(path, mesh.triangles)
        else:
            kind = {"stl": "stl_ascii"}.get(path.rsplit(".", 1)[1], path.rsplit(".", 1)[1])
            _trimesh(mesh).export(path, file_type=kind)
    return paths


@pytest.fixture(scope="module")
def corpus(tmp_path_factory):
    """Good files of every format and the whole bad-input corpus: (good {path: mesh}, bad {path: fragment})."""
    root = tmp_path_factory.mktemp("corpus")
    os.mkdir(root / "good")
    os.mkdir(root / "bad")
    return _write_good_files(str(root / "good")), make_bad_files(root / "bad")


def _invoke(runner, *args):
    return runner.invoke(massprops.cli.main, ["batch", *map(str, args)])


def _read_report(path):
    with open(path, newline="", encoding="utf-8") as f:
        text = f.read()
    return text, list(csv.DictReader(io.StringIO(text)))


def _props_objects(runner, paths):
    result = runner.invoke(massprops.cli.main, ["props", "--format", "json", *paths])
    assert result.exit_code == 0, result.output
    return {o["file"]: o for o in json.loads(result.stdout)}


def test_mixed_corpus_every_file_a_row_good_match_props_bad_carry_message(runner, corpus, tmp_path):
    good, bad = corpus
    out = tmp_path / "report.csv"
    result = _invoke(runner, *good, *bad, "-o", out, "--jobs", "2")
    assert result.exit_code == 1, result.output
    assert f"{len(good)} ok, {len(bad)} failed" in result.stderr
    text, rows = _read_report(out)
    assert text.splitlines()[0] == SPEC_HEADER
    files = [r["file"] for r in rows]
    assert files == sorted(files) and set(files) == set(good) | set(bad)

    expected = _props_objects(runner, list(good))
    for row in (r for r in rows if r["file"] in good):
        obj = expected[row["file"]]
        assert row["status"] == "ok" and row["message"] == ""
        assert int(row["triangles"]) == obj["triangles"] == good[row["file"]].faces.shape[0]
        # every number round-trips: the CSV text parses back to props' float exactly
        assert float(row["volume"]) == obj["volume"] and float(row["mass"]) == obj["mass"]
        assert [float(row[c]) for c in ("cx", "cy", "cz")] == obj["center_of_mass"]
        j = obj["inertia_com"]
        assert [float(row[c]) for c in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")] == [
            j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]]
        assert [float(row[c]) for c in ("I1", "I2", "I3")] == obj["principal_moments"]
        assert [[float(row[f"a{k}{c}"]) for c in "xyz"] for k in (1, 2, 3)] == obj["principal_axes"]
        assert float(row["err_volume"]) == obj["error"]["volume"]
        assert float(row["err_inertia"]) == obj["error"]["inertia_com"]
        assert float(row["elapsed_s"]) > 0
    for row in (r for r in rows if r["file"] in bad):
        assert row["status"] == "error" and bad[row["file"]] in row["message"], row
        assert row["volume"] == "" and row["elapsed_s"] == ""


def test_rows_within_error_bounds_of_the_exact_values(runner, corpus, tmp_path):
    good, _ = corpus
    out = tmp_path / "report.csv"
    assert _invoke(runner, *good, "-o", out, "--jobs", "1").exit_code == 0
    for row in _read_report(out)[1]:
        # the coordinates as stored (float32 in binary STL, decimals in text formats), read by trimesh
        import trimesh
        exact = exact_properties(trimesh.load(row["file"], process=False).triangles)
        assert abs(Fraction(row["volume"]) - exact["volume"]) <= Fraction(row["err_volume"])
        inertia = exact["inertia_com"]
        for name, (i, k) in {"Ixx": (0, 0), "Iyy": (1, 1), "Izz": (2, 2), "Ixy": (0, 1), "Ixz": (0, 2),
                             "Iyz": (1, 2)}.items():
            assert inertia[i][k] != 0
            assert abs(Fraction(row[name]) - inertia[i][k]) <= Fraction(row["err_inertia"])


def test_jsonl_holds_the_props_objects(runner, corpus, tmp_path):
    good, bad = corpus
    out = tmp_path / "report.jsonl"
    open_mesh = next(p for p in bad if p.endswith("open.stl"))
    result = _invoke(runner, *good, open_mesh, "-o", out, "--format", "jsonl", "--density", "7850",
                     "--unit", "mm", "--rotate", "euler:xyz:10,20,30", "--translate", "1", "2", "3")
    assert result.exit_code == 1
    lines = [json.loads(line) for line in open(out, encoding="utf-8")]
    assert [o["file"] for o in lines] == sorted(list(good) + [open_mesh])
    expected_result = runner.invoke(massprops.cli.main, [
        "props", "--format", "json", "--density", "7850", "--unit", "mm", "--rotate", "euler:xyz:10,20,30",
        "--translate", "1", "2", "3", *good])
    expected = {o["file"]: o for o in json.loads(expected_result.stdout)}
    for obj in lines:
        if obj["file"] == open_mesh:
            assert obj["status"] == "error" and "open" in obj["message"]
            continue
        assert obj.pop("status") == "ok" and obj.pop("message") == ""
        want = expected[obj["file"]]
        assert obj.pop("elapsed_s") > 0 and want.pop("elapsed_s") > 0
        assert obj == want


def test_stdout_report_when_no_output_file(runner, corpus):
    good, _ = corpus
    result = _invoke(runner, *sorted(good)[:2], "--jobs", "1", "--quiet", "-o", "-")
    assert result.exit_code == 0 and result.stderr == ""
    lines = result.stdout.splitlines()
    assert lines[0] == SPEC_HEADER and [line.split(",")[0] for line in lines[1:]] == sorted(good)[:2]


def _count_runs(monkeypatch):
    """The files each run computes (their records as they arrive from the workers)."""
    from massprops.batch.output import ReportWriter
    computed = []
    real = ReportWriter.add

    def counting(self, outcome, *args, **kwargs):
        computed.append(outcome.file)
        return real(self, outcome, *args, **kwargs)

    monkeypatch.setattr(ReportWriter, "add", counting)
    return computed


def test_resume_after_interruption_recomputes_only_missing_and_changed(runner, tmp_path, monkeypatch):
    folder = tmp_path / "parts"
    folder.mkdir()
    for k in range(6):
        write_binary(folder / f"p{k}.stl", solids.box((1.0 + k, 2.0, 3.0)).triangles)
    files = batch.expand_inputs([str(folder)])
    out = str(tmp_path / "report.csv")

    # interrupt the first run after three files: their rows must already be on disk
    def interrupt_after_three(outcome, seen=[]):
        seen.append(outcome)
        if len(seen) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        batch.run_batch(files, output=out, jobs=1, on_outcome=interrupt_after_three)
    done = [r["file"] for r in _read_report(out)[1]]
    assert done == files[:3]
    first_lines = open(out, encoding="utf-8").read().splitlines()

    # change one finished file (new size of box: new volume), with a different mtime
    changed = files[1]
    write_binary(changed, solids.box((9.0, 2.0, 3.0)).triangles)
    os.utime(changed, ns=(os.stat(changed).st_atime_ns, os.stat(changed).st_mtime_ns + 10**9))

    computed = _count_runs(monkeypatch)
    result = _invoke(runner, folder, "-o", out, "--resume", "--jobs", "1")
    assert result.exit_code == 0, result.output
    assert sorted(computed) == sorted([changed, *files[3:]])
    assert "6 ok, 0 failed (2 unchanged, reused); 4 computed" in result.stderr
    text, rows = _read_report(out)
    assert [r["file"] for r in rows] == files
    untouched = [line for line in first_lines[1:] if not line.startswith(changed)]
    assert all(line in text.splitlines() for line in untouched)  # elapsed_s included: not recomputed
    assert [float(r["volume"]) for r in rows] == [6.0, 54.0, 18.0, 24.0, 30.0, 36.0]

    # a second resume computes nothing; other settings recompute everything
    computed.clear()
    assert _invoke(runner, folder, "-o", out, "--resume", "--jobs", "1").exit_code == 0
    assert computed == []
    result = _invoke(runner, folder, "-o", out, "--resume", "--jobs", "1", "--density", "2")
    assert sorted(computed) == files and "recomputing every file" in result.stderr
    assert all(float(r["mass"]) == 2 * float(r["volume"]) for r in _read_report(out)[1])


def test_resume_drops_a_half_written_last_row(tmp_path):
    paths = []
    for k in range(3):
        paths.append(str(tmp_path / f"t{k}.stl"))
        write_binary(paths[-1], _tilted(solids.tetrahedron(), k).triangles)
    out = str(tmp_path / "r.csv")
    batch.run_batch(paths, output=out, jobs=1, resume=True)      # a --resume run keeps its state file
    text = open(out, encoding="utf-8").read()
    with open(out, "w", encoding="utf-8") as f:
        f.write(text[:-20])  # the last row lost its tail mid-number
    summary = batch.run_batch(paths, output=out, jobs=1, resume=True)
    assert (summary.computed, summary.unchanged) == (1, 2)
    assert open(out, encoding="utf-8").read().splitlines()[:3] == text.splitlines()[:3]


def _without_elapsed(path):
    return [{k: v for k, v in row.items() if k != "elapsed_s"} for row in _read_report(path)[1]]


def test_local_dask_cluster_gives_the_process_pool_report(runner, corpus, tmp_path):
    good, bad = corpus
    pool, dask = tmp_path / "pool.csv", tmp_path / "dask.csv"
    assert _invoke(runner, *good, *bad, "-o", pool, "--jobs", "2").exit_code == 1
    result = _invoke(runner, *good, *bad, "-o", dask, "--scheduler", "local", "--jobs", "1")
    assert result.exit_code == 1, result.output
    assert _without_elapsed(dask) == _without_elapsed(pool)
    assert open(dask, encoding="utf-8").readline().rstrip("\n") == SPEC_HEADER


def test_a_crashed_worker_costs_only_its_file(tmp_path, monkeypatch):
    paths = [str(tmp_path / f"t{k}.stl") for k in range(6)]
    for k, path in enumerate(paths):
        write_binary(path, _tilted(solids.tetrahedron(), k).triangles)
    real = batch.run_one

    def die_on_the_third(path, *args, **kwargs):
        if path == paths[2]:
            os._exit(3)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(batch, "run_one", die_on_the_third)  # the forked workers inherit it
    out = str(tmp_path / "r.csv")
    summary = batch.run_batch(paths, output=out, jobs=2)
    assert (summary.ok, summary.failed) == (5, 1)
    rows = _read_report(out)[1]
    assert [r["file"] for r in rows] == paths
    assert [r["status"] for r in rows] == ["ok", "ok", "error", "ok", "ok", "ok"]
    assert "worker process died" in rows[2]["message"] and "exit status 3" in rows[2]["message"]


def test_expand_inputs_directories_globs_and_lists(tmp_path):
    (tmp_path / "sub" / "deeper").mkdir(parents=True)
    names = ["a.stl", "b.OBJ", "sub/c.ply", "sub/deeper/d.off", "notes.txt"]
    for name in names:
        (tmp_path / name).write_text("x")
    root = str(tmp_path)
    j = os.path.join
    assert batch.expand_inputs([root]) == [j(root, "a.stl"), j(root, "b.OBJ")]
    assert batch.expand_inputs([root], recursive=True) == [
        j(root, "a.stl"), j(root, "b.OBJ"), j(root, "sub", "c.ply"), j(root, "sub", "deeper", "d.off")]
    assert batch.expand_inputs([j(root, "**", "*.off")], recursive=True) == [j(root, "sub", "deeper", "d.off")]
    assert batch.expand_inputs([j(root, "*.stl"), j(root, "a.stl"), j(root, "none*.stl")]) == [
        j(root, "a.stl"), j(root, "none*.stl")]  # once each; an unmatched pattern stays, to be reported
    (tmp_path / "list.txt").write_text("# parts\na.stl\n\nsub/c.ply\n" + j(root, "sub", "deeper", "d.off") + "\n")
    assert batch.expand_inputs(["@" + j(root, "list.txt")]) == [
        j(root, "a.stl"), j(root, "sub", "c.ply"), j(root, "sub", "deeper", "d.off")]


def test_usage_and_option_errors(runner, corpus, tmp_path, monkeypatch):
    good, _ = corpus
    some = sorted(good)[0]
    result = _invoke(runner, some, "--resume")
    assert result.exit_code == 2 and "-o" in result.stderr
    result = _invoke(runner, "@" + str(tmp_path / "missing.txt"), "-o", tmp_path / "r.csv")
    assert result.exit_code == 2 and "cannot read the list" in result.stderr
    result = _invoke(runner, some, "-o", tmp_path / "r.csv", "--density", "-1")
    assert result.exit_code == 2 and "--density" in result.stderr and "Traceback" not in result.output
    assert not (tmp_path / "r.csv").exists()
    result = _invoke(runner, some, "-o", tmp_path / "no_such_folder" / "r.csv")
    assert result.exit_code == 1 and "cannot write the report" in result.stderr
    monkeypatch.setitem(__import__("sys").modules, "dask.distributed", None)
    result = _invoke(runner, some, "-o", tmp_path / "r.csv", "--scheduler", "local")
    assert result.exit_code == 1 and 'pip install "massprops[dask]"' in result.stderr


@hsettings(max_examples=60, deadline=None)
@given(st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=40))
def test_error_messages_are_one_csv_line_that_reads_back(text):
    from massprops.model.errors import MeshFormatError
    message = batch.error_message(MeshFormatError("bad " + text, fix="fix, \"it\"\n now"))
    line = batch.record({"file": "a,b.stl"}, "error", message, "csv")
    assert line.endswith("\n") and len(line.splitlines()) == 1
    row = next(csv.DictReader([SPEC_HEADER + "\n", line]))
    assert (row["file"], row["status"], row["message"]) == ("a,b.stl", "error", message)
    assert message.endswith('— fix, "it" now')


def test_volume_and_shell_options_reach_every_file(runner, tmp_path):
    """--density-field for volume meshes and --shell for open surfaces, as in props."""
    import meshio

    from massprops.validation import solids

    points = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1, 2)], float)
    cells = [[i, i + 1, i + 4, i + 3, i + 6, i + 7, i + 10, i + 9] for i in (0, 1)]
    meshio.write(tmp_path / "bar.vtu", meshio.Mesh(points, [("hexahedron", np.array(cells))],
                                                   cell_data={"rho": [np.array([7850.0, 2700.0])]}))
    out = tmp_path / "bars.csv"
    assert _invoke(runner, tmp_path / "bar.vtu", "-o", out, "--density-field", "rho").exit_code == 0
    [row] = _read_report(out)[1]
    assert float(row["mass"]) == 10550.0
    assert float(row["cx"]) == pytest.approx((7850 * 0.5 + 2700 * 1.5) / 10550, rel=1e-15)

    box = solids.box((2.0, 1.0, 1.0), (1.0, 0.5, 0.5))
    open_faces = box.faces[[not np.all(box.vertices[f][:, 2] == 1.0) for f in box.faces]]
    from massprops.io.stl import write_binary
    write_binary(tmp_path / "tray.stl", box.vertices[open_faces])
    out = tmp_path / "trays.csv"
    assert _invoke(runner, tmp_path / "tray.stl", "-o", out).exit_code == 1
    assert _invoke(runner, tmp_path / "tray.stl", "-o", out, "--shell", "0.5").exit_code == 0
    [row] = _read_report(out)[1]
    assert float(row["mass"]) == pytest.approx(0.5 * (2 + 2 * 2 + 2 * 1), rel=1e-15)   # t · area of the open box
