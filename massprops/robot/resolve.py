"""Where the files a robot description names are: ``package://``, ``model://``, ``file://`` and relative URIs.

Order for ``package://NAME/rest`` (first hit wins, every try is logged):

1. ``--package NAME=DIR`` (``packages=`` here);
2. the config file's ``[packages]``;
3. the ROS path variables: ``ROS_PACKAGE_PATH`` (each entry, its ``NAME``
   folder, or a folder below it whose ``package.xml`` names ``NAME``) and
   ``AMENT_PREFIX_PATH`` (``PREFIX/share/NAME``);
4. a ``package.xml`` whose ``<name>`` is ``NAME``, walking up from the model
   file: in each folder above it and in that folder's sub-folders;
5. a folder called ``NAME`` above the model file (a package without its
   ``package.xml``, as PyPI packages often ship them), with a warning.

``model://NAME/rest`` tries 1 and 2, then the Gazebo path variables
(``GZ_SIM_RESOURCE_PATH``, ``IGN_GAZEBO_RESOURCE_PATH``, ``GAZEBO_MODEL_PATH``,
``SDF_PATH``), then folders above the model file holding ``NAME/model.config``.
``file://`` is an absolute path; anything without a scheme is relative to the
model file's folder.  ``http(s)://`` is refused: massprops reads no network.

Confinement: a robot file is data from anyone, so every file it names must
lie, after ``..`` and symbolic links are resolved (``os.path.realpath``),
inside an allowed root: the model's own package (the nearest folder above the
model holding a ``package.xml`` or ``model.config``, else the parent of the
model's folder, so that ``../meshes/`` works), a ``--root DIR`` (``roots=``),
or a package folder resolved so far (by ``package://``, ``model://`` or
``$(find)``).  A package found only by its folder name (rule 5) counts only
inside those roots, so ``package://etc/passwd`` finds nothing.  An escape is
refused with one line, never silently skipped.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from functools import cached_property

from ..errors import MassPropsError, MeshReadError, option

__all__ = ["Resolution", "Resolver", "OutsideRootError", "ROS_VARIABLES", "GAZEBO_VARIABLES"]

ROS_VARIABLES = ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH")
GAZEBO_VARIABLES = ("GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH", "GAZEBO_MODEL_PATH", "SDF_PATH")
_PACKAGE_NAME = re.compile(rb"<name>\s*([^<\s]+)\s*</name>")


class OutsideRootError(MassPropsError, PermissionError):
    """A robot file names a file outside its allowed roots (``..`` past the root, a symbolic link out)."""


_OUTSIDE_FIX = "move the file into the package, or give {root} for a folder you trust"


@dataclass(frozen=True)
class Resolution:
    """One URI's resolution: the file found (or None), by which rule, and every place tried."""

    uri: str
    path: str | None
    by: str | None
    tried: tuple = ()
    warning: str | None = None
    fix: str | None = None

    def as_dict(self):
        return {"uri": self.uri, "resolved_path": self.path, "resolved_by": self.by, "tried": list(self.tried)}


