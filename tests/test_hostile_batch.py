"""Batch faults: dead and stuck workers, orphans, resume, names of any bytes, one row per file."""

from __future__ import annotations

import csv
import io
import json
import os
import signal
import subprocess
import sys
import time

import pytest

import massprops.cli
from massprops.batch import run as batch
from massprops.io.stl import write_binary
from massprops.validation import solids

WEIRD_NAMES = [b"a,b.stl", b'say "x".stl', b"cr\rname.stl", b"lf\nname.stl", b"latin1-\xe9\xff.stl",
               b" spaced .stl", b"plain.stl"]


def _parts(folder, count):
    paths = []
    for k in range(count):
        paths.append(str(folder / f"p{k:02d}.stl"))
        write_binary(paths[-1], solids.box((1.0 + k, 2.0, 3.0)).triangles)
    return paths


def _rows(path):
    with open(path, newline="", encoding="utf-8", errors="surrogateescape") as f:
        return list(csv.DictReader(f))


def _state(path):
    with open(batch.state_path(path), encoding="utf-8") as f:
        return [json.loads(line) for line in f.read().splitlines()[1:]]


# ---------------------------------------------------------------- dead and stuck workers

def test_a_killed_worker_costs_its_file_and_resume_recomputes_it(tmp_path, monkeypatch):
    paths = _parts(tmp_path, 8)
    victim = paths[3]
    real = batch.run_one

    def killed_on_the_victim(path, *args, **kwargs):
        if path == victim:
            os.kill(os.getpid(), signal.SIGKILL)       # as the out-of-memory killer would
        return real(path, *args, **kwargs)

    monkeypatch.setattr(batch, "run_one", killed_on_the_victim)     # the forked workers inherit it
    out = str(tmp_path / "r.csv")
    summary = batch.run_batch(paths, output=out, jobs=2)
    rows = _rows(out)
    assert [r["file"] for r in rows] == paths                       # every file once, sorted
    assert [r["file"] for r in rows if r["status"] != "ok"] == [victim] and summary.failed == 1
    assert "died computing this file, each time it was tried (killed by SIGKILL)" in rows[3]["message"]
    assert "resume=True" in rows[3]["message"]                      # a library call: keyword spelling

    monkeypatch.setattr(batch, "run_one", real)
    summary = batch.run_batch(paths, output=out, jobs=2, resume=True)
    assert (summary.computed, summary.unchanged, summary.failed) == (1, 7, 0)
    rows = _rows(out)
    assert [r["file"] for r in rows] == paths and all(r["status"] == "ok" for r in rows)
    assert sorted(entry["file"] for entry in _state(out)) == paths   # one state entry each, none stale


def test_a_worker_that_dies_once_is_replaced_and_its_file_retried(tmp_path, monkeypatch):
    paths = _parts(tmp_path, 4)
    marker = tmp_path / "died-once"
    real = batch.run_one

    def dies_the_first_time(path, *args, **kwargs):
        if path == paths[0] and not marker.exists():
            marker.touch()
            os._exit(9)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(batch, "run_one", dies_the_first_time)
    summary = batch.run_batch(paths, output=str(tmp_path / "r.csv"), jobs=2)
    assert marker.exists() and (summary.ok, summary.failed) == (4, 0)
    assert [r["file"] for r in _rows(tmp_path / "r.csv")] == paths


def test_a_stuck_file_times_out_alone(runner, tmp_path, monkeypatch):
    paths = _parts(tmp_path, 5)
    stuck = paths[1]
    real = batch.run_one

    def hangs_on_one(path, *args, **kwargs):
        if path == stuck:
            time.sleep(60)                    # without the time limit the test fails, after a minute
        return real(path, *args, **kwargs)

    monkeypatch.setattr(batch, "run_one", hangs_on_one)
    out = tmp_path / "r.csv"
    result = runner.invoke(massprops.cli.main, ["batch", *paths, "-o", str(out), "--timeout", "3", "-j", "2"])
    assert result.exit_code == 1 and "Traceback" not in result.output
    rows = _rows(out)
    assert [r["status"] for r in rows] == ["ok", "error", "ok", "ok", "ok"]
    assert rows[1]["message"].startswith("timed out after 3 s") and "--timeout SECONDS" in rows[1]["message"]
    monkeypatch.setattr(batch, "run_one", real)
    result = runner.invoke(massprops.cli.main, ["batch", *paths, "-o", str(out), "--resume"])
    assert result.exit_code == 0 and "5 ok, 0 failed (4 unchanged, reused); 1 computed" in result.stderr


