"""Exceptions raised by massprops.

Every error names the input (``path``), says what is wrong (``problem``) and
what to do about it (``fix``); ``str(err)`` is the one line the command line
prints after ``error:``.  The library raises; only :mod:`massprops.cli` prints.

Options in messages
-------------------
A message that names an option writes it as a placeholder, ``{repair}`` or
``{shell=THICKNESS}`` (:func:`option` builds one inside an f-string).  The
error renders it for its audience: ``str(err)`` (Python callers) spells
keyword arguments, ``repair=True`` and ``shell=THICKNESS``;
``err.render("cli")`` spells options, ``--repair`` and ``--shell THICKNESS``.
"""

from __future__ import annotations

import re

__all__ = [
    "MassPropsError",
    "MeshFormatError",
    "MeshReadError",
    "MeshGeometryError",
    "OpenMeshError",
    "WindingError",
    "OptionError",
    "OutputError",
    "ArgumentTypeError",
    "option",
    "render_options",
    "printable",
    "reason",
]

# Options that are both keyword arguments of the library and command-line options.
# Flags: a bare placeholder means "turn it on" (repair=True / --repair).
_FLAGS = frozenset({"repair", "recursive", "resume", "declared_only", "allow_env", "expand"})
_VALUED = frozenset({"density", "mass", "unit", "pose", "only", "shell", "density_field", "density_map",
                     "max_unpacked", "max_instances", "max_depth", "timeout", "digits", "rtol", "steps", "duration", "jobs", "scheduler",
                     "omega", "about", "rotate", "translate", "on_open", "mass_policy", "massless", "joints",
                     "geometry", "tolerance"})
# Options whose keyword argument has another name and form: placeholder → (keyword spelling, option spelling).
_RENAMED = {"package": ("packages={'NAME': 'DIR'}", "--package NAME=DIR"),
            "config": ("config_path", "--config"),
            "root": ("roots=['DIR']", "--root DIR"),
            "xacro_arg": ("xacro_args={'NAME': 'VALUE'}", "--xacro-arg NAME=VALUE")}
# On/off switches with an option each way: {name=True} is --name, {name=False} is --no-name.
_SWITCHES = frozenset({"self_intersection"})
OPTION_NAMES = _FLAGS | _VALUED | _SWITCHES | frozenset(_RENAMED)
# Patterns are kept as text and compiled by the re module on first use (and cached there): compiling
# them at import would cost every start-up about 0.7 ms, for messages most runs never write.
_PLACEHOLDER = r"\{([a-z_]+)(?:=([A-Za-z_.,0-9|:*=-]+))?\}"
STYLES = ("python", "cli")


# Characters a terminal acts on (C0 and C1 controls: ESC starts escape sequences, BEL rings, VT and FF and
# NEL and the Unicode separators break lines), invisible reordering marks, and lone surrogates (bytes of a
# file that are not UTF-8) which no terminal encoding can print.
_UNPRINTABLE = ("[\x00-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028-\u202e\u2066-\u2069\ufeff"
                "\ud800-\udfff]")


def _escaped(match):
    code = ord(match.group(0))
    if 0xDC80 <= code <= 0xDCFF:                # a byte decoded with surrogateescape
        return f"\\x{code - 0xDC00:02x}"
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


_LINE_BREAK = "[ \t]*[\n\r\x0b\x0c\x1c-\x1e\x85\u2028\u2029]+[ \t]*"


def printable(text):
    """``text`` safe to print on one line of a terminal, CSV cell or log.

    Line breaks of every kind (with the blanks around them) become one space,
    so the text stays one line; every other control character (and invisible
    reordering mark) is shown as an escape, ``\\x1b``, ``\\x07``,
    ``\\u202e``.  Everything else, backslashes included, is kept, so
    applying it twice changes nothing more.
    """
    text = str(text)
    if not re.search(_UNPRINTABLE, text):
        return text
    return re.sub(_UNPRINTABLE, _escaped, re.sub(_LINE_BREAK, " ", text))


# A Python class name in a message (``DaeMalformedError:``, ``BadZipFile:``): users are told what, not which class.
_CLASS_NAME = r"\b[A-Z][A-Za-z0-9]*(?:Error|Exception|Warning|ZipFile)\b:?\s*"
# Exceptions a third-party reader raises on its own bugs: their text is about its code, not the file.
_INTERNAL = (AttributeError, TypeError, KeyError, IndexError, NameError, AssertionError, RecursionError,
             ZeroDivisionError)


