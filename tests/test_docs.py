"""Every ```console example in the README and in docs/ prints what the page shows.

A block is a sequence of ``$ command`` lines, each followed by the output the
page promises.  ``massprops`` commands run through click's CliRunner (stdout
and stderr interleaved, as a terminal shows them), anything else (and any
command with a pipe or a redirection) through the shell, all in one scratch folder per block that sees the repository's
``sample_meshes/``.  In the expected text a line ``...`` stands for any number
of lines and ``...`` inside a line for any text, as in doctest's ELLIPSIS, so
run times and abridged listings can be shown without going stale.  Blocks
fenced as ```bash are illustrations and are not run.
"""

from __future__ import annotations

import glob
import os
import re
import shlex
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_FENCE = re.compile(r"^```console[^\n]*\n(.*?)^```", re.S | re.M)


def _blocks():
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for match in _FENCE.finditer(text):
            line = text[:match.start()].count("\n") + 1
            yield pytest.param(page, match.group(1), id=f"{page.relative_to(ROOT)}:{line}")


def _steps(block):
    """``[(command, expected lines)]`` of one block."""
    steps = []
    for line in block.splitlines():
        if line.startswith("$ "):
            steps.append((line[2:], []))
        elif steps:
            steps[-1][1].append(line.rstrip())
        elif line.strip():
            raise AssertionError(f"output before any command: {line!r}")
    return steps


def _line_matches(pattern, line):
    if "..." not in pattern:
        return pattern == line
    parts = [re.escape(p) for p in pattern.split("...")]
    return re.fullmatch(".*".join(parts), line, re.S) is not None


def matches(expected, actual):
    """Whether ``actual`` lines fit ``expected`` lines with ``...`` wildcards (lines and inline)."""
    memo = {}

    def fit(i, j):
        if (i, j) in memo:
            return memo[i, j]
        if i == len(expected):
            result = j == len(actual)
        elif expected[i].strip() == "...":
            result = any(fit(i + 1, k) for k in range(j, len(actual) + 1))
        else:
            result = j < len(actual) and _line_matches(expected[i], actual[j]) and fit(i + 1, j + 1)
        memo[i, j] = result
        return result

    return fit(0, 0)


def _run(command, folder):
    words = shlex.split(command, comments=True)
    if words and words[0] == "massprops" and not set("|;&<>") & set(command):
        from click.testing import CliRunner

        from massprops.cli import main
        args = []
        for word in words[1:]:
            found = sorted(glob.glob(word, root_dir=folder)) if any(c in word for c in "*?[") else []
            args += found or [word]
        cwd = os.getcwd()
        os.chdir(folder)
        try:
            result = CliRunner().invoke(main, args, catch_exceptions=False)
        finally:
            os.chdir(cwd)
        return result.output
    done = subprocess.run(command, shell=True, cwd=folder, capture_output=True, text=True, timeout=120)
    return done.stdout + done.stderr


def test_the_examples_are_found():
    assert sum(1 for _ in _blocks()) >= 10


def test_ellipsis_matching_can_fail():
    assert matches(["a", "...", "d"], ["a", "b", "c", "d"])
    assert matches(["x = ...s"], ["x = 0.19 s"])
    assert not matches(["a", "...", "d"], ["a", "b", "c"])
    assert not matches(["x = ...s"], ["x = 0.19 ms!"])


@pytest.mark.parametrize("page,block", _blocks())
def test_example_prints_what_the_page_shows(page, block, tmp_path):
    (tmp_path / "sample_meshes").symlink_to(ROOT / "sample_meshes")
    for command, expected in _steps(block):
        while expected and not expected[-1]:
            expected.pop()
        actual = [line.rstrip() for line in _run(command, tmp_path).rstrip("\n").splitlines()]
        assert matches(expected, actual), (
            f"{page.name}: `$ {command}` printed\n" + "\n".join(actual) + "\n\nbut the page shows\n"
            + "\n".join(expected))
