"""One option language: every command × every --format it accepts, --only on every command, conflicts exit 2.

Each output is parsed as the format it claims (JSON, JSON Lines, CSV with one
width, JUnit XML, text that is not JSON); --only is checked by what is
printed and what is not; the values are checked against the 1 × 2 × 3 box's
closed forms (mass 6, principal moments 2.5, 5, 6.5) where a box is read.
"""

import csv
import io
import json
import os
import re
import xml.etree.ElementTree as ET

import pytest

from massprops.cli import main
from massprops.io.stl import write_binary
from massprops.validation import solids

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROBOT = os.path.join(ROOT, "sample_meshes", "robot", "massprops_robot", "urdf", "robot.urdf")
SCENE = os.path.join(ROOT, "sample_meshes", "scene", "flange.toml")


@pytest.fixture
def parts(tmp_path):
    """A folder with the 1 × 2 × 3 box and a 1 × 1 × 1 cube (mass 6 and 1 at density 1)."""
    folder = tmp_path / "parts"
    folder.mkdir()
    write_binary(folder / "box.stl", solids.box((1.0, 2.0, 3.0)).triangles)
    write_binary(folder / "cube.stl", solids.box((1.0, 1.0, 1.0)).triangles)
    return folder


def invoke(runner, *args):
    result = runner.invoke(main, [str(a) for a in args])
    return result


def parsed(text, output_format):
    """The output parsed as ``output_format``; fails the test if it is not that."""
    if output_format == "json":
        return json.loads(text)
    if output_format == "jsonl":
        lines = text.splitlines()
        assert lines and all(line.strip() for line in lines)
        return [json.loads(line) for line in lines]
    if output_format == "csv":
        rows = list(csv.reader(io.StringIO(text)))
        assert len(rows) >= 2 and len({len(r) for r in rows}) == 1, text[:500]
        return [dict(zip(rows[0], r)) for r in rows[1:]]
    if output_format == "junit":
        root = ET.fromstring(text)
        assert root.tag in ("testsuites", "testsuite")
        return root
    assert text.strip()
    with pytest.raises(ValueError):
        json.loads(text)
    return text


# (command arguments given a box file or the parts folder, formats it accepts)
def _commands(box, folder, tmp_path):
    return {
        "props": (["props", box], ("text", "json", "jsonl", "csv")),
        "scene": (["scene", SCENE], ("text", "json", "jsonl", "csv")),
        "batch": (["batch", folder, "-j", "1"], ("csv", "jsonl", "json", "text")),
        "robot props": (["robot", "props", ROBOT], ("text", "json", "jsonl", "csv")),
        "robot check": (["robot", "check", ROBOT], ("text", "json", "jsonl", "csv", "junit")),
        "spin": (["spin", box, "--omega", "0.2,1,0.1", "--duration", "1", "--samples", "5"],
                 ("text", "json", "jsonl", "csv")),
    }


MATRIX = [(name, fmt) for name, formats in (
    ("props", ("text", "json", "jsonl", "csv")), ("scene", ("text", "json", "jsonl", "csv")),
    ("batch", ("csv", "jsonl", "json", "text")), ("robot props", ("text", "json", "jsonl", "csv")),
    ("robot check", ("text", "json", "jsonl", "csv", "junit")), ("spin", ("text", "json", "jsonl", "csv")))
    for fmt in formats]


@pytest.mark.parametrize("name,output_format", MATRIX)
def test_every_command_prints_parseable_output_of_each_format(runner, parts, tmp_path, name, output_format):
    args, formats = _commands(parts / "box.stl", parts, tmp_path)[name]
    assert output_format in formats
    result = invoke(runner, *args, "--format", output_format)
    assert result.exit_code in (0, 1), result.output          # robot check: the sample robot has a mismatch
    parsed(result.stdout, output_format)


def test_help_lists_exactly_the_formats_each_command_accepts(runner, parts, tmp_path):
    for name, (args, formats) in _commands(parts / "box.stl", parts, tmp_path).items():
        text = invoke(runner, *args[:2 if name.startswith("robot") else 1], "--help").output
        assert f"[{'|'.join(formats)}]" in text.replace("\n", "").replace(" ", ""), name


def test_batch_json_and_text_hold_every_file(runner, parts):
    result = invoke(runner, "batch", parts, "-j", "1", "--format", "json")
    assert result.exit_code == 0, result.output
    objects = parsed(result.stdout, "json")
    assert [os.path.basename(o["file"]) for o in objects] == ["box.stl", "cube.stl"]
    assert [o["status"] for o in objects] == ["ok", "ok"]
    assert [o["mass"] for o in objects] == pytest.approx([6.0, 1.0], rel=1e-14)
    text = invoke(runner, "batch", parts, "-j", "1", "--format", "text").stdout
    blocks = text.split("\n\n")
    assert blocks[0].startswith(str(parts / "box.stl")) and blocks[1].startswith(str(parts / "cube.stl"))
    assert "principal moments" in blocks[0] and "2.5" in blocks[0]
    assert text.rstrip().endswith("2 files: 2 ok, 0 failed")


