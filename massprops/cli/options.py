"""Options shared by several subcommands, as named decorators, and the error edge.

Library code raises :class:`massprops.errors.MassPropsError`; here, at the
edge, it becomes one line on stderr (``error: FILE: what — fix``) and an exit
code.  Set ``MASSPROPS_DEBUG=1`` to see tracebacks of unexpected errors.
"""

from __future__ import annotations

import os
import sys

import click

from ..errors import MassPropsError

UNIT_CHOICES = ["m", "cm", "mm", "um", "in", "ft"]


def _pose_from(rotate, translate):
    from ..frames import Pose
    translation = translate or (0.0, 0.0, 0.0)
    if rotate:
        return Pose.parse(rotate, translation=translation)
    return Pose(translation=__import__("numpy").asarray(translation, dtype=float))


def material_options(f):
    """--density / --mass / --unit."""
    f = click.option("--unit", type=click.Choice(UNIT_CHOICES),
                     help="Declare the mesh's length unit; density is then kg/m³ and all outputs SI.")(f)
    f = click.option("--mass", "total_mass", type=float, help="Total mass (density derived).")(f)
    f = click.option("--density", type=float, help="Density [mass/length³]; default 1, so mass = volume.")(f)
    return f


def pose_options(f):
    """--rotate / --translate, giving the part's pose (x = A x' + t)."""
    f = click.option("--translate", type=float, nargs=3, default=None, metavar="X Y Z",
                     help="Translation t of the pose, in mesh units.")(f)
    f = click.option("--rotate", metavar="ROTATION",
                     help="Rotation A of the pose: quat:w,x,y,z | euler:SEQ:a,b,c (degrees; xyz extrinsic, "
                          "XYZ intrinsic) | matrix:9 numbers row-major.")(f)
    return f


def _density_map(ctx, param, text):
    if text is None:
        return None                 # before the import: plain `props` stays light at start-up
    from ..errors import OptionError
    from ..mesh.volume import parse_density_map
    try:
        return parse_density_map(text)
    except OptionError as exc:
        raise click.BadParameter(str(exc), param_hint="--density-map") from None


def cell_options(f):
    """--density-field / --density-map (volume meshes) and --shell (surfaces as sheets)."""
    f = click.option("--shell", type=float, metavar="THICKNESS",
                     help="Treat the surface (open or closed) as a sheet of this thickness in mesh units: "
                          "area density = density × THICKNESS.")(f)
    f = click.option("--density-map", metavar="GROUP=VALUE,...", callback=_density_map,
                     help="Volume meshes: density per physical group / cell set (--density fills the other cells).")(f)
    f = click.option("--density-field", metavar="NAME",
                     help="Volume meshes: per-cell density from the cell-data array NAME.")(f)
    return f


def self_intersection_option(f):
    """--self-intersection / --no-self-intersection (default: by face count)."""
    from ..mesh.solid import SELF_INTERSECTION_UP_TO
    return click.option("--self-intersection/--no-self-intersection", "self_intersection", default=None,
                        help=f"Check (or not) that no shell crosses itself; by default meshes of up to "
                             f"{SELF_INTERSECTION_UP_TO:,} faces are checked.  checks.self_intersection says "
                             "none, found or not checked.")(f)


def repair_option(f):
    return click.option("--repair", is_flag=True,
                        help="Fix winding, remove duplicate faces, close holes, turn inside-out shells outward, and say "
                             "what changed.")(f)


def format_option(*choices):
    def decorate(f):
        return click.option("--format", "output_format", type=click.Choice(list(choices)), default=choices[0],
                            show_default=True, help="Output format.")(f)
    return decorate


def parse_only(text):
    """The set of quantities named by ``--only a,b,c`` (None when not given); unknown ones are usage errors."""
    from ..compute import QUANTITIES
    if text is None:
        return None
    wanted = [w.strip() for w in text.split(",") if w.strip()]
    unknown = [w for w in wanted if w not in QUANTITIES]
    if unknown:
        raise click.BadParameter(f"unknown quantity {unknown[0]!r}; pick from {', '.join(QUANTITIES)}",
                                 param_hint="--only")
    return set(wanted)


def pose_from_options(rotate, translate):
    """Build the Pose the options describe (raises OptionError)."""
    return _pose_from(rotate, translate)


def echo_error(message):
    click.echo(f"error: {message}", err=True)


def guarded(fn, *args, path=None, **kwargs):
    """Run ``fn``; on failure print the one-line error and return None.

    A :class:`MassPropsError` prints its own line; anything else is a bug in
    massprops and says so (with a traceback only under ``MASSPROPS_DEBUG``).
    """
    try:
        return fn(*args, **kwargs)
    except MassPropsError as exc:
        echo_error(str(exc) if exc.path or path is None else str(exc.with_path(path)))
    except MemoryError:
        echo_error(f"{path}: not enough memory to process this mesh — free memory or split the file")
    except Exception as exc:  # noqa: BLE001 - the edge: never a traceback
        if os.environ.get("MASSPROPS_DEBUG"):
            raise
        where = f"{path}: " if path else ""
        echo_error(f"{where}internal error ({type(exc).__name__}: {exc}) — "
                   "please report it; rerun with MASSPROPS_DEBUG=1 for details")
    return None


def exit_with(failed):
    sys.exit(1 if failed else 0)
