"""``massprops accuracy [--out DIR] [--quick]``: error against run time, ours and trimesh's."""

from __future__ import annotations

import os

import click

from . import options


def _write(directory, name, text):
    path = os.path.join(directory, name)
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(text)
    return path


def _report(tessellation, extreme, quick):
    from ..validation import accuracy as acc
    levels = "100 to 10k" if quick else "100 to 1M"
    return (f"## Smooth solids, {levels} triangles\n\n"
            "Largest relative error over volume, center of mass and inertia about the COM; "
            "run times in seconds (best of 3 below 100k triangles).\n\n"
            + acc.markdown_table(tessellation, "tessellation")
            + "\n## Extreme cases, against exact rational arithmetic on the same triangles\n\n"
            + acc.markdown_table(extreme, "extreme"))


@click.command()
@click.option("--out", "out_dir", default="accuracy", show_default=True, type=click.Path(file_okay=False),
              help="Directory for accuracy.md, tessellation.csv, extreme.csv and accuracy.png.")
@click.option("--quick", is_flag=True, help="Up to 10k triangles (seconds) instead of 1M (a few minutes).")
@click.option("--no-plot", is_flag=True, help="Skip the PNG (no matplotlib needed).")
def accuracy(out_dir, quick, no_plot):
    """Error against run time on analytic solids and extreme cases, massprops and trimesh.

    Smooth solids (sphere, cylinder, cone, torus, ellipsoid) at increasing
    tessellation, compared with their smooth analytic values and with the
    exact values of the polyhedron; then offsets up to 1e8 part sizes, scales
    1e-9 to 1e9, plates and needles of aspect 1e-6, float32 input and a large
    mesh, against exact rational arithmetic.  Writes a Markdown report, CSVs
    and a log-log plot (the ``plot`` extra).  Exit 1 if massprops's reported
    error bound failed to cover its true error on any row.
    """
    from ..validation import accuracy as acc

    def progress(row):
        click.echo(f"  {row['case']:<34} {row['triangles']:>8} triangles", err=True)

    os.makedirs(out_dir, exist_ok=True)
    click.echo("smooth solids:", err=True)
    tessellation = acc.tessellation_rows(quick=quick, progress=progress)
    click.echo("extreme cases:", err=True)
    extreme = acc.extreme_rows(quick=quick, progress=progress)
    report = _report(tessellation, extreme, quick)
    written = [_write(out_dir, "accuracy.md", report),
               _write(out_dir, "tessellation.csv", acc.csv_text(tessellation)),
               _write(out_dir, "extreme.csv", acc.csv_text(extreme))]
    click.echo(report)
    failed = 0
    if not no_plot:
        png = os.path.join(out_dir, "accuracy.png")
        if options.guarded(acc.plot, tessellation, png) is None:
            failed += 1
        else:
            written.append(png)
    uncovered = [r["case"] for r in tessellation + extreme if not r["bound_covers"]]
    if uncovered:
        options.echo_error(f"massprops's error bound did not cover its true error on: {', '.join(uncovered)} — "
                           "please report this")
        failed += 1
    click.echo("wrote " + ", ".join(written), err=True)
    options.exit_with(failed)
