"""A scene result as the JSON object and the text that ``massprops scene`` prints."""

from __future__ import annotations

import numpy as np

from ..result import Result
from .digits import vector_text
from .objects import result_dict
from .text import about_bound, display_bounds, to_text

__all__ = ["scene_dict", "scene_text", "scene_blocks"]


def scene_blocks(obj):
    """The part objects, then the total's (when computed)."""
    return obj["parts"] + ([obj["total"]] if "total" in obj else [])


def scene_dict(result):
    """The JSON object of a scene: ``scene``, ``parts``, ``total``, ``frames``, ``stats``.

    Part and total objects carry the same keys as ``props``; the total's local
    frame is the global frame (identity pose), so its ``center_of_mass`` is
    global and ``inertia_com`` is in global axes.
    """
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


def scene_text(obj, *, digits=None):
    """Readable text: one block per part, then the total and the bookkeeping (digits as in :func:`to_text`)."""
    blocks = []
    for block in scene_blocks(obj):
        lines = [f"{'part ' + block['name'] if block['name'] != 'total' else 'total of ' + obj['scene']}",
                 to_text(block, digits=digits)]
        bounds = display_bounds(block)
        for entry in block.get("inertia_in_frames", []):
            origin = obj["frames"].get(entry["frame"], {}).get("translation")
            bound = None if origin is None else about_bound(block, bounds, origin, rotations=2)
            for i, row in enumerate(np.asarray(entry["inertia"]).tolist()):
                label = f"in frame {entry['frame']}" if i == 0 else ""
                lines.append(f"  {label:<22} {vector_text(row, bound, digits)}")
        blocks.append("\n".join(lines))
    stats = obj["stats"]
    blocks.append(f"{stats['instances']} parts, {stats['meshes_integrated']} meshes integrated "
                  f"(moments up to order {stats['moment_order']}), "
                  f"{stats['principal_decompositions']} principal decompositions")
    return "\n\n".join(blocks)
