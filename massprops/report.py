"""Text, JSON and CSV renderings of results (no click, no printing).

JSON keys and CSV columns are the SPEC's; floats are written with ``repr``
precision so every number round-trips.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re

import numpy as np

__all__ = ["plain", "result_dict", "to_json", "to_text", "csv_row", "CSV_COLUMNS", "to_csv"]

CSV_COLUMNS = ("file,status,message,triangles,volume,mass,cx,cy,cz,Ixx,Iyy,Izz,Ixy,Ixz,Iyz,I1,I2,I3,"
               "a1x,a1y,a1z,a2x,a2y,a2z,a3x,a3y,a3z,err_volume,err_inertia,elapsed_s").split(",")
_COLUMN_SET = frozenset(CSV_COLUMNS)
_CSV_HEADER = ",".join(CSV_COLUMNS) + "\n"          # no column name needs quoting


_AS_IS = frozenset((str, int, float, bool, type(None)))


def plain(value):
    """numpy values to plain Python for json."""
    kind = type(value)
    if kind in _AS_IS:                      # exact types: a numpy float64 (a float subclass) is converted below
        return value
    if kind is dict:
        return {k: v if type(v) in _AS_IS else plain(v) for k, v in value.items()}
    if kind is list:
        return [v if type(v) in _AS_IS else plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


_ERROR_OF = {"principal_axes_rad": "principal_axes"}


def result_dict(result, *, omega=None, about=(), only=None, extra=None):
    """The SPEC's JSON object for one :class:`massprops.compute.Result`.

    Parameters
    ----------
    omega : array_like (3,), optional
        Angular velocity in local axes (rad/s): adds ``angular_momentum`` and
        ``kinetic_energy``.
    about : sequence of (3,) points
        Global points to report the inertia about (``inertia_about``).
    only : collection of str, optional
        Restrict the quantities reported (see ``massprops.compute.QUANTITIES``).
    """
    p = result.properties
    want = (lambda q: True) if not only else (lambda q: q in only)
    out = {"file": result.file, "triangles": result.triangles}
    if want("volume"):
        out["volume"] = p.volume
    if want("mass"):
        out["mass"] = p.mass
        out["density"] = p.density
    if want("surface_area"):
        out["surface_area"] = p.surface_area
    if p.unit:
        out["unit"] = "SI (m, kg, kg·m²), mesh unit " + p.unit
    if p.center_of_mass is not None and (want("center_of_mass") or want("inertia") or want("principal")):
        out["center_of_mass"] = p.center_of_mass
        out["center_of_mass_global"] = p.center_of_mass_global
    if p.inertia_com is not None:
        if want("inertia"):
            out["inertia_com"] = p.inertia_com
            out["inertia_com_global"] = p.inertia_com_global
            out["inertia_origin"] = p.inertia_origin
            if about:
                out["inertia_about"] = [{"point": list(map(float, pt)), "inertia": p.about(pt)} for pt in about]
        if want("principal"):
            pr = p.principal
            out["principal_moments"] = pr.moments
            out["principal_axes"] = pr.axes
            out["degenerate"] = [list(g) for g in pr.degenerate]
    if omega is not None:
        local, world = p.angular_momentum(omega)
        out["angular_momentum"] = {"local": local, "global": world}
        out["kinetic_energy"] = p.kinetic_energy(omega)
    # no eigen-decomposition unless asked
    error = p.error.as_dict(p.principal if p.inertia_com is not None and want("principal") else None)
    # Bounds only for what was computed (volume and mass always are).
    out["error"] = {key: bound for key, bound in error.items()
                    if _ERROR_OF.get(key, key) in out or key in ("volume", "mass", "input_resolution")}
    out["pose"] = {"rotation": p.pose.rotation, "translation": p.pose.translation}
    out["checks"] = result.checks
    out["warnings"] = list(result.warnings)
    out["elapsed_s"] = result.elapsed_s
    if extra:
        out.update(extra)
    return plain(out)


_NUMBER_LIST = re.compile(r"\[\s*([-+0-9.eE,\s]+?)\s*\]")


def to_json(value):
    """JSON text of a result object, or of an array of them (any iterable), indented, numeric arrays on one
    line, floats at full precision."""
    text = json.dumps(plain(value if isinstance(value, dict) else list(value)), indent=2, allow_nan=False)
    return _NUMBER_LIST.sub(lambda m: "[" + ", ".join(v.strip() for v in m.group(1).split(",")) + "]", text)


def _num(x):
    return f"{x:.15g}"


def _vec(v):
    return "[" + ", ".join(f"{x: .15g}" for x in v) + "]"


def to_text(obj):
    """A readable block for one result object (as made by :func:`result_dict`)."""
    lines = [f"{obj['file']}  ({obj['triangles']} triangles, {obj['checks'].get('shells', '?')} shell(s))"]
    err = obj["error"]

    def row(label, value, bound=None):
        text = _vec(value) if isinstance(value, list) and value and not isinstance(value[0], list) else (
            _num(value) if isinstance(value, (int, float)) else str(value))
        lines.append(f"  {label:<22} {text}" + (f"   ± {bound:.2g}" if bound is not None else ""))

    posed = obj["pose"]["rotation"] != np.eye(3).tolist() or any(obj["pose"]["translation"])
    skip = set() if posed else {"center_of_mass_global", "inertia_com_global"}
    for key, label, bound in (("volume", "volume", "volume"), ("mass", "mass", "mass"),
                              ("density", "density", None), ("surface_area", "surface area", None),
                              ("center_of_mass", "center of mass", "center_of_mass"),
                              ("center_of_mass_global", "center of mass global", None)):
        if key in obj and key not in skip:
            row(label, obj[key], err.get(bound) if bound else None)
    for key, label, bound in (("inertia_com", "inertia about COM", "inertia_com"),
                              ("inertia_com_global", "  global axes", None),
                              ("inertia_origin", "about global origin", None)):
        if key in obj and key not in skip:
            rows = obj[key]
            for i, r in enumerate(rows):
                lines.append(f"  {label if i == 0 else '':<22} {_vec(r)}"
                             + (f"   ± {err[bound]:.2g}" if bound and i == 0 else ""))
    if "principal_moments" in obj:
        row("principal moments", obj["principal_moments"], err["principal_moments"])
        for k, axis in enumerate(obj["principal_axes"]):
            row(f"  axis {k + 1}", axis)
        if obj["degenerate"]:
            lines.append(f"  {'degenerate':<22} {obj['degenerate']} (axes chosen by the SPEC's rule)")
    for extra in obj.get("inertia_about", []):
        for i, r in enumerate(extra["inertia"]):
            lines.append(f"  {('about ' + _vec(extra['point'])) if i == 0 else '':<22} {_vec(r)}")
    if "angular_momentum" in obj:
        row("angular momentum", obj["angular_momentum"]["local"])
        row("  global axes", obj["angular_momentum"]["global"])
        row("kinetic energy", obj["kinetic_energy"])
    if "trimesh" in obj:
        rel = obj["trimesh"].get("relative_difference", {})
        row("trimesh rel. diff.", ", ".join(f"{k} {v:.1e}" for k, v in rel.items()))
    for w in obj["warnings"]:
        lines.append(f"  warning: {w}")
    return "\n".join(lines)


def csv_row(obj, *, status="ok", message=""):
    """One batch CSV row (a dict keyed by :data:`CSV_COLUMNS`) from a result object."""
    row = dict.fromkeys(CSV_COLUMNS, "")
    row.update(file=obj["file"], status=status, message=message)
    if status != "ok":
        return row
    row.update(triangles=obj["triangles"], err_volume=repr(obj["error"]["volume"]), elapsed_s=repr(obj["elapsed_s"]))
    row.update((key, repr(obj[key])) for key in ("volume", "mass") if key in obj)
    if "center_of_mass" in obj:
        row.update(zip(("cx", "cy", "cz"), map(repr, obj["center_of_mass"])))
    if "inertia_com" in obj:
        j = obj["inertia_com"]
        row.update(Ixx=repr(j[0][0]), Iyy=repr(j[1][1]), Izz=repr(j[2][2]),
                   Ixy=repr(j[0][1]), Ixz=repr(j[0][2]), Iyz=repr(j[1][2]), err_inertia=repr(obj["error"]["inertia_com"]))
    if "principal_moments" in obj:
        row.update(zip(("I1", "I2", "I3"), map(repr, obj["principal_moments"])))
        for k, axis in enumerate(obj["principal_axes"]):
            row.update(zip((f"a{k + 1}x", f"a{k + 1}y", f"a{k + 1}z"), map(repr, axis)))
    return row


def to_csv(rows):
    """CSV text with the SPEC's header for rows made by :func:`csv_row`."""
    buffer = io.StringIO(_CSV_HEADER)
    buffer.seek(0, io.SEEK_END)
    writer = csv.writer(buffer, lineterminator="\n")
    for row in rows:
        extra = row.keys() - _COLUMN_SET
        if extra:
            raise ValueError(f"dict contains fields not in the CSV columns: {', '.join(map(repr, extra))}")
        values = [row.get(key, "") for key in CSV_COLUMNS]
        line = _plain_csv_line(values)
        if line is None:
            writer.writerow(values)
        else:
            buffer.write(line)
    return buffer.getvalue()


_NEEDS_QUOTES = re.compile(r'["\r\n]')


def _plain_csv_line(values):
    """The CSV line of strings and ints that need no quoting (what csv.writer writes for them), else None."""
    if len(values) < 2 or not all(type(v) is str or type(v) is int for v in values):
        return None                 # a lone empty field is written quoted
    line = ",".join(map(str, values))
    if line.count(",") != len(values) - 1 or _NEEDS_QUOTES.search(line):
        return None
    return line + "\n"


def relative_difference(ours, theirs, *, floor=0.0):
    """max|ours − theirs| / max(max|ours|, floor) (0 when both are 0).

    ``floor`` keeps a quantity near zero (the center of mass of a centred
    part) from being judged against its own rounding noise: pass its scale.
    """
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)
    scale = max(float(np.abs(ours).max()), floor)
    diff = float(np.abs(ours - theirs).max())
    return diff / scale if scale else (0.0 if diff == 0 else math.inf)
