"""``massprops props FILE...``: mass properties of each closed mesh."""

from __future__ import annotations

import click

from . import options


def _parse_point(text):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3:
        raise click.BadParameter(f"expected X,Y,Z, got {text!r}", param_hint="--about")
    return values


@click.command()
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=True))
@options.material_options
@options.pose_options
@click.option("--about", "about", multiple=True, metavar="X,Y,Z",
              help="Also report the inertia about this global point (repeatable).")
@click.option("--omega", type=float, nargs=3, default=None, metavar="WX WY WZ",
              help="Angular velocity in local axes [rad/s]: adds angular momentum and kinetic energy.")
@click.option("--only", "only", metavar="LIST",
              help="Comma-separated quantities: volume, mass, surface_area, center_of_mass, inertia, principal.")
@click.option("--check-trimesh", is_flag=True, help="Also compute with trimesh and report the relative differences.")
@options.cell_options
@options.repair_option
@options.self_intersection_option
@options.format_option("text", "json", "csv")
def props(files, density, total_mass, unit, rotate, translate, about, omega, only, check_trimesh, density_field,
          density_map, shell, repair, self_intersection, output_format):
    """Mass properties of each closed mesh FILE (STL, OBJ, PLY, OFF, GLB; volume meshes via meshio).

    Volume, mass, center of mass, inertia about the center of mass, principal
    moments and axes, each with an absolute error bound.  Exit 1 if any file
    failed; the others are still reported.
    """
    from .. import report
    from ..compute import mass_properties

    about_points = [_parse_point(a) for a in about]
    wanted = options.parse_only(only)
    if omega is not None and wanted is not None:
        wanted |= {"inertia"}
    pose = options.guarded(options.pose_from_options, rotate, translate)
    if pose is None:
        raise SystemExit(1)
    objects, failed = [], 0

    def one(path):
        result = mass_properties(path, density=density, mass=total_mass, unit=unit, pose=pose, repair=repair,
                                 only=wanted, density_field=density_field, density_map=density_map, shell=shell,
                                 self_intersection=self_intersection)
        extra = None
        if check_trimesh:
            from ..validation.crosscheck import trimesh_comparison
            extra = {"trimesh": trimesh_comparison(path, result)}
        return report.result_dict(result, omega=omega, about=about_points, only=wanted, extra=extra)

    for path in files:
        obj = options.guarded(one, path, path=path)
        if obj is None:
            failed += 1
            continue
        objects.append(obj)
        if output_format == "text":
            click.echo(report.to_text(obj))
            click.echo("")
    if output_format == "json":
        click.echo(report.to_json(objects))
    elif output_format == "csv":
        click.echo(report.to_csv([report.csv_row(o) for o in objects]), nl=False)
    options.exit_with(failed)
