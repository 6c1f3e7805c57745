"""Start-up stays light, and the thread count comes from the environment.

``massprops props`` on a small binary STL imports none of the heavy optional
packages (checked in a fresh interpreter, through click's CliRunner).
"""

import json
import os
import subprocess
import sys

import pytest

from massprops.validation import solids
from massprops.core import thread_count
from massprops.model.errors import OptionError
from massprops.io.stl import write_binary

HEAVY = ("trimesh", "scipy", "meshio", "matplotlib", "plotly", "dask", "manifold3d", "mujoco", "pymeshlab")

PROBE = """
import json, sys
from click.testing import CliRunner
import massprops.cli
result = CliRunner().invoke(massprops.cli.main, ["props", "--format", "json", sys.argv[1]])
print(json.dumps({"exit": result.exit_code, "output": result.output,
                  "heavy": sorted(m for m in %r if m in sys.modules)}))
""" % (HEAVY,)


def _probe(path):
    done = subprocess.run([sys.executable, "-c", PROBE, str(path)], capture_output=True, text=True, check=True)
    return json.loads(done.stdout)


def test_props_on_a_binary_stl_imports_no_heavy_package(tmp_path):
    path = tmp_path / "box.stl"
    write_binary(path, solids.box((1.0, 2.0, 3.0), (0.5, 0.5, 0.5)).triangles)
    probe = _probe(path)
    assert probe["exit"] == 0, probe["output"]
    assert json.loads(probe["output"])[0]["volume"] == 6.0
    assert probe["heavy"] == []


def test_a_bad_binary_stl_also_fails_without_heavy_imports(tmp_path):
    path = tmp_path / "open.stl"
    write_binary(path, solids.box((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)).triangles[:-1])
    probe = _probe(path)
    assert probe["exit"] == 1
    assert "open" in probe["output"]
    assert probe["heavy"] == []


# Source text run with exec while importing massprops and its CLI: a dataclass writes and compiles
# its methods this way (about 0.3 ms each), which start-up does without (massprops.model.records);
# and any other text compiled (a NamedTuple's annotations and the __new__ namedtuple evaluates),
# seen by the interpreter's audit hook (a module's own source, when no bytecode is cached, is not
# generated code).  Text is massprops' when the first frame that asked for it outside the standard
# library is in massprops (a stdlib module's own namedtuple, loaded first by massprops under an old
# numpy, is not).
GENERATED = """
import builtins, json, os, sys, sysconfig
import numpy, click
found = []
stdlib = os.path.realpath(sysconfig.get_paths()["stdlib"])
def ours(frame):
    while frame is not None:
        name = frame.f_code.co_filename
        if not (name.startswith("<frozen") or os.path.realpath(name).startswith(stdlib + os.sep)):
            return "massprops" in os.path.realpath(name).split(os.sep)
        frame = frame.f_back
    return False
original = builtins.exec
def counting(source, *args, **kwargs):
    if isinstance(source, (str, bytes)) and ours(sys._getframe(1)):
        found.append(sys._getframe(1).f_code.co_filename)
    return original(source, *args, **kwargs)
builtins.exec = counting
def audit(event, args):
    if event == "compile" and not str(args[1]).endswith(".py") and ours(sys._getframe(1)):
        found.append(f"compile {args[1]}")
sys.addaudithook(audit)
import massprops, massprops.cli, massprops.cli.props, massprops.mesh.solid, massprops.mesh.shells, massprops.report
import massprops.io, massprops.compute                     # what props loads to read and integrate a file
print(json.dumps(found))
"""


