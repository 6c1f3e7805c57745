"""``massprops compare FILE...``: cross-check against trimesh on the same triangles, raw and fair.

``massprops check`` is the same command under its old name, hidden from the
command list and saying so.
"""

from __future__ import annotations

import click

from . import options

_LABELS = {"volume": "volume", "center_of_mass": "center of mass", "inertia_com": "inertia about COM",
           "principal_moments": "principal moments"}


@click.command()
@click.argument("files", nargs=-1, required=True, type=click.Path())
@click.option("--rtol", type=options.NON_NEGATIVE, default=1e-9, show_default=True,
              help="Largest relative difference allowed between massprops and fair trimesh.")
@options.format_option("text", "json", "jsonl")
def compare(files, rtol, output_format):
    """Compare massprops with trimesh on the same triangles of each FILE.

    Two trimesh runs: raw, as a trimesh user gets it (integrals about the
    origin), and fair, on the mesh shifted exactly to near its own
    bounding-box centre.  Prints the relative difference per quantity and,
    when raw and fair disagree, why.  Exit 1 if a fair difference exceeds
    --rtol or a file cannot be read (a mesh massprops refuses is not
    compared: fix it first, see `massprops props --repair`).
    """
    from .. import report

    objects, failed = [], 0
    for path in files:
        obj = options.guarded(_one, path, rtol, path=path)
        if obj is None:
            failed += 1
            continue
        failed += not obj["within_tolerance"]
        objects.append(obj)
        if output_format == "text":
            click.echo(_text(obj, rtol))
    if output_format == "json":
        click.echo(report.to_json(objects))
    elif output_format == "jsonl":
        click.echo(report.to_jsonl(objects), nl=False)
    options.exit_with(failed)


def _deprecated(**kwargs):
    click.echo("note: `massprops check` is now `massprops compare` (`check` will be removed)", err=True)
    return compare.callback(**kwargs)


check = click.Command("check", params=compare.params, callback=_deprecated, hidden=True,
                      context_settings=compare.context_settings,
                      help="Deprecated name of `massprops compare` (it will be removed): " + compare.help,
                      short_help="Deprecated: use `massprops compare`.")


def _one(path, rtol):
    from ..api import mass_properties
    from ..validation.crosscheck import explanation, trimesh_comparison

    result = mass_properties(path)
    comparison = trimesh_comparison(path, result)
    fair = max(comparison["relative_difference"].values())
    return {"file": path, "triangles": result.triangles, **comparison, "explanation": explanation(comparison),
            "within_tolerance": fair <= rtol, "rtol": rtol, "warnings": list(result.warnings)}


def _text(obj, rtol):
    lines = [f"{obj['file']}  ({obj['triangles']} triangles, size {obj['size']:.3g}, "
             f"{obj['offset']:.3g} from the origin)",
             f"  {'relative difference':<20} {'raw trimesh':>12} {'fair trimesh':>13}"]
    for key, label in _LABELS.items():
        lines.append(f"  {label:<20} {obj['relative_difference_raw'][key]:>12.2e} "
                     f"{obj['relative_difference'][key]:>13.2e}")
    lines += [f"  warning: {w}" for w in obj["warnings"]]
    if obj["explanation"]:
        lines.append(f"  why raw differs: {obj['explanation']}")
    fair = max(obj["relative_difference"].values())
    lines.append(f"  {'ok' if obj['within_tolerance'] else 'FAIL'}: fair difference {fair:.2e} "
                 f"{'<=' if obj['within_tolerance'] else '>'} tolerance {rtol:g}")
    return "\n".join(lines) + "\n"