def test_batch_text_names_a_failed_file_and_counts_it(runner, parts):
    (parts / "broken.stl").write_bytes(b"solid x\nendsolid x\n")
    result = invoke(runner, "batch", parts, "-j", "1", "--format", "text")
    assert result.exit_code == 1
    assert f"error: {parts / 'broken.stl'}: " in result.stdout
    assert result.stdout.rstrip().endswith("3 files: 2 ok, 1 failed")


@pytest.mark.parametrize("output_format", ["json", "text"])
def test_batch_json_and_text_reports_resume_from_the_state_file(runner, parts, tmp_path, output_format):
    report = tmp_path / f"report.{output_format}"
    first = invoke(runner, "batch", parts, "-j", "1", "--format", output_format, "-o", report, "--resume")
    assert first.exit_code == 0, first.output
    written = report.read_text(encoding="utf-8")
    parsed(written, output_format)
    assert os.path.exists(f"{report}.state.jsonl")
    again = invoke(runner, "batch", parts, "-j", "1", "--format", output_format, "-o", report, "--resume")
    assert again.exit_code == 0, again.output
    assert "(2 unchanged, reused); 0 computed" in again.stderr
    write_binary(parts / "cube.stl", solids.box((1.0, 1.0, 2.0)).triangles)      # changed: computed again
    third = invoke(runner, "batch", parts, "-j", "1", "--format", output_format, "-o", report, "--resume")
    assert "(1 unchanged, reused); 1 computed" in third.stderr
    if output_format == "json":
        assert [o["mass"] for o in parsed(report.read_text(encoding="utf-8"), "json")] == pytest.approx([6.0, 2.0])


def test_batch_output_file_follows_format_and_a_complete_run_leaves_no_state(runner, parts, tmp_path):
    report = tmp_path / "report.csv"                 # named .csv, written as --format says
    result = invoke(runner, "batch", parts, "-j", "1", "--format", "json", "-o", report)
    assert result.exit_code == 0, result.output
    assert result.stdout == ""
    assert len(parsed(report.read_text(encoding="utf-8"), "json")) == 2
    assert not os.path.exists(f"{report}.state.jsonl")


QUANTITY_KEYS = {"mass": "mass", "inertia": "inertia_com", "principal": "principal_moments",
                 "center_of_mass": "center_of_mass"}


def _links(objects):
    return [link for obj in objects for link in obj["links"] if link["status"] == "ok"]


@pytest.mark.parametrize("only", ["mass", "inertia", "principal,center_of_mass"])
def test_only_restricts_what_every_command_prints(runner, parts, tmp_path, only):
    asked = set(only.split(","))
    shown = {QUANTITY_KEYS[q] for q in asked}
    hidden = {key for q, key in QUANTITY_KEYS.items() if q not in asked
              and not (key == "center_of_mass" and asked & {"inertia", "principal"})}   # the COM they are about
    box = parts / "box.stl"

    def check(obj):
        assert shown <= set(obj), (only, sorted(obj))
        assert not hidden & set(obj), (only, sorted(obj))

    for obj in parsed(invoke(runner, "props", box, "--only", only, "--format", "json").stdout, "json"):
        check(obj)
    for obj in parsed(invoke(runner, "batch", parts, "-j", "1", "--only", only, "--format", "json").stdout, "json"):
        check(obj)
    check(parsed(invoke(runner, "scene", SCENE, "--only", only, "--format", "json").stdout, "json")["total"])
    for command in ("props", "check"):
        links = _links(parsed(invoke(runner, "robot", command, ROBOT, "--only", only, "--format", "json").stdout,
                              "json"))
        assert links
        for link in links:
            check(link)


def test_only_in_text_and_csv(runner, parts, tmp_path):
    box = parts / "box.stl"
    text = invoke(runner, "props", box, "--only", "mass").stdout
    assert "mass" in text and "inertia about COM" not in text and "principal moments" not in text
    text = invoke(runner, "batch", parts, "-j", "1", "--only", "mass", "--format", "text").stdout
    assert "mass" in text and "inertia about COM" not in text
    rows = parsed(invoke(runner, "robot", "props", ROBOT, "--only", "mass", "--format", "csv").stdout, "csv")
    ok = [r for r in rows if r["status"] == "ok"]
    assert ok and all(r["mass"] and not r["Ixx"] and not r["I1"] and not r["cx"] for r in ok)
    full = parsed(invoke(runner, "robot", "props", ROBOT, "--format", "csv").stdout, "csv")
    assert all(r["Ixx"] and r["I1"] for r in full if r["status"] == "ok")
    for command in ("props", "check"):                        # the link's row: its vectors only when asked
        some = _row(invoke(runner, "robot", command, ROBOT, "--only", "mass").stdout, "base_link")
        full = _row(invoke(runner, "robot", command, ROBOT).stdout, "base_link")
        assert "[" in full and "[" not in some and "12" in some


