"""Text, CSV and JUnit renderings of analysed models (the JSON is :func:`massprops.report.objects.to_json` of them)."""

from __future__ import annotations

import os

from ..model.errors import printable
from .digits import bound_text, significant
from .tables import to_csv

__all__ = ["props_text", "check_text", "csv_text", "CSV_COLUMNS", "junit_xml"]

CSV_COLUMNS = ("model,link,status,message,mass,volume,density,cx,cy,cz,Ixx,Iyy,Izz,Ixy,Ixz,Iyz,I1,I2,I3,"
               "err_mass,err_inertia,declared_mass,declared_cx,declared_cy,declared_cz,declared_Ixx,declared_Iyy,"
               "declared_Izz,declared_Ixy,declared_Ixz,declared_Iyz,implied_density,com_distance,"
               "inertia_difference,computed_mass,computed_Ixx,computed_Iyy,computed_Izz,computed_Ixy,computed_Ixz,"
               "computed_Iyz,diagnoses,geometries,elapsed_s").split(",")
_TENSOR = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


def _g(value, digits=6):
    """A robot table's cell: the one number policy (:func:`significant`) at ``digits``, ``-`` where absent."""
    return "-" if value is None else significant(value, digits=digits)


def _vector(values, digits=6):
    return "-" if values is None else "[" + ", ".join(significant(v, digits=digits) for v in values) + "]"


def _header(obj, extra=""):
    name = f" '{obj['name']}'" if obj.get("name") else ""
    return (f"{obj['model']}  ({obj['format']}{name}, {len(obj['links'])} links, {obj['geometry']} geometry, "
            f"mass policy {obj['mass_policy']}{_density(obj)}{extra})")


def _density(obj):
    density = obj.get("default_density")
    return "" if density is None else f", density {density:g} kg/m³ unless given"


def _geometry_text(link):
    parts = []
    for g in link.get("geometries") or []:
        if g.get("included") is False:
            continue
        text = g["kind"] if not g.get("uri") else f"{g['kind']} {os.path.basename(g['uri'])}"
        if g.get("scale") and any(s != 1 for s in g["scale"]):
            text += " ×" + "·".join(f"{s:g}" for s in g["scale"])
        parts.append(text)
    return ", ".join(parts) or "-"


def _table(rows):
    widths = [max(len(str(row[k])) for row in rows) for k in range(len(rows[0]))]
    return ["  " + "  ".join(str(cell).ljust(width) for cell, width in zip(row, widths)).rstrip() for row in rows]


def _total_lines(obj):
    total = obj.get("total")
    if not total:
        return []
    frame = "the model frame" if obj["frame"] in ("model", "world") else f"the frame of root link '{obj['frame']}'"
    moved = {k: v for k, v in obj.get("joints", {}).items() if v}
    at = "joints at 0" if not moved else "joints " + ", ".join(f"{k}={v:g}" for k, v in moved.items())
    bound = total["error"].get("mass")
    lines = [f"  total ({at}; in {frame}): mass {_g(total.get('mass'), 9)} kg"
             + (f" ± {bound_text(bound)}" if bound is not None and "mass" in total else "")
             + f", center of mass {_vector(total.get('center_of_mass'), 9)} m"]
    for k, row in enumerate(total.get("inertia_com") or []):
        label = "inertia about it [kg·m²]" if k == 0 else ""
        lines.append(f"    {label:<26}{_vector(row, 9)}"
                     + (f"   ± {bound_text(total['error']['inertia_com'])}" if k == 0 else ""))
    if total.get("left_out"):
        lines.append(f"    (leaves out the links that failed: {', '.join(total['left_out'])})")
    return lines


def _failed(obj):
    return [f"error: {obj['model']}: {obj['message']}"]


def props_text(obj):
    """A readable block for one ``robot props`` object."""
    if obj.get("status") == "error":
        return "\n".join(_failed(obj))
    rows = [("link", "status", "mass [kg]", "± ", "center of mass [m]", "principal moments [kg·m²]", "geometry")]
    for link in obj["links"]:
        error = link.get("error") or {}
        rows.append((link["link"], link["status"], _g(link.get("mass"), 9),
                     bound_text(error["mass"]) if error.get("mass") else "", _vector(link.get("center_of_mass")),
                     _vector(link.get("principal_moments")), _geometry_text(link)))
    lines = [_header(obj), *_table(rows), *_total_lines(obj)]
    lines += _messages(obj)
    return "\n".join(lines)


def _messages(obj):
    lines = []
    for link in obj["links"]:
        if link["message"] and link["status"] != "ok":
            lines.append(f"  {printable(link['link'])}: {printable(link['message'])}")
        for warning in link.get("warnings") or []:
            lines.append(f"  warning: {printable(warning)}")
    for warning in obj.get("warnings") or []:
        lines.append(f"  warning: {printable(warning)}")
    return lines


def _moments(tensor):
    if tensor is None:
        return None
    import numpy as np
    return list(np.linalg.eigvalsh(np.asarray(tensor, dtype=float)))


def _percent(value):
    if value is None:
        return "-"
    return f"{value:.2%}" if value < 10 else f"×{value:.3g}"


