"""Options shared by several subcommands, as named decorators and parameter types, and the error edge.

Every option value is checked here, by click, before any file is read: a
bad one is one usage error (exit 2), not one error per file.  Numbers must be
finite, densities and thicknesses positive, rotations proper.

Library code raises :class:`massprops.model.errors.MassPropsError`; here, at the
edge, it becomes one line on stderr (``error: FILE: what — fix``, options
spelled as options) and an exit code.  Set ``MASSPROPS_DEBUG=1`` to see
tracebacks of unexpected errors.
"""

from __future__ import annotations

import math
import os
import re
import sys

import click

from ..model.errors import MassPropsError, printable

UNIT_CHOICES = ["m", "cm", "mm", "um", "in", "ft"]


# ---------------------------------------------------------------- parameter types

class Number(click.ParamType):
    """A finite float; with ``positive``, > 0; with ``zero_ok`` too, ≥ 0."""

    name = "number"

    def __init__(self, *, positive=False, zero_ok=False):
        self.positive, self.zero_ok = positive, zero_ok

    def convert(self, value, param, ctx):
        if isinstance(value, float) and math.isfinite(value):
            number = value
        else:
            try:
                number = float(value)
            except (TypeError, ValueError):
                self.fail(f"{value!r} is not a number", param, ctx)
            if not math.isfinite(number):
                self.fail(f"{value!r} is not a finite number", param, ctx)
        if self.positive and not (number > 0 or (self.zero_ok and number == 0)):
            self.fail(f"must be {'≥ 0' if self.zero_ok else 'positive'}, got {value}", param, ctx)
        return number


FINITE = Number()
POSITIVE = Number(positive=True)
NON_NEGATIVE = Number(positive=True, zero_ok=True)


class Point(click.ParamType):
    """Three finite numbers, ``X,Y,Z`` or ``X Y Z`` (see :class:`Command`, which joins the second form)."""

    name = "X,Y,Z"

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):
            return value
        parts = str(value).replace(",", " ").split()
        if len(parts) != 3:
            self.fail(f"expected three numbers, X,Y,Z or X Y Z, got {value!r}", param, ctx)
        return tuple(FINITE.convert(part, param, ctx) for part in parts)


def _number_like(token):
    try:
        float(token)
    except ValueError:
        return False
    return True


class Command(click.Command):
    """A command whose three-number options (type :class:`Point`) take ``X,Y,Z`` or ``X Y Z`` alike.

    Before click parses, ``--about 1 2 3`` becomes ``--about 1,2,3``: an
    option of type Point followed by three numbers takes all three.
    """

    def parse_args(self, ctx, args):
        vectors = {opt for p in self.params if isinstance(p.type, Point) for opt in p.opts}
        joined, i = [], 0
        while i < len(args):
            token = args[i]
            joined.append(token)
            i += 1
            if token == "--":
                joined.extend(args[i:])
                break
            if token in vectors and i + 3 <= len(args) and all(_number_like(t) for t in args[i:i + 3]):
                joined.append(",".join(args[i:i + 3]))
                i += 3
        return super().parse_args(ctx, joined)


class Rotation(click.ParamType):
    """A rotation given as text (see :meth:`massprops.model.frames.Pose.parse`): its proper rotation matrix."""

    name = "ROTATION"

    def convert(self, value, param, ctx):
        if not isinstance(value, str):
            return value
        from ..model.frames import Pose
        try:
            return Pose.parse(value).rotation
        except MassPropsError as exc:
            self.fail(exc.render("cli"), param, ctx)


class Bytes(click.ParamType):
    """A size in bytes: ``1000000``, ``500k``, ``200MB``, ``2G`` (powers of 1000)."""

    name = "BYTES"
    _FORM = r"\s*(\d+(?:\.\d+)?)\s*([kKMGT]?)B?\s*"      # compiled by re on first use, not at start-up
    _SCALE = {"": 1, "k": 10 ** 3, "K": 10 ** 3, "M": 10 ** 6, "G": 10 ** 9, "T": 10 ** 12}

    def convert(self, value, param, ctx):
        if isinstance(value, int):
            return value
        match = re.fullmatch(self._FORM, str(value))
        size = int(float(match.group(1)) * self._SCALE[match.group(2)]) if match else 0
        if size <= 0:
            self.fail(f"expected a positive size such as 500MB or 2G, got {value!r}", param, ctx)
        return size


