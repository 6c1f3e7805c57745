"""Where the files a robot description names are: ``package://``, ``model://``, ``file://`` and relative URIs.

Order for ``package://NAME/rest`` and ``$(find NAME)`` (every try is logged,
and each geometry's ``resolved_by`` names the rule that found its file):

1. ``--package NAME=DIR`` (``packages=`` here);
2. the config file's ``[packages]``;
3. the path variables: ``ROS_PACKAGE_PATH`` (each entry, its ``NAME``
   folder, or a folder below it whose ``package.xml`` names ``NAME``),
   ``AMENT_PREFIX_PATH`` (``PREFIX/share/NAME``) and ``GZ_SIM_RESOURCE_PATH``
   (each entry's ``NAME`` folder), in that order, each entry in its order;
4. a ``package.xml`` whose ``<name>`` is ``NAME``, walking up from the model
   file: in each folder above it and in that folder's sub-folders;
5. a folder called ``NAME`` (a package without its ``package.xml``, as trees
   copied out of a ROS workspace or installed from PyPI ship them), walking up
   from the model: a folder above it called ``NAME``, or a sub-folder ``NAME``
   of a folder above it (the model package's siblings), with one warning per
   package.

Rules 4 and 5 take the nearest level: two different folders found at the same
level for one URI (both holding the file it names) are ambiguous, an error
that lists them (give ``--package``).

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
or a package folder resolved so far by rules 1-4 (or ``model://``).

A folder's name alone (rule 5) is weaker evidence, since ``package://etc/passwd``
names a folder ``/etc`` above every model.  A folder found by its name is used
when it lies inside the roots above, and becomes a root of its own only when
it belongs to the model's tree:

- the model sits in an install prefix's ``share/`` folder (``PREFIX/share/PKG/...``,
  the layout of ament, colcon and cmeel installs) and the folder is
  ``PREFIX/share/NAME``, that is, the package ``PKG`` itself or a package
  installed beside it; or
- the model's own package has no ``package.xml`` (a tree shipped without
  them) and the folder lies inside the *tree*, the folder holding the
  model's package (``robots/`` for ``robots/foo_description/urdf/foo.urdf``):
  the package itself or a sibling such as ``robots/bar_description``.

Never a folder that is, or holds, the user's home folder, and never a tree
that is the file system's root or holds the home folder.  Any other folder
found by its name is passed over, and the message says so (give ``--package``
or ``--root``).  An escape is refused with one line, never silently skipped.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from functools import cached_property

from ..model.errors import MassPropsError, MeshReadError, option

__all__ = ["Resolution", "Resolver", "OutsideRootError", "AmbiguousPackageError", "ROS_VARIABLES",
           "GAZEBO_VARIABLES"]

ROS_VARIABLES = ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH", "GZ_SIM_RESOURCE_PATH")
GAZEBO_VARIABLES = ("GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH", "GAZEBO_MODEL_PATH", "SDF_PATH")
_PACKAGE_NAME = re.compile(rb"<name>\s*([^<\s]+)\s*</name>")


class OutsideRootError(MassPropsError, PermissionError):
    """A robot file names a file outside its allowed roots (``..`` past the root, a symbolic link out)."""


class AmbiguousPackageError(MassPropsError, LookupError):
    """Two different folders are equally good for one package name (rules 4 and 5 at the same level)."""


def _within(path, folder):
    """Whether real path ``path`` is ``folder`` or inside it."""
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


def _ambiguous(uri, name, found):
    """The Resolution of a URI (or ``$(find)``) that two or more folders answer equally well."""
    listed = "; ".join(f"{folder} ({by})" for folder, by in found)
    return Resolution(uri, None, "ambiguous", (f"package {name!r} is ambiguous: {listed}",),
                      fix=f"give {option('package')} for {name!r}, the one meant")


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
    _notices: dict = field(default_factory=dict)

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
            if resolution.by == "ambiguous":
                raise AmbiguousPackageError(f"{what} {uri}: {resolution.tried[0]}", path=self.model_path,
                                            fix=resolution.fix)
            if resolution.by == "refused":
                error = OutsideRootError if resolution.fix == _OUTSIDE_FIX else MeshReadError
                raise error(f"{what} {uri}: {resolution.tried[0]}", path=self.model_path,
                            fix=resolution.fix or "download the file and give a local path")
            tried = "; ".join(resolution.tried)
            fix = ("give {package} or set ROS_PACKAGE_PATH" if uri.startswith("package://") else
                   "set GZ_SIM_RESOURCE_PATH or give {package}" if uri.startswith("model://") else
                   "check the path")
            raise MeshReadError(f"{what} {uri} not found" + (f" (tried: {tried})" if tried else ""),
                                path=self.model_path, fix=fix)
        return resolution.path

    def find_package(self, name):
        """The folder of ROS package ``name`` (xacro's ``$(find NAME)``), by the same rules; None if not found.

        Raises :class:`AmbiguousPackageError` when two different folders are equally good.
        """
        tried, key = [], (f"$(find {name})", None)
        for group in self._groups(self._package_folders(name, "package")):
            found = []
            for folder, by in group:
                tried.append(f"{folder} ({by})")
                if os.path.isdir(folder) and os.path.realpath(folder) not in {os.path.realpath(f) for f, _ in found}:
                    found.append((folder, by))
            if len(found) > 1:
                resolution = _ambiguous(f"$(find {name})", name, found)
                self.log[key] = resolution
                raise AmbiguousPackageError(f"$(find {name}): {resolution.tried[0]}", path=self.model_path,
                                            fix=resolution.fix)
            if found:
                folder, by = found[0]
                self.log[key] = Resolution(f"$(find {name})", folder, by, tuple(tried))
                self._admit(folder)
                self._note(name, folder, by)
                return folder
        self.log[key] = Resolution(f"$(find {name})", None, None, tuple(tried))
        return None

    def notices(self):
        """One warning per package found only by its folder name (the model's warnings, not each geometry's)."""
        return list(self._notices.values())

    def _note(self, name, folder, by):
        if by == "folder name" and name not in self._notices:
            self._notices[name] = (f"package://{name}/ is the folder {folder}, found by its name (no package.xml "
                                   f"names it) — give {option('package')} for {name!r} to be sure")

    @staticmethod
    def _groups(candidates):
        """Consecutive candidates of one level (same group key) together: ``[[(folder, by), ...], ...]``."""
        groups, last = [], object()
        for folder, by, group in candidates:
            if group is None or group != last:
                groups.append([])
            groups[-1].append((folder, by))
            last = group
        return groups

    # -- the rules -----------------------------------------------------------

    def _resolve(self, uri, base):
        scheme, sep, rest = uri.partition("://")
        if not sep:
            path = uri if os.path.isabs(uri) else os.path.join(base, uri)
            return self._checked(uri, [(os.path.normpath(path), "relative to the model" if not os.path.isabs(uri)
                                        else "absolute path", None, None)])
        scheme = scheme.lower()
        if scheme in ("http", "https"):
            return Resolution(uri, None, "refused", ("http(s) URIs are not fetched: massprops reads local files only",))
        if scheme == "file":
            path = rest if rest.startswith("/") else "/" + rest
            return self._checked(uri, [(path, "file://", None, None)])
        if scheme not in ("package", "model"):
            return Resolution(uri, None, None, (f"unknown URI scheme '{scheme}://'",))
        # package:///NAME/rest (an empty host, written by some exporters; pinocchio reads it) is package://NAME/rest.
        name, _, inner = rest.lstrip("/").partition("/")
        candidates = [(os.path.join(folder, inner), by, folder, group)
                      for folder, by, group in self._package_folders(name, scheme)]
        found = self._checked(uri, candidates, name=name)
        if found.path is None and found.by not in ("refused", "ambiguous"):
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

    def _checked(self, uri, candidates, name=None):
        """The first level of ``candidates`` ``(path, by, package folder, group)`` that holds the file."""
        tried, seen = [], set()
        for group in self._groups([((path, package), by, key) for path, by, package, key in candidates]):
            hits = []
            for (path, package), by in group:
                if path in seen:
                    continue
                seen.add(path)
                tried.append(f"{path} ({by})")
                # Checked before the file is looked at: an escape is refused whether or not the file exists.
                if not self.inside(path, extra=(package,) if package else ()):
                    where = f"its package {package}, " if package else ""
                    return Resolution(uri, None, "refused", (self._outside("it", path).replace(
                        "outside the model's roots", f"outside {where}the model's roots"),), fix=_OUTSIDE_FIX)
                if os.path.isfile(path) and os.path.realpath(path) not in {os.path.realpath(p) for p, _, _ in hits}:
                    hits.append((path, by, package))
            if len(hits) > 1:
                return _ambiguous(uri, name, [(package, by) for _, by, package in hits])
            if hits:
                path, by, package = hits[0]
                if package:
                    self._admit(package)
                    self._note(name, package, by)
                return Resolution(uri, os.path.normpath(path), by, tuple(tried))
        return Resolution(uri, None, None, tuple(tried))

    def _package_folders(self, name, scheme):
        """Candidate folders for package (or model) ``name``, in the documented order: ``(folder, rule, level)``.

        ``level`` groups the candidates that are equally good (rules 4 and 5: one folder above the model);
        None for a candidate that stands alone.
        """
        if name in self.packages:
            yield os.path.abspath(self.packages[name]), "--package", None
        if name in self.config_packages:
            yield self.config_packages[name], "config [packages]", None
        if scheme == "package":
            for entry in self._split("ROS_PACKAGE_PATH"):
                for folder in (os.path.join(entry, name), entry):
                    if self._names(folder) == name:
                        yield folder, "ROS_PACKAGE_PATH", None
                for folder in self._subfolders(entry):
                    if self._names(folder) == name:
                        yield folder, "ROS_PACKAGE_PATH", None
            for prefix in self._split("AMENT_PREFIX_PATH"):
                yield os.path.join(prefix, "share", name), "AMENT_PREFIX_PATH", None
            for entry in self._split("GZ_SIM_RESOURCE_PATH"):
                yield os.path.join(entry, name), "GZ_SIM_RESOURCE_PATH", None
            for level, ancestor in enumerate(self._ancestors()):
                if self._names(ancestor) == name:
                    yield ancestor, "package.xml", ("package.xml", level, "self")
                for folder in self._subfolders(ancestor):
                    if self._names(folder) == name:
                        yield folder, "package.xml", ("package.xml", level)
            # A folder's name is weak evidence: only inside the roots or the model's tree (not /etc for package://etc/).
            for level, ancestor in enumerate(self._ancestors()):
                for candidate in [ancestor] * (os.path.basename(ancestor) == name) + [os.path.join(ancestor, name)]:
                    if not os.path.isdir(candidate):
                        continue
                    if self._name_admitted(candidate):
                        yield candidate, "folder name", ("folder name", level)
                    else:
                        self._passed_over.setdefault(name, candidate)
        else:
            for variable in GAZEBO_VARIABLES:
                for entry in self._split(variable):
                    yield os.path.join(entry, name), variable, None
            for ancestor in self._ancestors():
                if os.path.isfile(os.path.join(ancestor, name, "model.config")):
                    yield os.path.join(ancestor, name), "model.config", None
                if os.path.basename(ancestor) == name and os.path.isfile(os.path.join(ancestor, "model.config")):
                    yield ancestor, "model.config", None

    def _name_admitted(self, folder):
        """Whether a folder found by its name may be read: inside the roots or the model's tree (module docstring)."""
        real = os.path.realpath(folder)
        home = os.path.realpath(os.path.expanduser("~"))
        if _within(home, real):
            return False                    # the home folder, or a folder that holds it
        if self.inside(folder):
            return True
        parent = os.path.dirname(real)
        if os.path.basename(parent) == "share" and any(os.path.realpath(a) == parent for a in self._ancestors()):
            return True                     # PREFIX/share/NAME beside (or holding) the model in PREFIX/share/
        tree = self.tree
        return tree is not None and _within(real, tree)

    @cached_property
    def tree(self):
        """The folder holding the model's package when that package has no package.xml (module docstring), or None."""
        root = self.model_root
        if any(os.path.isfile(os.path.join(root, n)) for n in ("package.xml", "model.config")):
            return None
        tree = os.path.realpath(os.path.dirname(root))
        home = os.path.realpath(os.path.expanduser("~"))
        if os.path.dirname(tree) == tree or _within(home, tree):
            return None
        return tree

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