def check_text(obj):
    """A readable block for one ``robot check`` object: a row per link, then what is wrong and why."""
    if obj.get("status") == "error":
        return "\n".join(_failed(obj))
    rows = [("link", "status", "declared [kg]", "computed [kg]", "density*", "COM off [m]", "(of size)",
             "inertia off", "computed moments [kg·m²]†", "diagnoses")]
    for link in obj["links"]:
        comparison = link.get("comparison") or {}
        declared = link.get("declared") or {}
        computed = link.get("computed") or {}
        rows.append((link["link"], link["status"], _g(declared.get("mass")), _g(computed.get("mass")),
                     _g(comparison.get("implied_density"), 4),
                     _g(comparison.get("com_distance"), 3),
                     f"{comparison['com_distance_relative']:.1%}" if "com_distance_relative" in comparison else "-",
                     _percent(comparison.get("inertia_difference")),
                     _vector(_moments(computed.get("inertia_com")), 4),
                     ", ".join(link["diagnoses"]) or "-"))
    lines = [_header(obj), *_table(rows),
             "  * implied density: declared mass / geometry volume [kg/m³]; computed: mass from the densities",
             "  † principal moments of the geometry's inertia at the declared mass (at the computed mass where "
             "none is declared)"]
    lines += _messages(obj)
    lines.append(f"  summary: {', '.join(f'{n} {s}' for s, n in obj['summary'].items())}")
    lines += _causes(obj)
    return "\n".join(lines)


def _causes(obj):
    """One line per diagnosis present: what usually causes it, and what ``robot write`` would change."""
    from ..robot.check import CAUSES, DIAGNOSES
    present = {name for link in obj["links"] for name in link.get("diagnoses") or []}
    return [f"  {name}: usually {CAUSES[name][0]}; `massprops robot write` {CAUSES[name][1]}"
            for name in DIAGNOSES if name in present]


def _csv_row(obj, link):
    row = dict.fromkeys(CSV_COLUMNS, "")
    row.update(model=obj["model"], link=link["link"], status=link["status"], message=link["message"],
               diagnoses=" ".join(link["diagnoses"]), geometries=_geometry_text(link),
               elapsed_s=repr(link.get("elapsed_s", 0.0)))
    for key in ("mass", "volume", "density"):
        if link.get(key) is not None:
            row[key] = repr(link[key])
    if link.get("center_of_mass") is not None:
        row.update(zip(("cx", "cy", "cz"), map(repr, link["center_of_mass"])))
    if link.get("inertia_com") is not None:
        j = link["inertia_com"]
        row.update(zip(("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"), (repr(j[a][b]) for a, b in _TENSOR)))
        row.update(err_mass=repr(link["error"]["mass"]), err_inertia=repr(link["error"]["inertia_com"]))
    if link.get("principal_moments") is not None:
        row.update(zip(("I1", "I2", "I3"), map(repr, link["principal_moments"])))
    declared = link.get("declared")
    if declared and declared.get("inertia_com") is not None:
        row["declared_mass"] = repr(declared["mass"])
        row.update(zip(("declared_cx", "declared_cy", "declared_cz"), map(repr, declared["center_of_mass"])))
        d = declared["inertia_com"]
        row.update(zip(("declared_Ixx", "declared_Iyy", "declared_Izz", "declared_Ixy", "declared_Ixz",
                        "declared_Iyz"), (repr(d[a][b]) for a, b in _TENSOR)))
    computed = link.get("computed")
    if computed and computed.get("mass") is not None:
        row["computed_mass"] = repr(computed["mass"])
    if computed and computed.get("inertia_com") is not None:
        c = computed["inertia_com"]
        row.update(zip(("computed_Ixx", "computed_Iyy", "computed_Izz", "computed_Ixy", "computed_Ixz",
                        "computed_Iyz"), (repr(c[a][b]) for a, b in _TENSOR)))
    comparison = link.get("comparison") or {}
    for key in ("implied_density", "com_distance", "inertia_difference"):
        if key in comparison:
            row[key] = repr(comparison[key])
    return row


def csv_text(objects):
    """One CSV row per link of every model (a model that failed: one row with status error)."""
    rows = []
    for obj in objects:
        if obj.get("status") == "error":
            rows.append({"model": obj["model"], "status": "error", "message": obj["message"]})
            continue
        rows += [_csv_row(obj, link) for link in obj["links"]]
    return to_csv(rows, CSV_COLUMNS)


def junit_xml(objects, failing):
    """JUnit XML (:func:`massprops.report.junit.junit`): a test suite per model, a test case per link; ``failing``
    statuses are failures, a model that could not be read one error."""
    from .junit import junit
    suites = []
    for obj in objects:
        if obj.get("status") == "error":
            suites.append({"name": obj["model"], "cases": [{
                "name": obj["model"], "classname": "massprops.robot", "time": obj.get("elapsed_s", 0.0),
                "error": {"message": obj["message"], "text": obj["message"]}}]})
            continue
        cases = []
        for link in obj.get("links") or []:
            case = {"name": link["link"], "classname": f"massprops.robot.{obj.get('name') or 'model'}",
                    "time": link.get("elapsed_s", 0.0)}
            if link["status"] in failing:
                text = link["message"] or link["status"]
                case["failure"] = {"message": f"{link['status']}: {text}", "type": link["status"], "text": text}
            cases.append(case)
        suites.append({"name": obj["model"], "cases": cases})
    return junit(suites, name="massprops robot")