# ---------------------------------------------------------------- shared options

def material_options(f):
    """--density / --mass / --unit."""
    f = click.option("--unit", type=click.Choice(UNIT_CHOICES),
                     help="Declare the mesh's length unit; density is then kg/m³ and all outputs SI.  Default: "
                          "the unit the file declares (3MF, DAE), else none (mesh units).")(f)
    f = click.option("--mass", "total_mass", type=POSITIVE, help="Total mass (density derived).")(f)
    f = click.option("--density", type=POSITIVE,
                     help="Density [mass/length³; kg/m³ with a unit].  Default 1, so mass = volume (robot "
                          "commands default to 1000 kg/m³).")(f)
    return f


def pose_options(f):
    """--rotate / --translate, giving the part's pose (x = A x' + t)."""
    f = click.option("--translate", type=Point(), default=None, metavar="X,Y,Z",
                     help="Translation t of the pose, in mesh units (X,Y,Z or X Y Z).  Default 0,0,0.")(f)
    f = click.option("--rotate", type=Rotation(), metavar="ROTATION",
                     help="Rotation A of the pose: quat:w,x,y,z | euler:SEQ:a,b,c (degrees; xyz extrinsic, "
                          "XYZ intrinsic) | matrix:9 numbers row-major.  Default: none (the identity).")(f)
    return f


def about_option(f):
    """--about X,Y,Z (repeatable): also the inertia about these global points."""
    return click.option("--about", "about", multiple=True, type=Point(), metavar="X,Y,Z",
                        help="Also report the inertia about this global point (repeatable; X,Y,Z or X Y Z).")(f)


def _density_map(ctx, param, text):
    if text is None:
        return None                 # before the import: plain `props` stays light at start-up
    from ..mesh.volume import parse_density_map
    try:
        return parse_density_map(text)
    except MassPropsError as exc:
        raise click.BadParameter(exc.render("cli"), ctx, param) from None


def cell_options(f):
    """--density-field / --density-map (volume meshes) and --shell (surfaces as sheets)."""
    f = click.option("--shell", type=POSITIVE, metavar="THICKNESS",
                     help="Treat the surface (open or closed) as a sheet of this thickness in mesh units: "
                          "area density = density × THICKNESS.")(f)
    f = click.option("--density-map", metavar="GROUP=VALUE,...", callback=_density_map,
                     help="Volume meshes: density per physical group / cell set (--density fills the other cells).")(f)
    f = click.option("--density-field", metavar="NAME",
                     help="Volume meshes: per-cell density from the cell-data array NAME.")(f)
    return f


def self_intersection_option(f):
    """--self-intersection / --no-self-intersection (default: checked, at every size)."""
    return click.option("--self-intersection/--no-self-intersection", "self_intersection", default=None,
                        help="Find faces that cross and integrate the region the surface encloses (the default, at "
                             "every size); --no-self-intersection integrates a one-shell surface's signed volume as "
                             "it is.  checks.self_intersection says none, resolved or not checked.")(f)


def repair_option(f):
    return click.option("--repair", is_flag=True,
                        help="Fix winding, remove duplicate faces, close holes, turn inside-out shells outward, and say "
                             "what changed.")(f)


def unpack_option(f):
    """--max-unpacked: the size an archive (3MF) may unpack to."""
    return click.option("--max-unpacked", type=Bytes(), default=None, metavar="BYTES",
                        help="Largest size an archive such as 3MF may unpack to (default: 100 times the file's "
                             "size, at least 64 MiB), e.g. 2G for a trusted large file.")(f)