def test_importing_massprops_writes_no_code():
    done = subprocess.run([sys.executable, "-c", GENERATED], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == []


def test_thread_count_follows_the_environment(monkeypatch):
    monkeypatch.setenv("MASSPROPS_THREADS", "1")
    assert thread_count() == 1
    monkeypatch.setenv("MASSPROPS_THREADS", " 3 ")
    assert thread_count() == 3
    monkeypatch.delenv("MASSPROPS_THREADS")
    assert thread_count() >= 1


@pytest.mark.parametrize("value", ["abc", "1.5", "two"])
def test_a_thread_count_that_is_not_a_whole_number_is_refused(monkeypatch, runner, tmp_path, value):
    monkeypatch.setenv("MASSPROPS_THREADS", value)
    with pytest.raises(OptionError, match="MASSPROPS_THREADS must be a whole number"):
        thread_count()
    from massprops.cli import main
    path = tmp_path / "box.stl"
    write_binary(path, solids.box().triangles)
    result = runner.invoke(main, ["props", str(path)])
    assert result.exit_code != 0 and "MASSPROPS_THREADS must be a whole number" in result.output
    assert "Traceback" not in result.output


COLLECTOR = """
import gc, json
gc.disable()
import massprops
paused = gc.isenabled()
gc.enable()
import massprops.cli
print(json.dumps([paused, gc.isenabled()]))
"""


def test_importing_massprops_leaves_the_garbage_collector_as_it_was():
    """Start-up pauses the cyclic collector while modules load (issue 24), and restores what it found."""
    done = subprocess.run([sys.executable, "-c", COLLECTOR], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == [False, True]


# numpy's BLAS threads (issue 24): the `massprops` script asks for one before numpy is imported, unless the
# user chose a count; importing massprops or its CLI as a library changes no environment variable.
BLAS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "BLIS_NUM_THREADS")

# Records the BLAS settings numpy finds when it is first imported.
AT_NUMPY = """
import json, os, sys
seen = {}
def audit(event, args):
    if event == "import" and args[0] == "numpy" and "numpy" not in seen:
        seen["numpy"] = {name: os.environ.get(name) for name in %r}
sys.addaudithook(audit)
""" % (BLAS,)

BLAS_PROBE = AT_NUMPY + """
before = dict(os.environ)
import massprops, massprops.cli
from massprops import mass_properties
mass_properties(sys.argv[1])
imported = dict(os.environ)
sys.argv = ["massprops", "props", sys.argv[1]]
try:
    massprops.cli.main()                  # as the installed script calls it
except SystemExit as exit:
    code = exit.code
print(json.dumps({"imported_unchanged": imported == before, "at_numpy": seen["numpy"], "exit": code}))
"""


def _blas_probe(path, **env):
    clean = {k: v for k, v in os.environ.items() if k not in BLAS}
    done = subprocess.run([sys.executable, "-c", BLAS_PROBE, str(path)], capture_output=True, text=True,
                          check=True, env={**clean, **env})
    return json.loads(done.stdout.splitlines()[-1])


def test_importing_massprops_changes_no_environment_variable(tmp_path):
    path = tmp_path / "box.stl"
    write_binary(path, solids.box((1.0, 2.0, 3.0), (0.5, 0.5, 0.5)).triangles)
    probe = _blas_probe(path)
    assert probe["imported_unchanged"]
    assert probe["at_numpy"] == dict.fromkeys(BLAS)        # the library loaded numpy with the user's (no) settings
    assert probe["exit"] == 0


CLI_BLAS_PROBE = AT_NUMPY + """
from massprops.cli import main
sys.argv = ["massprops", "props", "--format", "json", sys.argv[1]]
try:
    main()
except SystemExit as exit:
    code = exit.code
print(json.dumps({"at_numpy": seen["numpy"], "exit": code}))
"""


@pytest.mark.parametrize("chosen", [None, "2"])
def test_the_command_line_starts_numpy_with_one_blas_thread_unless_told(tmp_path, chosen):
    path = tmp_path / "box.stl"
    write_binary(path, solids.box((1.0, 2.0, 3.0), (0.5, 0.5, 0.5)).triangles)
    clean = {k: v for k, v in os.environ.items() if k not in BLAS}
    if chosen:
        clean["OPENBLAS_NUM_THREADS"] = chosen
    done = subprocess.run([sys.executable, "-c", CLI_BLAS_PROBE, str(path)], capture_output=True, text=True,
                          check=True, env=clean)
    report, probe = done.stdout.rstrip("\n").rsplit("\n", 1)
    probe = json.loads(probe)
    assert probe["exit"] in (0, None)
    assert json.loads(report)[0]["volume"] == 6.0
    assert probe["at_numpy"] == {**dict.fromkeys(BLAS, "1"), "OPENBLAS_NUM_THREADS": chosen or "1"}


LAZY = """
import json, sys
import massprops
light = "numpy" not in sys.modules
names = [massprops.Pose.__name__, massprops.mass_properties.__name__, massprops.io.read.__name__,
         massprops.core.integrate.__name__]
try:
    massprops.no_such_name
    missing = "found"
except AttributeError:
    missing = "AttributeError"
print(json.dumps({"light": light, "names": names, "missing": missing}))
"""


def test_import_massprops_loads_its_names_and_subpackages_on_first_use():
    done = subprocess.run([sys.executable, "-c", LAZY], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == {"light": True, "names": ["Pose", "mass_properties", "read", "integrate"],
                                       "missing": "AttributeError"}


HELP_PROBE = """
import json, sys
from massprops.cli import main
sys.argv = ["massprops", sys.argv[1]]
try:
    main()                                # as the installed script calls it
except SystemExit as exit:
    code = exit.code
print(json.dumps({"exit": code, "numpy": "numpy" in sys.modules}))
"""


@pytest.mark.parametrize("option, code, said", [("--version", 0, "version"), ("--no-such-option", 2, "No such option")])
def test_the_script_loads_numpy_only_for_a_command(option, code, said):
    """The script loads the pipeline before click parses (issue 24), but only when a command is named."""
    done = subprocess.run([sys.executable, "-c", HELP_PROBE, option], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout.splitlines()[-1]) == {"exit": code, "numpy": False}
    assert said in done.stdout + done.stderr
