"""``massprops scene SCENE``: mass properties of an assembly (TOML, GLB, glTF, 3MF or COLLADA)."""

from __future__ import annotations

from dataclasses import replace

import click

from . import options


@click.command(cls=options.Command)
@click.argument("scene_file", metavar="SCENE", type=click.Path(dir_okay=False))
@click.option("--density", type=options.POSITIVE,
              help="Density for parts that give none (default 1; kg/m³ with a unit).")
@click.option("--unit", type=click.Choice(options.UNIT_CHOICES),
              help="The meshes' length unit (overrides the scene's [report] unit); outputs are then SI.")
@options.only_option("Comma-separated quantities: volume, mass, surface_area, center_of_mass, inertia, principal "
                     "for every part and the total (overrides the scene's [report] quantities and principal).")
@options.repair_option
@options.unpack_option
@options.graph_limit_options
@options.digits_option
@options.format_option("text", "json", "jsonl", "csv")
@click.option("--html", "html_path", type=click.Path(dir_okay=False), metavar="SCENE.html",
              help="Also write a self-contained web page: the assembly, each part's centre of mass, the total's "
                   "principal axes and equivalent box (needs plotly, the view extra).")
def scene(scene_file, density, unit, only, repair, max_unpacked, max_instances, max_depth, digits, output_format,
          html_path):
    """Mass properties of each part of SCENE and of the whole assembly.

    SCENE is a .toml assembly (parts with meshes, densities and poses; frames;
    a [report] section) or a .glb/.gltf/.3mf/.dae scene graph, where every node with
    geometry is a part.  A mesh used by several parts is integrated once.  A
    part that cannot be computed stops the run with exit 1.
    """
    options.refuse_conflicts()
    from .. import report
    from ..scene import assembly
    from ..report.scene import scene_blocks, scene_dict, scene_text

    wanted = only
    limits = {"max_unpacked": max_unpacked, "max_instances": max_instances, "max_depth": max_depth}
    loaded = options.guarded(assembly.load_scene, scene_file, density=density, unit=unit, **limits, path=scene_file)
    if loaded is not None and wanted is not None:
        principal = frozenset({"total", "parts"}) if "principal" in wanted else frozenset()
        loaded = replace(loaded, report=replace(loaded.report, quantities=frozenset(wanted - {"principal"}),
                                                principal=principal))
    result = loaded and options.guarded(assembly.compute_scene, loaded, repair=repair, **limits, path=scene_file)
    if result is None:
        options.exit_with(1)
    obj = scene_dict(result)
    options.warn_units(density, unit, [obj.get("unit")])
    if output_format == "json":
        options.echo(report.to_json(obj))
    elif output_format == "jsonl":
        options.echo(report.to_jsonl(dict(o, file=f"{obj['scene']}#{o['name']}") for o in scene_blocks(obj)), nl=False)
    elif output_format == "csv":
        rows = [report.csv_row(dict(o, file=f"{obj['scene']}#{o['name']}")) for o in scene_blocks(obj)]
        options.echo(report.to_csv(rows), nl=False)
    else:
        options.echo(scene_text(obj, digits=digits))
    options.exit_with(bool(html_path) and not _html(loaded, result, obj, html_path, repair, limits))


def _html(loaded, result, obj, html_path, repair, limits):
    """Write the scene's page; the picture needs every part's COM and the total's inertia, computed if not asked."""
    from ..compute import QUANTITIES
    from ..scene import assembly
    from ..report.scene import scene_dict
    from ..view import write_picture
    from ..view.scene import scene_picture
    request = loaded.report
    if not (request.parts and request.total and {"center_of_mass", "inertia"} <= request.quantities
            and "total" in request.principal):
        widened = replace(request, parts=True, total=True, quantities=frozenset(QUANTITIES),
                          principal=request.principal | {"total"})
        result = options.guarded(assembly.compute_scene, replace(loaded, report=widened), repair=repair, **limits,
                                 path=loaded.path)
        if result is None:
            return False
        obj = scene_dict(result)
    picture = options.guarded(scene_picture, result, obj, path=loaded.path)
    if picture is None or options.guarded(write_picture, picture, html_path, path=html_path) is None:
        return False
    click.echo(f"wrote {html_path}", err=True)
    return True