_PARENT = """
import os, sys, time
from massprops.batch import run as batch
folder = sys.argv[1]

def hang(path, *args, **kwargs):
    open(os.path.join(folder, f"worker-{os.getpid()}"), "w").close()
    time.sleep(3600)

batch.run_one = hang
batch.run_batch(sys.argv[2:], output=os.path.join(folder, "r.csv"), jobs=2)
"""


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="no SIGKILL on this platform")
def test_workers_die_with_their_parent(tmp_path):
    paths = _parts(tmp_path, 4)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    parent = subprocess.Popen([sys.executable, "-c", _PARENT, str(tmp_path), *paths], env=env)
    try:
        for _ in range(600):                            # until both workers hold a file
            workers = [int(name.split("-")[1]) for name in os.listdir(tmp_path) if name.startswith("worker-")]
            if len(workers) == 2 or parent.poll() is not None:
                break
            time.sleep(0.1)
        assert len(workers) == 2, "the workers never started"
        parent.kill()                                   # kill -9: no chance to clean up
        parent.wait()
        for _ in range(300):
            alive = [pid for pid in workers if _alive(pid)]
            if not alive:
                break
            time.sleep(0.1)
        assert not alive, f"orphaned workers {alive}"
    finally:
        parent.kill()
        for pid in workers if "workers" in dir() else []:
            if _alive(pid):
                os.kill(pid, signal.SIGKILL)


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] != "Z"       # a zombie has exited
    except FileNotFoundError:
        return False
    except OSError:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True


