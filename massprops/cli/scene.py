"""``massprops scene SCENE``: mass properties of an assembly (TOML, GLB, glTF or 3MF)."""

from __future__ import annotations

import json
from dataclasses import replace

import click
import numpy as np

from . import options


@click.command()
@click.argument("scene_file", metavar="SCENE", type=click.Path(dir_okay=False))
@click.option("--density", type=float,
              help="Density for parts that give none (default 1; kg/m³ with a unit).")
@click.option("--unit", type=click.Choice(options.UNIT_CHOICES),
              help="The meshes' length unit (overrides the scene's [report] unit); outputs are then SI.")
@click.option("--only", "only", metavar="LIST",
              help="Comma-separated quantities: volume, mass, surface_area, center_of_mass, inertia, principal "
                   "for every part and the total (overrides the scene's [report] quantities and principal).")
@options.repair_option
@options.format_option("text", "json", "csv")
def scene(scene_file, density, unit, only, repair, output_format):
    """Mass properties of each part of SCENE and of the whole assembly.

    SCENE is a .toml assembly (parts with meshes, densities and poses; frames;
    a [report] section) or a .glb/.gltf/.3mf scene graph, where every node with
    geometry is a part.  A mesh used by several parts is integrated once.  A
    part that cannot be computed stops the run with exit 1.
    """
    from .. import scene as assembly

    wanted = options.parse_only(only)
    loaded = options.guarded(assembly.load_scene, scene_file, density=density, unit=unit, path=scene_file)
    if loaded is not None and wanted is not None:
        principal = frozenset({"total", "parts"}) if "principal" in wanted else frozenset()
        loaded = replace(loaded, report=replace(loaded.report, quantities=frozenset(wanted - {"principal"}),
                                                principal=principal))
    result = loaded and options.guarded(assembly.compute_scene, loaded, repair=repair, path=scene_file)
    if result is None:
        options.exit_with(1)
    obj = scene_dict(result)
    if output_format == "json":
        click.echo(json.dumps(obj, indent=2, allow_nan=False, default=_plain))
    elif output_format == "csv":
        from .. import report
        rows = [report.csv_row(dict(o, file=f"{obj['scene']}#{o['name']}")) for o in _blocks(obj)]
        click.echo(report.to_csv(rows), nl=False)
    else:
        click.echo(scene_text(obj))
    options.exit_with(0)


def _plain(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} as JSON")


def _blocks(obj):
    return obj["parts"] + ([obj["total"]] if "total" in obj else [])


def scene_dict(result):
    """The JSON object of a scene: ``scene``, ``parts``, ``total``, ``frames``, ``stats``.

    Part and total objects carry the same keys as ``props``; the total's local
    frame is the global frame (identity pose), so its ``center_of_mass`` is
    global and ``inertia_com`` is in global axes.
    """
    from ..compute import Result
    from ..report import result_dict

    scene, request = result.scene, result.scene.report
    poses = result.frames
    seen, parts = set(), []
    if request.parts:
        wanted = request.wanted("parts")
        for part, props in zip(scene.placed_parts(), result.parts):
            record = result.records[part.mesh]
            first = part.mesh not in seen
            seen.add(part.mesh)
            one = Result(record.key, props, record.triangles, record.checks, record.warnings if first else (),
                         record.elapsed_s if first else 0.0)
            parts.append(_with_frames({"name": part.name, **result_dict(one, only=wanted)}, props, poses,
                                      request))
    obj = {"scene": scene.path, "unit": request.unit, "parts": parts}
    if result.total is not None:
        records = result.records.values()
        checks = {"parts": result.stats["instances"], "meshes": len(result.records),
                  "shells": sum(result.records[p.mesh].checks.get("shells", 0) * p.count for p in scene.parts)}
        warnings = tuple(f"{r.key}: {w}" for r in records for w in r.warnings)
        total = Result(scene.path, result.total, sum(result.records[p.mesh].triangles * p.count for p in scene.parts),
                       checks, warnings, result.elapsed_s)
        obj["total"] = _with_frames({"name": "total", **result_dict(total, only=request.wanted("total"))},
                                    result.total, poses, request)
    obj["frames"] = {name: {"rotation": poses[name].rotation, "translation": poses[name].translation,
                            "part": frame.part} for name, frame in scene.frames.items()}
    obj["stats"] = result.stats
    obj["elapsed_s"] = result.elapsed_s
    return obj


def _with_frames(obj, props, poses, request):
    if request.about and "inertia" in request.quantities and props.inertia_com is not None:
        obj["inertia_in_frames"] = [{"frame": name, "inertia": props.in_frame(poses[name])}
                                    for name in request.about]
    return obj


def scene_text(obj):
    """Readable text: one block per part, then the total and the bookkeeping."""
    from ..report import to_text
    blocks = []
    for block in _blocks(obj):
        lines = [f"{'part ' + block['name'] if block['name'] != 'total' else 'total of ' + obj['scene']}",
                 to_text(block)]
        for entry in block.get("inertia_in_frames", []):
            for i, row in enumerate(np.asarray(entry["inertia"]).tolist()):
                label = f"in frame {entry['frame']}" if i == 0 else ""
                lines.append(f"  {label:<22} [" + ", ".join(f"{x: .15g}" for x in row) + "]")
        blocks.append("\n".join(lines))
    stats = obj["stats"]
    blocks.append(f"{stats['instances']} parts, {stats['meshes_integrated']} meshes integrated "
                  f"(moments up to order {stats['moment_order']}), "
                  f"{stats['principal_decompositions']} principal decompositions")
    return "\n\n".join(blocks)
