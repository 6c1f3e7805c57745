"""STL and OBJ files straight into welded arrays (the parsers of the compiled core).

Both readers refuse anything that is not a regular file before reading it (a
FIFO never blocks), read with ``pread`` into bounded buffers (a file that
shrinks while it is read is an error, not a crash), and allocate nothing a
header claims unless the file's size can hold it.  Their errors become
:class:`massprops.model.errors.MeshFormatError` naming the file, the line where it
applies, and a fix.
"""

from __future__ import annotations

import os

import numpy as np

from ..model.errors import MeshFormatError
from . import _core
from .threads import thread_count

__all__ = ["read_stl", "read_obj"]


def read_stl(path):
    """Read a binary or ASCII STL and weld it.

    Binary when the size is exactly ``84 + 50 n`` for the header's count
    ``n`` (whatever the header's text), ASCII when the text starts with
    ``solid`` (after a UTF-8 byte-order mark and blanks; keywords in any case).

    Returns
    -------
    vertices : ndarray, shape (k, 3), float64
        Binary coordinates are float32 values, widened exactly.
    faces : ndarray, shape (m, 3), int64
    binary : bool
    """
    try:
        vertices, faces, binary = _core.read_stl(os.fspath(path), thread_count())
    except _core.ParseError as error:
        raise MeshFormatError(error.args[0], path=path, fix=error.args[1] or None) from None
    return np.asarray(vertices), np.asarray(faces), binary


def read_obj(path):
    """Read a Wavefront OBJ (``v`` and ``f`` statements, polygons fanned) and weld it.

    Returns
    -------
    vertices : ndarray, shape (k, 3), float64
        Coordinates as Python's ``float`` reads them; only the vertices faces use.
    faces : ndarray, shape (m, 3), int64
    ignored : int
        Vertices no face uses whose coordinates are NaN or infinite (left out).
    """
    try:
        vertices, faces, ignored = _core.read_obj(os.fspath(path), thread_count())
    except _core.ParseError as error:
        raise MeshFormatError(error.args[0], path=path, fix=error.args[1] or None) from None
    return np.asarray(vertices), np.asarray(faces), ignored