def test_no_traceback_at_exit(tmp_path):
    paths = _parts(tmp_path, 12)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    done = subprocess.run([sys.executable, "-m", "massprops", "batch", *paths, "-o", str(tmp_path / "r.csv"),
                           "-j", "2"], env=env, capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout == ""
    assert done.stderr.splitlines()[-1].startswith("12 ok, 0 failed") and len(done.stderr.splitlines()) == 1


# ---------------------------------------------------------------- names

@pytest.fixture
def weird(tmp_path):
    folder = os.fsencode(tmp_path / "weird")
    os.mkdir(folder)
    for name in WEIRD_NAMES:
        write_binary(os.path.join(folder, name), solids.box().triangles)
    return os.fsdecode(folder)


@pytest.mark.skipif(sys.platform == "win32", reason="these names are not allowed on Windows")
def test_names_of_any_bytes_round_trip_through_csv_and_json(runner, weird, tmp_path):
    expected = sorted(os.fsdecode(os.path.join(os.fsencode(weird), name)) for name in WEIRD_NAMES)
    out = tmp_path / "r.csv"
    result = runner.invoke(massprops.cli.main, ["batch", weird, "-o", str(out), "--resume"])   # keeps its state
    assert result.exit_code == 0, result.output
    rows = _rows(out)
    assert [r["file"] for r in rows] == expected and all(os.path.isfile(r["file"]) for r in rows)
    result = runner.invoke(massprops.cli.main, ["batch", weird, "-o", str(out), "--resume"])
    assert "7 unchanged" in result.stderr and [r["file"] for r in _rows(out)] == expected
    jsonl = tmp_path / "r.jsonl"
    assert runner.invoke(massprops.cli.main, ["batch", weird, "-o", str(jsonl), "--format", "jsonl"]).exit_code == 0
    text = jsonl.read_text(encoding="ascii")                      # surrogates as \\udcXX escapes: ASCII JSON
    assert [json.loads(line)["file"] for line in text.splitlines()] == expected
    stdout = runner.invoke(massprops.cli.main, ["batch", weird, "-q"]).stdout_bytes
    back = list(csv.DictReader(io.StringIO(stdout.decode("utf-8", "surrogateescape"), newline="")))
    assert [r["file"] for r in back] == expected
    props = runner.invoke(massprops.cli.main, ["props", *expected])
    assert props.exit_code == 0 and os.fsencode(expected[0]) in props.stdout_bytes


def test_a_list_file_in_any_encoding(runner, weird, tmp_path):
    listing = os.path.join(weird, "list.txt")
    with open(listing, "wb") as f:
        f.write(b"# parts\r\nlatin1-\xe9\xff.stl\r\n./plain.stl\n\n")
    files = batch.expand_inputs(["@" + listing])
    assert [os.fsencode(os.path.basename(f)) for f in files] == [b"latin1-\xe9\xff.stl", b"plain.stl"]
    result = runner.invoke(massprops.cli.main, ["batch", "@" + listing, "-q"])
    assert result.exit_code == 0 and len(result.stdout_bytes.splitlines()) == 3


def test_one_file_under_several_spellings_is_one_row(runner, tmp_path):
    (tmp_path / "sub").mkdir()
    [part] = _parts(tmp_path, 1)
    os.symlink(part, tmp_path / "link.stl")
    os.link(part, tmp_path / "hard.stl")
    spellings = [part, os.path.join(str(tmp_path), ".", "p00.stl"), os.path.join(str(tmp_path), "sub", "..", "p00.stl"),
                 str(tmp_path / "link.stl"), str(tmp_path / "hard.stl"), os.path.relpath(part)]
    duplicates = []
    assert batch.expand_inputs(spellings, duplicates=duplicates) == [part]
    assert len(duplicates) == 3 and all(kept == part for _, kept in duplicates)
    result = runner.invoke(massprops.cli.main, ["batch", *spellings, "-o", str(tmp_path / "r.csv")])
    assert [r["file"] for r in _rows(tmp_path / "r.csv")] == [part]
    assert "1 ok, 0 failed" in result.stderr and "3 name(s) of files already listed" in result.stderr


# ---------------------------------------------------------------- Dask

def test_dask_a_reader_that_exits_fails_only_its_file(runner, tmp_path):
    pytest.importorskip("dask.distributed")
    paths = _parts(tmp_path, 3)
    (tmp_path / "bad.msh").write_text("$MeshFormat\n9.9 0 8\n$EndMeshFormat\n")      # meshio exits on it
    out = tmp_path / "r.csv"
    result = runner.invoke(massprops.cli.main, ["batch", *paths, str(tmp_path / "bad.msh"), "-o", str(out),
                                                "--scheduler", "local", "-j", "1"])
    assert result.exit_code == 1, result.output
    assert [(os.path.basename(r["file"]), r["status"]) for r in _rows(out)] == [
        ("bad.msh", "error"), ("p00.stl", "ok"), ("p01.stl", "ok"), ("p02.stl", "ok")]


def test_dask_a_chunk_whose_worker_dies_is_retried_file_by_file(tmp_path, monkeypatch):
    distributed = pytest.importorskip("dask.distributed")
    paths = _parts(tmp_path, 6)
    poison = paths[2]
    real = batch.run_chunk

    def dies_with_the_poison(chunk, *args, **kwargs):
        if poison in chunk:
            raise RuntimeError("worker lost (as Dask says after a worker dies)")
        return real(chunk, *args, **kwargs)

    monkeypatch.setattr(batch, "run_chunk", dies_with_the_poison)
    monkeypatch.setattr(batch, "_chunks", lambda files, workers: [tuple(files[i:i + 3]) for i in (0, 3)])
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        summary = batch.run_batch(paths, output=str(tmp_path / "r.csv"), client=client)
    rows = _rows(tmp_path / "r.csv")
    assert [r["file"] for r in rows] == paths and summary.failed == 1
    assert [r["status"] for r in rows] == ["ok", "ok", "error", "ok", "ok", "ok"]
    assert "worker lost" in rows[2]["message"]
