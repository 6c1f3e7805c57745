"""What the CLI tests of model files share: run a command through CliRunner, write a dedented file."""

import textwrap

from click.testing import CliRunner

from massprops.cli import main


def run(*args):
    """``massprops ARGS`` in process (paths and numbers given as they are)."""
    return CliRunner().invoke(main, [str(a) for a in args])


def write(path, text):
    """Write ``text`` (dedented) to ``path``, making its folders; returns the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(text).lstrip(), encoding="utf-8")
    return path
