"""The reader registry: which reader takes a file, by extension.

Reader modules register ``read(path) -> mesh`` for their extensions with
:func:`register_format`; :func:`read` picks the reader by extension.
"""

from __future__ import annotations

import os

from ..errors import MeshFormatError, MeshReadError
from .inputs import check_archive, check_input, check_no_holes

__all__ = ["read", "register_format", "reader_for", "check_mesh_file", "EXTENSIONS"]

_READERS = {}
_TEXT = set()


def register_format(name, extensions, reader, *, text=False):
    """Register ``reader(path) -> mesh`` for file names ending in any of ``extensions``.

    ``text``: the format is text only, so a file with holes (NUL bytes) is refused before it is parsed.
    """
    for ext in extensions:
        _READERS[ext.lower()] = (name, reader)
        if text:
            _TEXT.add(ext.lower())
        else:
            _TEXT.discard(ext.lower())


def _extension(path):
    return os.path.splitext(str(path))[1].lower()


def reader_for(path):
    """The ``(format name, reader)`` registered for ``path``'s extension."""
    ext = _extension(path)
    try:
        return _READERS[ext]
    except KeyError:
        known = ", ".join(sorted(_READERS))
        raise MeshFormatError(f"unknown mesh format {ext or '(no extension)'!r}", path=path,
                              fix=f"pick one of {known}") from None


def check_mesh_file(path, *, max_unpacked=None):
    """Everything checked of a mesh file before a reader opens it (see :mod:`massprops.io.inputs`).

    Returns the ``(format name, reader)`` for it.
    """
    info = check_input(path, what="mesh file", dir_fix="name the mesh files, or use `massprops batch DIR`")
    found = reader_for(path)
    if _extension(path) in _TEXT:
        check_no_holes(path, info)
    check_archive(path, info, max_unpacked)
    return found


def read(path, *, max_unpacked=None):
    """Read a mesh file into a :class:`massprops.mesh.surface.TriangleMesh` (or a volume mesh).

    Parameters
    ----------
    max_unpacked : int, optional
        Bytes an archive (3MF) may unpack to; default: 100 times its size, at
        least 64 MiB (:func:`massprops.io.inputs.unpack_limit`).

    Raises
    ------
    MeshReadError
        Missing path, a directory, a FIFO, a device, or unreadable.
    MeshFormatError
        Unknown extension, or contents that are not a mesh of that format.
    """
    path = os.fspath(path)
    _, reader = check_mesh_file(path, max_unpacked=max_unpacked)
    try:
        return reader(path)
    except (MeshFormatError, MeshReadError):
        raise
    except OSError as exc:
        raise MeshReadError(f"cannot read the file ({exc.strerror or exc})", path=path,
                            fix="check permissions and that the file is complete") from None


EXTENSIONS = _READERS