@dataclass
class Resolver:
    """Resolves URIs for one model file and logs every resolution.

    Parameters
    ----------
    model_path : str
        The description file; relative URIs and the upward search start at its folder.
    packages : dict of str to str
        ``--package NAME=DIR`` (relative paths are relative to the current folder).
    config_packages : dict of str to str
        The config file's ``[packages]`` (relative to the config file; the caller makes them absolute).
    environ : mapping
        The environment (``os.environ`` by default).
    roots : tuple of str
        ``--root DIR``: folders the model may also read from, besides its own package root.
    """

    model_path: str
    packages: dict = field(default_factory=dict)
    config_packages: dict = field(default_factory=dict)
    environ: dict | None = None
    roots: tuple = ()
    log: dict = field(default_factory=dict)
    _package_xml: dict = field(default_factory=dict)
    _package_roots: list = field(default_factory=list)
    _passed_over: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.environ is None:
            self.environ = dict(os.environ)

    @cached_property
    def model_root(self):
        """The model's own package: the nearest folder above it with a package.xml or model.config.

        Else the parent of the model's folder (``../meshes/`` is the usual layout), or the model's
        folder itself when that parent is the file system's root.
        """
        for ancestor in self._ancestors():
            if any(os.path.isfile(os.path.join(ancestor, n)) for n in ("package.xml", "model.config")):
                return ancestor
        parent = os.path.dirname(self.folder)
        return self.folder if os.path.dirname(parent) == parent else parent

    def allowed_roots(self):
        """Every folder the model may read from: its root, the ``--root`` folders, the packages resolved so far."""
        return list(dict.fromkeys([self.model_root, *(os.path.abspath(r) for r in self.roots), *self._package_roots]))

    def inside(self, path, extra=()):
        """Whether ``path`` (its symbolic links and ``..`` resolved) lies inside an allowed root or ``extra``."""
        real = os.path.realpath(path)
        for root in (*self.allowed_roots(), *extra):
            top = os.path.realpath(root)
            if real == top or real.startswith(top.rstrip(os.sep) + os.sep):
                return True
        return False

    def confine(self, path, what):
        """``path`` if it lies inside an allowed root, else :class:`OutsideRootError` naming ``what``."""
        if not self.inside(path):
            raise OutsideRootError(self._outside(what, path), path=self.model_path, fix=_OUTSIDE_FIX)
        return path

    def _outside(self, what, path):
        return (f"{what} resolves to {os.path.realpath(path)}, outside the model's roots "
                f"({', '.join(self.allowed_roots())}): refused")

    def _admit(self, folder):
        """Record a resolved package folder as a root the model may read from."""
        if folder not in self._package_roots:
            self._package_roots.append(folder)

    @property
    def folder(self):
        return os.path.dirname(os.path.abspath(self.model_path))

    def resolve(self, uri, *, base=None):
        """The :class:`Resolution` of ``uri`` (logged once per distinct URI and base)."""
        key = (uri, base)
        if key not in self.log:
            self.log[key] = self._resolve(uri.strip(), base or self.folder)
        return self.log[key]

    def require(self, uri, *, base=None, what="mesh"):
        """The resolved path of ``uri``; a :class:`MeshReadError` listing the places tried if none."""
        resolution = self.resolve(uri, base=base)
        if resolution.path is None:
            if resolution.by == "refused":
                error = OutsideRootError if resolution.fix == _OUTSIDE_FIX else MeshReadError
                raise error(f"{what} {uri!r}: {resolution.tried[0]}", path=self.model_path,
                            fix=resolution.fix or "download the file and give a local path")
            tried = "; ".join(resolution.tried) or "nowhere to look"
            fix = ("give {package} or set ROS_PACKAGE_PATH" if uri.startswith("package://") else
                   "set GZ_SIM_RESOURCE_PATH or give {package}" if uri.startswith("model://") else
                   "check the path")
            raise MeshReadError(f"{what} {uri!r} not found (tried: {tried})", path=self.model_path, fix=fix)
        return resolution.path

    def find_package(self, name):
        """The folder of ROS package ``name`` (xacro's ``$(find NAME)``), by the same rules; None if not found."""
        tried = []
        for folder, by in self._package_folders(name, "package"):
            tried.append(f"{folder} ({by})")
            if os.path.isdir(folder):
                self.log[(f"$(find {name})", None)] = Resolution(f"$(find {name})", folder, by, tuple(tried))
                self._admit(folder)
                return folder
        self.log[(f"$(find {name})", None)] = Resolution(f"$(find {name})", None, None, tuple(tried))
        return None

    # -- the rules -----------------------------------------------------------

    def _resolve(self, uri, base):
        scheme, sep, rest = uri.partition("://")
        if not sep:
            path = uri if os.path.isabs(uri) else os.path.join(base, uri)
            return self._checked(uri, [(os.path.normpath(path), "relative to the model" if not os.path.isabs(uri)
                                        else "absolute path", None)])
        scheme = scheme.lower()
        if scheme in ("http", "https"):
            return Resolution(uri, None, "refused", ("http(s) URIs are not fetched: massprops reads local files only",))
        if scheme == "file":
            path = rest if rest.startswith("/") else "/" + rest
            return self._checked(uri, [(path, "file://", None)])
        if scheme not in ("package", "model"):
            return Resolution(uri, None, None, (f"unknown URI scheme {scheme!r}",))
        name, _, inner = rest.partition("/")
        candidates = [(os.path.join(folder, inner), by, folder) for folder, by in self._package_folders(name, scheme)]
        found = self._checked(uri, candidates, ancestor_name=name if scheme == "package" else None)
        if found.path is None and found.by != "refused":
            return Resolution(uri, None, None, found.tried + self._searched(name, scheme))
        return found

    def _searched(self, name, scheme):
        """What the rules looked at without finding ``name`` (for the message of a URI not found)."""
        notes = [] if name in self.packages else [f"no {option('package')} for {name!r}"]
        variables = ROS_VARIABLES if scheme == "package" else GAZEBO_VARIABLES
        for variable in variables:
            notes.append(f"{variable}={self.environ[variable]}" if self.environ.get(variable) else f"{variable} unset")
        what = f"package.xml naming {name!r} nor folder {name!r}" if scheme == "package" \
            else f"folder {name!r} with a model.config"
        notes.append(f"no {what} above {self.folder}")
        if name in self._passed_over:
            notes.append(f"the folder {self._passed_over[name]} is outside the model's roots: give "
                         f"{option('package')} or {option('root')} if it is the package")
        return tuple(notes)

    def _checked(self, uri, candidates, ancestor_name=None):
        tried, seen = [], set()
        for path, by, package in candidates:
            if path in seen:
                continue
            seen.add(path)
            tried.append(f"{path} ({by})")
            # Checked before the file is looked at: an escape is refused whether or not the file exists.
            if not self.inside(path, extra=(package,) if package else ()):
                where = f"its package {package}, " if package else ""
                return Resolution(uri, None, "refused", (self._outside("it", path).replace(
                    "outside the model's roots", f"outside {where}the model's roots"),), fix=_OUTSIDE_FIX)
            if os.path.isfile(path):
                warning = (f"{uri}: resolved by the folder name {ancestor_name!r} above the model (no package.xml "
                           f"names it) — give {option('package')} for {ancestor_name!r} to be sure") if by == "folder name" else None
                if package:
                    self._admit(package)
                return Resolution(uri, os.path.normpath(path), by, tuple(tried), warning)
        return Resolution(uri, None, None, tuple(tried))

    def _package_folders(self, name, scheme):
        """Candidate folders for package (or model) ``name``, in the documented order, each with its rule."""
        if name in self.packages:
            yield os.path.abspath(self.packages[name]), "--package"
        if name in self.config_packages:
            yield self.config_packages[name], "config [packages]"
        if scheme == "package":
            for entry in self._split("ROS_PACKAGE_PATH"):
                for folder in (os.path.join(entry, name), entry):
                    if self._names(folder) == name:
                        yield folder, "ROS_PACKAGE_PATH"
                for folder in self._subfolders(entry):
                    if self._names(folder) == name:
                        yield folder, "ROS_PACKAGE_PATH"
            for prefix in self._split("AMENT_PREFIX_PATH"):
                yield os.path.join(prefix, "share", name), "AMENT_PREFIX_PATH"
            for ancestor in self._ancestors():
                for folder in (ancestor, *self._subfolders(ancestor)):
                    if self._names(folder) == name:
                        yield folder, "package.xml"
            # A folder's name is no evidence it is a package: only inside the roots (not /etc for package://etc/).
            for ancestor in self._ancestors():
                for candidate in [ancestor] * (os.path.basename(ancestor) == name) + [os.path.join(ancestor, name)]:
                    if not os.path.isdir(candidate):
                        continue
                    if self.inside(candidate):
                        yield candidate, "folder name"
                    else:
                        self._passed_over.setdefault(name, candidate)
        else:
            for variable in GAZEBO_VARIABLES:
                for entry in self._split(variable):
                    yield os.path.join(entry, name), variable
            for ancestor in self._ancestors():
                if os.path.isfile(os.path.join(ancestor, name, "model.config")):
                    yield os.path.join(ancestor, name), "model.config"
                if os.path.basename(ancestor) == name and os.path.isfile(os.path.join(ancestor, "model.config")):
                    yield ancestor, "model.config"

    def _split(self, variable):
        return [p for p in self.environ.get(variable, "").split(os.pathsep) if p]

    def _ancestors(self):
        folder = self.folder
        while True:
            yield folder
            parent = os.path.dirname(folder)
            if parent == folder:
                return
            folder = parent

    @staticmethod
    def _subfolders(folder):
        try:
            return sorted(os.path.join(folder, n) for n in os.listdir(folder)
                          if os.path.isdir(os.path.join(folder, n)))
        except OSError:
            return []

    def _names(self, folder):
        """The ``<name>`` in ``folder/package.xml`` (cached), or None."""
        if folder not in self._package_xml:
            name = None
            try:
                with open(os.path.join(folder, "package.xml"), "rb") as handle:
                    match = _PACKAGE_NAME.search(handle.read(65536))
                name = match.group(1).decode("utf-8", "replace") if match else None
            except OSError:
                pass
            self._package_xml[folder] = name
        return self._package_xml[folder]

    def resolutions(self):
        """The log as JSON-able dicts, in the order the URIs were first resolved."""
        return [r.as_dict() for r in self.log.values()]