def graph_limit_options(f):
    """--max-instances / --max-depth: how many meshes an instance graph (3MF, COLLADA) may place, how deep."""
    f = click.option("--max-depth", type=click.IntRange(min=1), default=None, metavar="N",
                     help="Deepest nesting of 3MF components or COLLADA nodes read (default 100).")(f)
    f = click.option("--max-instances", type=click.IntRange(min=1), default=None, metavar="N",
                     help="Most meshes a 3MF or COLLADA file may place through its components or instanced nodes "
                          "(default 100000), e.g. 1000000 for a trusted large assembly.")(f)
    return f


def digits_option(f):
    """--digits: significant digits of the text output (default: those the error bound makes significant)."""
    return click.option("--digits", type=click.IntRange(1, 17), default=None, metavar="N",
                        help="Text output: N significant digits for every value (default: the digits the "
                             "error bound leaves significant).  JSON and CSV keep full precision.")(f)


def format_option(*choices):
    def decorate(f):
        return click.option("--format", "output_format", type=click.Choice(list(choices)), default=choices[0],
                            show_default=True, help="Output format.")(f)
    return decorate


def _only(ctx, param, text):
    from ..compute import QUANTITIES
    if text is None:
        return None
    wanted = [w.strip() for w in text.split(",") if w.strip()]
    unknown = [w for w in wanted if w not in QUANTITIES]
    if unknown or not wanted:
        shown = repr(unknown[0]) if unknown else "nothing"
        raise click.BadParameter(f"unknown quantity {shown}; pick from {', '.join(QUANTITIES)}", ctx, param)
    return frozenset(wanted)


def only_option(help_text):
    return click.option("--only", "only", metavar="LIST", callback=_only, help=help_text)


# Options that cannot be given together, by parameter name, with why (checked before any file is read).
CONFLICTS = (
    ("density", "total_mass", "the density is derived from the mass"),
    ("shell", "density_field", "--density-field is for volume meshes, --shell for surfaces"),
    ("shell", "density_map", "--density-map is for volume meshes, --shell for surfaces"),
    ("density_field", "density_map", "each gives every cell's density"),
    ("density", "density_field", "the field gives every cell's density"),
    ("rtol", "steps", "a fixed step count or a tolerance"),
    ("compare_methods", "torque",
     "--compare-methods measures errors against the torque-free closed form: drop --torque"),
    ("compare_methods", "out_csv", "--compare-methods prints a table, not one time series"),
    ("links_glob", "all_links", "--all writes every link"),
    ("output", "in_place", "--in-place writes MODEL itself"),
    ("expand", "in_place", "--expand writes a new URDF"),
    ("timeout", "scheduler", "a Dask run is bounded by its cluster's own settings"),
    ("check_trimesh", "shell", "--check-trimesh compares solids bounded by surfaces, not sheets"),
    ("check_trimesh", "density_field", "--check-trimesh compares surfaces, not volume meshes"),
    ("check_trimesh", "density_map", "--check-trimesh compares surfaces, not volume meshes"),
    ("compare_methods", "method", "--compare-methods runs every method"),
    ("compare_methods", "rtol", "--compare-methods runs every method at several tolerances"),
    ("compare_methods", "steps", "--compare-methods runs every method at several tolerances"),
    ("compare_methods", "torque_frame", "--compare-methods is torque-free"),
    ("declared_only", "density", "--declared-only reads no geometry"),
    ("declared_only", "mass_policy", "--declared-only reads no geometry"),
    ("declared_only", "on_open", "--declared-only reads no geometry"),
    ("declared_only", "repair", "--declared-only reads no geometry"),
)
# An option that applies only with another, or with some of its values: (option, other, values or None, why).
NEEDS = (
    ("torque_frame", "torque", None, "the frame of the torque"),
    ("digits", "output_format", ("text",), "JSON and CSV keep full precision"),
    ("check_trimesh", "output_format", ("text", "json", "jsonl"), "the CSV columns have no room for it"),
)