def _row(text, link):
    return next(line for line in text.splitlines() if line.startswith(f"  {link} "))


def test_view_only_restricts_the_side_panel(runner, parts, tmp_path):
    pytest.importorskip("plotly")
    full, some = tmp_path / "full.html", tmp_path / "some.html"
    assert invoke(runner, "view", parts / "box.stl", "-o", full).exit_code == 0
    assert invoke(runner, "view", parts / "box.stl", "-o", some, "--only", "mass").exit_code == 0
    full_page, some_page = full.read_text(encoding="utf-8"), some.read_text(encoding="utf-8")
    assert "inertia about COM" in full_page and "inertia about COM" not in some_page
    assert "about global origin" in full_page and "about global origin" not in some_page
    panel = re.compile(r"<pre>.*?</pre>", re.S)                 # the drawing is the same, the panel shorter
    assert panel.sub("", full_page) == panel.sub("", some_page)
    assert len(panel.findall(some_page)) == 1


def test_spin_json_and_csv_hold_the_run(runner, parts):
    args = ["spin", parts / "box.stl", "--omega", "0.2", "1", "0.1", "--duration", "2", "--samples", "5"]
    obj = parsed(invoke(runner, *args, "--format", "json").stdout, "json")
    assert obj["principal_moments"] == pytest.approx([2.5, 5.0, 6.5], rel=1e-14)
    assert obj["density"] == 1.0 and obj["method"] == "split6"
    assert obj["omega_error"] < 1e-8 and obj["momentum_drift"] < 1e-12
    assert [s["t"] for s in obj["trajectory"]] == pytest.approx([0, 0.5, 1, 1.5, 2], rel=1e-15)
    rows = parsed(invoke(runner, *args, "--format", "csv").stdout, "csv")
    lines = parsed(invoke(runner, *args, "--format", "jsonl").stdout, "jsonl")
    assert len(rows) == len(lines) == 5
    for row, line, sample in zip(rows, lines, obj["trajectory"]):
        assert {k: float(v) for k, v in row.items()} == line == sample
    # H = J ω: the box's body-axes momentum at t = 0
    assert [lines[0]["Hx"], lines[0]["Hy"], lines[0]["Hz"]] == pytest.approx([6.5 * 0.2, 5.0, 2.5 * 0.1])
    result = invoke(runner, *args, "--format", "csv")
    assert "principal moments" in result.stderr and "principal moments" not in result.stdout


def test_spin_compare_methods_in_every_format(runner, parts):
    args = ["spin", parts / "box.stl", "--omega", "0.2", "1", "0.1", "--duration", "1", "--compare-methods",
            "--samples", "3"]
    rows = parsed(invoke(runner, *args, "--format", "csv").stdout, "csv")
    obj = parsed(invoke(runner, *args, "--format", "json").stdout, "json")
    assert len(rows) == len(obj["work_precision"]) >= 4
    assert {r["method"] for r in rows} == {r["method"] for r in obj["work_precision"]}
    assert all(float(r["omega_error"]) < 1e-2 for r in rows)


@pytest.mark.parametrize("args", [
    ["batch", "missing-dir", "--format", "text", "--density", "2", "--mass", "1"],
    ["batch", "missing-dir", "--format", "json", "--resume"],
    ["batch", "missing-dir", "--format", "yaml"],
    ["batch", "missing-dir", "--only", "colour"],
    ["view", "missing.stl", "-o", "out.html", "--only", "colour"],
    ["view", "missing.stl", "-o", "out.html", "--only", "mass", "--density", "2", "--mass", "1"],
    ["spin", "missing.stl", "--omega", "1,2,3", "--duration", "1", "--format", "junit"],
    ["spin", "missing.stl", "--omega", "1,2,3", "--duration", "1", "--format", "csv", "--compare-methods",
     "--torque", "1,0,0"],
    ["robot", "props", "missing.urdf", "--only", "colour", "--format", "csv"],
    ["robot", "check", "missing.urdf", "--only", "mass", "--declared-only", "--density", "5"],
    ["props", "missing.stl", "--format", "json", "--digits", "3"],
])
def test_option_conflicts_are_usage_errors_before_any_file_is_read(runner, tmp_path, args):
    with runner.isolated_filesystem(temp_dir=tmp_path):
        result = invoke(runner, *args)
        assert result.exit_code == 2, result.output
        assert "--" in result.stderr.splitlines()[-1], result.stderr          # it names an option, not a file
        assert not os.path.exists("out.html")
