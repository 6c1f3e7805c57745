"""The reader registry: which reader takes a file, by extension.

Reader modules register ``read(path) -> mesh`` for their extensions with
:func:`register_format`; :func:`read` picks the reader by extension.
"""

from __future__ import annotations

import os

from ..errors import MeshFormatError, MeshReadError

__all__ = ["read", "register_format", "reader_for", "EXTENSIONS"]

_READERS = {}


def register_format(name, extensions, reader):
    """Register ``reader(path) -> mesh`` for file names ending in any of ``extensions``."""
    for ext in extensions:
        _READERS[ext.lower()] = (name, reader)


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


def read(path):
    """Read a mesh file into a :class:`massprops.mesh.surface.TriangleMesh` (or a volume mesh).

    Raises
    ------
    MeshReadError
        Missing path, a directory, or unreadable.
    MeshFormatError
        Unknown extension, or contents that are not a mesh of that format.
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        raise MeshReadError("is a directory, not a mesh file", path=path,
                            fix="name the mesh files, or use `massprops batch DIR`")
    if not os.path.exists(path):
        raise MeshReadError("no such file", path=path, fix="check the path")
    _, reader = reader_for(path)
    try:
        return reader(path)
    except (MeshFormatError, MeshReadError):
        raise
    except OSError as exc:
        raise MeshReadError(f"cannot read the file ({exc.strerror or exc})", path=path,
                            fix="check permissions and that the file is complete") from None


EXTENSIONS = _READERS
