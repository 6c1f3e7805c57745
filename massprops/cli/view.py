"""``massprops view FILE... -o OUT.html|OUT.png``: the part with its centre of mass and inertia drawn."""

from __future__ import annotations

import os

import click

from . import options


def _output(ctx, param, value):
    from ..view import SUFFIXES
    if os.path.splitext(value)[1].lower() not in SUFFIXES:
        raise click.BadParameter(f"{value!r}: name it .html (a self-contained web page) or .png (an image)",
                                 ctx, param)
    return value


@click.command(cls=options.Command)
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), callback=_output,
              metavar="OUT.html|OUT.png", help="Write a self-contained web page (.html) or an image (.png).")
@click.option("--glyph", type=click.Choice(["box", "ellipsoid"]), default="box", show_default=True,
              help="Draw the equivalent uniform box or ellipsoid (same mass and principal moments).")
@click.option("--max-triangles", type=click.IntRange(min=100), default=None, metavar="N",
              help="Draw at most N triangles per part (sampled; the numbers always use every triangle) "
                   "[default: 200000].")
@options.material_options
@options.pose_options
@options.about_option
@options.only_option("Comma-separated quantities the side panel lists: volume, mass, surface_area, center_of_mass, "
                     "inertia, principal.  Default: all.  The drawing always shows the centre of mass, the "
                     "principal axes and the equivalent box, so all are computed.")
@options.cell_options
@options.repair_option
@options.self_intersection_option
@options.unpack_option
@options.graph_limit_options
def view(files, output, glyph, max_triangles, density, total_mass, unit, rotate, translate, about, only, density_field,
         density_map, shell, repair, self_intersection, max_unpacked, max_instances, max_depth):
    """Draw each FILE as it was integrated: its centre of mass, principal axes and equivalent inertia box.

    The principal axes are drawn from the centre of mass with lengths by
    moment and labelled with their moments; the equivalent uniform box (or,
    with --glyph ellipsoid, the ellipsoid) has the part's mass and principal
    moments.  A side panel gives the numbers with their bounds (--only: some
    of them).  The output's kind follows -o's suffix (no --format).  The .html
    page embeds its viewer (plotly, the `view` extra) and opens offline; the
    .png (matplotlib, the `plot` extra) shows front, top and side views.
    Options change the result as they do for `props`.  Exit 1 if a file failed.
    """
    options.refuse_conflicts()
    from .. import report
    from ..api import mass_properties
    from ..io import read
    from ..view import write_picture
    from ..view.picture import DISPLAY_TRIANGLES, display_triangles, part_picture

    pose = options.pose_from_options(rotate, translate)
    parts, failed = [], 0

    def one(path):
        result = mass_properties(path, density=density, mass=total_mass, unit=unit, pose=pose, repair=repair,
                                 density_field=density_field, density_map=density_map, shell=shell,
                                 max_unpacked=max_unpacked, max_instances=max_instances, max_depth=max_depth,
                                 self_intersection=self_intersection)
        vertices, faces = display_triangles(read(path, max_unpacked=max_unpacked, max_instances=max_instances,
                                                 max_depth=max_depth))
        return result, report.result_dict(result, about=about, only=only), vertices, faces

    for path in files:
        part = options.guarded(one, path, path=path)
        if part is None:
            failed += 1
        else:
            parts.append(part)
    if parts:
        picture = part_picture(parts, glyph=glyph, limit=max_triangles or DISPLAY_TRIANGLES, about=about)
        if options.guarded(write_picture, picture, output, path=output) is None:
            failed += 1
        else:
            click.echo(f"wrote {output}", err=True)
    options.exit_with(failed)
