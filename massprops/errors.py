"""Exceptions raised by massprops.

Every error names the input (``path``), says what is wrong (``problem``) and
what to do about it (``fix``); ``str(err)`` is the one line the command line
prints after ``error:``.  The library raises; only :mod:`massprops.cli` prints.
"""

from __future__ import annotations

__all__ = [
    "MassPropsError",
    "MeshFormatError",
    "MeshReadError",
    "MeshGeometryError",
    "OpenMeshError",
    "WindingError",
    "OptionError",
]


class MassPropsError(Exception):
    """Base class: something about an input or an option is wrong.

    Parameters
    ----------
    problem : str
        What is wrong, e.g. ``"mesh is open: 4 boundary edges"``.
    path : str or os.PathLike, optional
        The input file the problem is in.
    fix : str, optional
        What the user can do about it, e.g. ``"close the holes or pass --repair"``.
    """

    def __init__(self, problem, *, path=None, fix=None):
        self.problem = problem
        self.path = None if path is None else str(path)
        self.fix = fix
        super().__init__(self._line())

    def _line(self):
        line = self.problem if self.path is None else f"{self.path}: {self.problem}"
        return line if not self.fix else f"{line} — {self.fix}"

    def with_path(self, path):
        """Return a copy of this error attributed to ``path``."""
        return type(self)(self.problem, path=path, fix=self.fix)


class MeshFormatError(MassPropsError, ValueError):
    """The file is not a mesh of a format massprops reads, or is malformed."""


class MeshReadError(MassPropsError, OSError):
    """The file cannot be read at all (missing, a directory, no permission)."""


class MeshGeometryError(MassPropsError, ValueError):
    """The mesh was read but is not a valid solid (NaN, zero volume, overflow)."""


class OpenMeshError(MeshGeometryError):
    """The surface is not closed: some directed edge has no matching reverse edge."""


class WindingError(MeshGeometryError):
    """The surface is closed but its faces are wound inconsistently."""


class OptionError(MassPropsError, ValueError):
    """An option value is invalid (a non-orthonormal rotation, a negative density...)."""