def reason(exc, internal="its reader failed on this content"):
    """Why a third-party call failed, in words: the exception's message without class names.

    An exception that is a reader's own bug (an ``AttributeError`` on ``None``,
    a ``KeyError``...) gives ``internal`` instead, whose text would mean nothing to a user.
    """
    if isinstance(exc, _INTERNAL):
        return internal
    text = re.sub(_CLASS_NAME, "", str(exc)).strip().strip(":").strip()
    return text or internal


def option(name, value=None):
    """The placeholder for option ``name`` (with an example ``value``), for use inside f-strings."""
    if name not in OPTION_NAMES:
        raise KeyError(f"{name!r} is not an option massprops names in messages")
    return "{" + name + ("" if value is None else f"={value}") + "}"


def _spell(match, style):
    name, value = match.group(1), match.group(2)
    if name not in OPTION_NAMES:
        return match.group(0)
    if name in _RENAMED:
        return _RENAMED[name][style == "cli"]
    if style == "cli":
        flag = "--" + name.replace("_", "-")
        if name in _SWITCHES:
            return flag if value != "False" else "--no-" + flag[2:]
        return flag if value is None else f"{flag} {value}"
    if value is None:
        return f"{name}=True" if name in _FLAGS else name
    return f"{name}={value}"


def render_options(text, style="python"):
    """``text`` with its option placeholders spelled for ``style`` (``"python"`` or ``"cli"``)."""
    if style not in STYLES:
        raise ValueError(f"style must be one of {STYLES}, got {style!r}")
    return re.sub(_PLACEHOLDER, lambda m: _spell(m, style), text) if "{" in text else text


class MassPropsError(Exception):
    """Base class: something about an input or an option is wrong.

    Parameters
    ----------
    problem : str
        What is wrong, e.g. ``"mesh is open: 4 boundary edges"``.
    path : str or os.PathLike, optional
        The input file the problem is in.
    fix : str, optional
        What the user can do about it, e.g. ``"close the holes or pass {repair}"``.
    """

    def __init__(self, problem, *, path=None, fix=None):
        # What a message quotes from a file (a line, a name, an attribute) must not act on the terminal.
        self.problem = printable(problem)
        self.path = None if path is None else str(path)
        self.fix = None if fix is None else printable(fix)
        super().__init__(self.problem)

    def render(self, style="python", *, with_path=True):
        """The one line: ``PATH: problem — fix``, options spelled for ``style`` (``"python"`` or ``"cli"``)."""
        line = self.problem if self.path is None or not with_path else f"{self.path}: {self.problem}"
        return render_options(line if not self.fix else f"{line} — {self.fix}", style)

    def __str__(self):
        return self.render()

    def with_path(self, path):
        """Return a copy of this error attributed to ``path``."""
        return type(self)(self.problem, path=path, fix=self.fix)

    def with_context(self, context, *, path=None):
        """A copy whose problem starts with ``context`` (e.g. ``"part 'arm'"``); ``path`` if it had none."""
        return type(self)(f"{context}: {self.problem}", path=self.path or path, fix=self.fix)


class MeshFormatError(MassPropsError, ValueError):
    """The file is not a mesh of a format massprops reads, or is malformed."""


class MeshReadError(MassPropsError, OSError):
    """The file cannot be read at all (missing, a directory, a device, no permission)."""


class MeshGeometryError(MassPropsError, ValueError):
    """The mesh was read but is not a valid solid (NaN, zero volume, overflow)."""


class OpenMeshError(MeshGeometryError):
    """The surface is not closed: some directed edge has no matching reverse edge."""


class WindingError(MeshGeometryError):
    """The surface is closed but its faces are wound inconsistently."""


class OptionError(MassPropsError, ValueError):
    """An option value is invalid (a non-orthonormal rotation, a negative density...)."""


class OutputError(MassPropsError, OSError):
    """An output (a report, a plot) cannot be written: a full disk, a missing folder, no permission."""


class ArgumentTypeError(MassPropsError, TypeError):
    """An argument of the Python API has the wrong type (a list of paths, float face indices...)."""
