"""JSON: a result as its JSON object (floats at ``repr`` precision, so every number round-trips), and JSON
and JSON Lines text of such objects."""

from __future__ import annotations

import math
import re

import numpy as np

from ..model.errors import printable

__all__ = ["plain", "result_dict", "finite_or_null", "to_json", "to_jsonl"]

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


def result_dict(result, *, omega=None, about=(), only=None, extra=None, brief=False):
    """The SPEC's JSON object for one :class:`massprops.result.Result`.

    Parameters
    ----------
    omega : array_like (3,), optional
        Angular velocity in local axes (rad/s): adds ``angular_momentum`` and
        ``kinetic_energy``.
    about : sequence of (3,) points
        Global points to report the inertia about (``inertia_about``).
    only : collection of str, optional
        Restrict the quantities reported (see ``massprops.compute.QUANTITIES``).
    brief : bool
        Only the keys a CSV row reads (:func:`massprops.report.tables.csv_row`), with the same values: no
        global frames, degenerate groups, pose, checks or warnings, and of the error only the volume's and
        the inertia's bounds (a batch's CSV report builds one such object per file).
    """
    with np.errstate(over="ignore", invalid="ignore"):        # overflow is said by finite_or_null
        return _result_dict(result, omega, about, only, extra, brief)


def _result_dict(result, omega, about, only, extra, brief=False):
    p = result.properties
    want = (lambda q: True) if not only else (lambda q: q in only)
    out = {"file": result.file, "triangles": result.triangles}
    if want("volume"):
        out["volume"] = p.volume
    if want("mass"):
        out["mass"] = p.mass
    out["density"] = p.density              # the density in use, whatever was asked
    if want("surface_area"):
        out["surface_area"] = p.surface_area
    if p.unit:
        out["unit"] = "SI (m, kg, kg·m²), mesh unit " + p.unit
    if p.center_of_mass is not None and (want("center_of_mass") or want("inertia") or want("principal")):
        out["center_of_mass"] = p.center_of_mass
        if not brief:
            out["center_of_mass_global"] = p.center_of_mass_global
    if p.inertia_com is not None:
        if want("inertia"):
            out["inertia_com"] = p.inertia_com
        if want("inertia") and not brief:
            out["inertia_com_global"] = p.inertia_com_global
            out["inertia_origin"] = p.inertia_origin
            if about:
                out["inertia_about"] = [{"point": list(map(float, pt)), "inertia": p.about(pt)} for pt in about]
        if want("principal"):
            pr = p.principal
            out["principal_moments"] = pr.moments
            out["principal_axes"] = pr.axes
            if not brief:
                out["degenerate"] = [list(g) for g in pr.degenerate]
    if brief:
        error = {"volume": p.error.volume}
        if "inertia_com" in out:
            error["inertia_com"] = p.error.inertia_com
        out["error"] = error
        out["elapsed_s"] = result.elapsed_s
        return finite_or_null(plain(out))
    if omega is not None:
        local, world = p.angular_momentum(omega)
        out["omega"] = list(map(float, omega))
        out["angular_momentum"] = {"local": local, "global": world}
        out["kinetic_energy"] = p.kinetic_energy(omega)
    # no eigen-decomposition unless asked
    error = p.error.as_dict(principal=want("principal"))
    # Bounds only for what was computed (volume and mass always are).
    out["error"] = {key: bound for key, bound in error.items()
                    if _ERROR_OF.get(key, key) in out or key in ("volume", "mass", "input_resolution")}
    out["pose"] = {"rotation": p.pose.rotation, "translation": p.pose.translation}
    out["checks"] = result.checks
    out["warnings"] = [printable(w) for w in result.warnings]      # they may quote the file
    out["elapsed_s"] = result.elapsed_s
    if extra:
        out.update(extra)
    return finite_or_null(plain(out))


def finite_or_null(obj):
    """``obj`` with every non-finite float replaced by None, and a warning naming where (JSON has no inf/NaN).

    Options are checked to be finite before anything is computed; what is left
    is overflow (a part placed at 1e308, a density of 1e300), said once per key.
    """
    where = []

    def clean(value, key):
        if type(value) is float:
            if math.isfinite(value):
                return value
            where.append(key)
            return None
        if type(value) is list:
            try:
                # Numbers only, all finite (an inf or NaN makes the sum one): nothing to replace.
                if math.isfinite(sum(value)):
                    return list(value)
            except (TypeError, OverflowError):
                pass
            return [clean(v, key) for v in value]
        if type(value) is dict:
            return {k: clean(v, f"{key}.{k}" if key else k) for k, v in value.items()}
        return value

    cleaned = clean(obj, "")
    if where:
        keys = ", ".join(dict.fromkeys(where))
        cleaned.setdefault("warnings", []).append(
            f"{keys}: beyond double precision (overflow or undefined); written as null")
    return cleaned


_NUMBER_LIST = r"\[\s*([-+0-9.eE,\s]+?)\s*\]"           # compiled on first use (re caches it)


def to_json(value):
    """JSON text of a result object, or of an array of them (any iterable), indented, numeric arrays on one
    line, floats at full precision; always valid JSON (non-finite values as null, see :func:`finite_or_null`)."""
    value = plain(value if isinstance(value, dict) else list(value))
    value = finite_or_null(value) if isinstance(value, dict) else [
        finite_or_null(v) if isinstance(v, dict) else v for v in value]
    import json                         # lazily: the text report does not need it (start-up)
    text = json.dumps(value, indent=2, allow_nan=False)
    return re.sub(_NUMBER_LIST, lambda m: "[" + ", ".join(v.strip() for v in m.group(1).split(",")) + "]", text)


def to_jsonl(objects):
    """JSON Lines: each result object on one line, as :func:`to_json` writes it (non-finite values as null)."""
    import json
    return "".join(json.dumps(finite_or_null(plain(obj)), allow_nan=False) + "\n" for obj in objects)
