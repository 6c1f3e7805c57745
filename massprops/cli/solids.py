"""``massprops solids DIR``: write the analytic reference solids and their exact expected values."""

from __future__ import annotations

import click

from . import options


@click.command()
@click.argument("directory", type=click.Path(file_okay=False))
@click.option("--robots", is_flag=True,
              help="Write small URDF, SDF and MJCF robots built from the solids instead, with expected.json "
                   "(per link: the exact values, and the status and diagnoses `robot check` must give).")
def solids(directory, robots):
    """Write the reference solids into DIRECTORY, each as binary STL and OBJ, with expected.csv.

    expected.csv holds, for every file, the exact polyhedral values of the
    tessellation as written (exact rational arithmetic on the stored
    coordinates: float32 for STL), the smooth analytic values of the ideal
    solid, and the tessellation error between them.  Check massprops (or a
    change) against them with `massprops regress DIRECTORY/expected.csv`.
    """
    if robots:
        return _robots(directory)
    from ..validation.reference_set import write_reference_set

    rows = options.guarded(write_reference_set, directory, path=directory)
    if rows is None:
        raise SystemExit(1)
    width = max(len(r["file"]) for r in rows)
    click.echo(f"{'file':<{width}}  {'triangles':>9}  {'volume (exact)':>22}  {'smooth':>20}  "
               f"{'tess. error: volume':>19}  {'inertia':>8}")
    for r in rows:
        click.echo(f"{r['file']:<{width}}  {r['triangles']:>9}  {r['volume']:>22}  "
                   f"{float(r['smooth_volume']):>20.15g}  {float(r['tess_rel_volume']):>19.2e}  "
                   f"{float(r['tess_rel_inertia']):>8.1e}")
    click.echo(f"wrote {len(rows)} files and expected.csv to {directory}")


def _robots(directory):
    from ..validation.robots import write_robots

    expected = options.guarded(write_robots, directory, path=directory)
    if expected is None:
        raise SystemExit(1)
    for fmt in ("urdf", "sdf", "mjcf"):
        if fmt in expected:
            links = expected[fmt]["links"]
            statuses = sorted({entry["status"] for entry in links.values()})
            click.echo(f"{expected[fmt]['model']}: {len(links)} links ({', '.join(statuses)})")
    click.echo(f"wrote the robots and expected.json to {directory}")
