"""The Python examples of docs/api.md and the README run as doctests, from the repository's top folder,
so they cannot go stale."""

from __future__ import annotations

import doctest
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_the_api_page_examples_print_what_the_page_shows(monkeypatch):
    monkeypatch.chdir(ROOT)                # the examples read sample_meshes/
    failures, tried = doctest.testfile(str(ROOT / "docs" / "api.md"), module_relative=False, verbose=False,
                                       optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert tried > 30 and failures == 0


def test_the_readme_python_example_prints_what_it_shows(monkeypatch):
    monkeypatch.chdir(ROOT)
    failures, tried = doctest.testfile(str(ROOT / "README.md"), module_relative=False, verbose=False,
                                       optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert tried >= 4 and failures == 0
