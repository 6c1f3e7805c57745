"""What a batch computes: the mesh files that paths, folders, globs and ``@LIST`` files name, each once.

One file is one row whatever it is called: ``./a.stl``, ``dir/../a.stl`` and a
symbolic or hard link to it are the same file (device and inode), listed under
the first name met.  Names keep the bytes the file system gives them (surrogate
escapes for bytes that are not UTF-8), from folders and from ``@LIST`` files alike.
"""

from __future__ import annotations

import glob
import os
import re

from ..model.errors import MassPropsError, MeshReadError

__all__ = ["expand_inputs"]

_GLOB_CHARS = re.compile(r"[*?\[]")


def _mesh_files_in(directory, recursive, skipped=None):
    from ..io import EXTENSIONS
    found = []
    for root, dirs, names in os.walk(directory):
        dirs.sort()
        for name in sorted(names):
            extension = os.path.splitext(name)[1].lower()
            if extension in EXTENSIONS:
                found.append(os.path.join(root, name))
            elif skipped is not None:
                skipped[extension or "(none)"] = skipped.get(extension or "(none)", 0) + 1
        if not recursive:
            break
    return found


def _read_list(list_path):
    """Paths listed one per line in ``list_path`` (blank lines and ``#`` comments skipped).

    The list is read as UTF-8; bytes that are not UTF-8 are kept as surrogate
    escapes, so names in any encoding reach the file system unchanged.  Lines
    end at line feeds (a carriage return before one is dropped); surrounding
    spaces are stripped.
    """
    from ..io.inputs import check_input, check_no_holes
    try:
        check_no_holes(list_path, check_input(list_path, what="list of paths"))
        with open(list_path, "rb") as f:
            text = f.read().decode("utf-8", "surrogateescape")
    except MassPropsError as exc:
        raise exc.with_context("cannot read the list of paths") from None
    except OSError as exc:
        raise MeshReadError(f"cannot read the list of paths ({exc.strerror or exc})", path=list_path,
                            fix="give an existing text file with one path per line after @") from None
    folder = os.path.dirname(list_path)
    # a relative path in a list means relative to the list, so a list travels with its folder
    return [os.path.join(folder, s) for s in (line.strip() for line in text.split("\n"))
            if s and not s.startswith("#")]


def _identity(path):
    """What makes two names one file: its device and inode (links and ``..`` resolved), else its name."""
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return ("name", path)
    return ("file", info.st_dev, info.st_ino)


def expand_inputs(paths, *, recursive=False, duplicates=None, skipped=None):
    """The mesh files that ``paths`` name, in order, each once.

    Parameters
    ----------
    paths : iterable of str
        Files; directories (their mesh files, by registered extension;
        sub-directories too with ``recursive``); glob patterns (``**`` with
        ``recursive``); ``@LIST`` for a text file of such paths, one a line,
        relative to the list's folder.  A name that matches nothing, or a
        folder with no mesh files, is kept, so the report says what is wrong.
    duplicates : list, optional
        Receives ``(name, kept)`` for each name of a file already listed
        under the name ``kept``: ``./a.stl``, ``dir/../a.stl``, a symbolic
        or hard link to it are one file, one row, under the first name met.
    skipped : dict, optional
        Filled with ``{extension: count}`` of the files in the folders walked
        that are not in a format massprops reads.

    Raises
    ------
    MeshReadError
        An ``@LIST`` file cannot be read.
    """
    files, seen = [], {}

    def add(path):
        path = os.path.normpath(path)
        key = _identity(path)
        if key not in seen:
            seen[key] = path
            files.append(path)
        elif duplicates is not None and seen[key] != path:
            duplicates.append((path, seen[key]))

    def expand(path, depth=0):
        if path.startswith("@") and depth < 8:
            for listed in _read_list(path[1:]):
                expand(listed, depth + 1)
        elif os.path.isdir(path):
            # a named folder with no mesh files still gets its row, so the report shows the mistake
            for found in _mesh_files_in(path, recursive, skipped) or [path]:
                add(found)
        elif _GLOB_CHARS.search(path) and not os.path.exists(path):
            matches = sorted(glob.glob(path, recursive=recursive))
            for match in matches or [path]:
                expand(match, depth + 1) if os.path.isdir(match) else add(match)
        else:
            add(path)

    for path in paths:
        expand(os.fsdecode(path))
    return files
