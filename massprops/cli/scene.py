"""``massprops scene SCENE``: mass properties of an assembly (TOML, GLB, glTF, 3MF or COLLADA)."""

from __future__ import annotations

from dataclasses import replace

import click

from . import options


@click.command()
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
@options.format_option("text", "json", "csv")
def scene(scene_file, density, unit, only, repair, max_unpacked, max_instances, max_depth, digits, output_format):
    """Mass properties of each part of SCENE and of the whole assembly.

    SCENE is a .toml assembly (parts with meshes, densities and poses; frames;
    a [report] section) or a .glb/.gltf/.3mf/.dae scene graph, where every node with
    geometry is a part.  A mesh used by several parts is integrated once.  A
    part that cannot be computed stops the run with exit 1.
    """
    from .. import report
    from ..scene import assembly
    from ..scene.report import scene_blocks, scene_dict, scene_text

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
    if output_format == "json":
        options.echo(report.to_json(obj))
    elif output_format == "csv":
        rows = [report.csv_row(dict(o, file=f"{obj['scene']}#{o['name']}")) for o in scene_blocks(obj)]
        options.echo(report.to_csv(rows), nl=False)
    else:
        options.echo(scene_text(obj, digits=digits))
    options.exit_with(0)
