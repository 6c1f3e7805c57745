"""``massprops props FILE...``: mass properties of each closed mesh."""

from __future__ import annotations

import click

from . import options


@click.command(cls=options.Command)
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=True))
@options.material_options
@options.pose_options
@options.about_option
@click.option("--omega", type=options.Point(), default=None, metavar="WX,WY,WZ",
              help="Angular velocity in local axes [rad/s] (WX,WY,WZ or WX WY WZ): adds angular momentum and "
                   "kinetic energy.")
@options.only_option("Comma-separated quantities: volume, mass, surface_area, center_of_mass, inertia, principal.")
@click.option("--check-trimesh", is_flag=True, help="Also compute with trimesh and report the relative differences.")
@options.cell_options
@options.repair_option
@options.self_intersection_option
@options.unpack_option
@options.graph_limit_options
@options.digits_option
@options.format_option("text", "json", "jsonl", "csv")
def props(files, density, total_mass, unit, rotate, translate, about, omega, only, check_trimesh, density_field,
          density_map, shell, repair, self_intersection, max_unpacked, max_instances, max_depth, digits,
          output_format):
    """Mass properties of each closed mesh FILE (STL, OBJ, PLY, OFF, GLB; volume meshes via meshio).

    Volume, mass, center of mass, inertia about the center of mass, principal
    moments and axes, each with an absolute error bound.  Text output shows the
    digits the bound leaves significant (--digits N for more); JSON and CSV keep
    full precision.  Exit 1 if any file failed; the others are still reported.
    """
    options.refuse_conflicts()
    from .. import report
    from ..api import mass_properties

    wanted = None if only is None else set(only) | ({"inertia"} if omega is not None else set())
    pose = options.pose_from_options(rotate, translate)
    objects, failed, declared = [], 0, []

    def one(path):
        result = mass_properties(path, density=density, mass=total_mass, unit=unit, pose=pose, repair=repair,
                                 only=wanted, density_field=density_field, density_map=density_map, shell=shell,
                                 max_unpacked=max_unpacked, max_instances=max_instances, max_depth=max_depth,
                                 self_intersection=self_intersection)
        declared.append(result.properties.unit)
        extra = None
        if check_trimesh:
            from ..validation.crosscheck import trimesh_comparison
            extra = {"trimesh": trimesh_comparison(path, result)}
        return report.result_dict(result, omega=omega, about=about, only=wanted, extra=extra)

    for path in files:
        obj = options.guarded(one, path, path=path)
        if obj is None:
            failed += 1
            continue
        objects.append(obj)
        if output_format == "text":
            options.echo(report.to_text(obj, digits=digits))
            options.echo("")
    if output_format == "json":
        options.echo(report.to_json(objects))
    elif output_format == "jsonl":
        options.echo(report.to_jsonl(objects), nl=False)
    elif output_format == "csv":
        options.echo(report.to_csv([report.csv_row(o) for o in objects]), nl=False)
    if declared:
        options.warn_units(density, unit, declared, mixed=True)
    options.exit_with(failed)