def _given(ctx, name):
    from click.core import ParameterSource
    value = ctx.params.get(name)
    return (ctx.get_parameter_source(name) in (ParameterSource.COMMANDLINE, ParameterSource.ENVIRONMENT)
            and value not in (None, False, ()))


def _spelling(ctx, name):
    param = next(p for p in ctx.command.params if p.name == name)
    return max(param.opts, key=len)


def refuse_conflicts(ctx=None):
    """A usage error (exit 2) for the first pair of :data:`CONFLICTS` both given, before any file is read."""
    ctx = ctx or click.get_current_context()
    for first, second, why in CONFLICTS:
        if first in ctx.params and second in ctx.params and _given(ctx, first) and _given(ctx, second):
            a, b = _spelling(ctx, first), _spelling(ctx, second)
            raise click.UsageError(f"give {a} or {b}, not both" + (f" ({why})" if why else ""), ctx)
    for name, other, values, why in NEEDS:
        if name in ctx.params and other in ctx.params and _given(ctx, name):
            value = ctx.params[other]
            if values is None and not _given(ctx, other):
                raise click.UsageError(f"{_spelling(ctx, name)} needs {_spelling(ctx, other)} ({why})", ctx)
            if values is not None and value not in values:
                raise click.UsageError(f"{_spelling(ctx, name)} applies to {_spelling(ctx, other)} "
                                       f"{' or '.join(values)}, not {value} ({why})", ctx)


def pose_from_options(rotation, translate):
    """The Pose that ``--rotate`` (a checked rotation matrix or None) and ``--translate`` describe."""
    import numpy as np

    from ..model.frames import Pose
    translation = np.asarray(translate or (0.0, 0.0, 0.0), dtype=float)
    return Pose(translation=translation) if rotation is None else Pose(rotation, translation)


# ---------------------------------------------------------------- output and the error edge

def echo(text="", *, nl=True):
    """Write ``text`` to stdout; file names with undecodable bytes are written as those bytes."""
    stream = sys.stdout
    data = (text + ("\n" if nl else "")).encode(getattr(stream, "encoding", None) or "utf-8", "surrogateescape")
    buffer = getattr(stream, "buffer", None)
    if buffer is None:
        click.echo(data.decode("utf-8", "replace"), nl=False)
        return
    stream.flush()
    buffer.write(data)
    buffer.flush()


def echo_error(message):
    click.echo(f"error: {message}", err=True)


def warn(message):
    """One warning line on stderr, options spelled as options."""
    from ..model.errors import render_options
    click.echo(f"warning: {render_options(message, 'cli')}", err=True)


def warn_units(density, unit, declared, *, mixed=False):
    """Warn (once per run) of a density that looks like a unit mistake, and of a report mixing units."""
    from ..model.density_units import density_warnings, mixed_units_warning
    messages = density_warnings(density, unit, declared)
    if mixed:
        messages.append(mixed_units_warning(unit, declared))
    for message in messages:
        if message:
            warn(message)


def render(exc, path=None):
    """The one line of a MassPropsError, options spelled as command-line options."""
    return (exc if exc.path or path is None else exc.with_path(path)).render("cli")


def guarded(fn, *args, path=None, **kwargs):
    """Run ``fn``; on failure print the one-line error and return None.

    A :class:`MassPropsError` prints its own line; anything else is a bug in
    massprops and says so (with a traceback only under ``MASSPROPS_DEBUG``).
    """
    try:
        return fn(*args, **kwargs)
    except MassPropsError as exc:
        echo_error(render(exc, path))
    except MemoryError:
        echo_error(f"{path}: not enough memory to process this mesh — free memory or split the file")
    except Exception as exc:  # noqa: BLE001 - the edge: never a traceback
        if os.environ.get("MASSPROPS_DEBUG"):
            raise
        where = f"{path}: " if path else ""
        echo_error(f"{where}internal error ({type(exc).__name__}: {printable(exc)}) — "
                   "please report it; rerun with MASSPROPS_DEBUG=1 for details")
    return None


def exit_with(failed):
    sys.exit(1 if failed else 0)
