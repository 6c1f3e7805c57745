"""Expected-values files and the comparison behind ``massprops regress`` (no click, no printing).

An expected-values file is a CSV with a ``file`` column (paths relative to
the CSV's folder), optional ``density`` and ``unit`` columns (how to compute),
and the quantity columns of the batch CSV (``volume, mass, cx..cz, Ixx..Iyz,
I1..I3, a1x..a3z``) plus ``degenerate`` (the principal index groups, as in the
JSON output).  Other columns are kept but not compared; empty cells are not
compared either, so a batch CSV (with absolute paths, or written beside the
files) also serves as a baseline; its rows whose ``status`` is not ``ok`` are
skipped.

Tolerances are normwise per quantity: an element deviates when
``|actual − expected| > atol + rtol · scale``, with ``scale`` the largest
expected element of that quantity (for the center of mass, at least the
part's radius of gyration, so a centred part is not judged against zero).
Principal axes are compared up to sign (the SPEC's sign rule only breaks
ties), with the angle the inertia tolerance allows (Davis–Kahan:
``rtol · scale / gap``); inside a group of equal moments only the subspace
they span is compared.
"""

from __future__ import annotations

import csv
import json
import math
import os
from dataclasses import dataclass

import numpy as np

from ..model.errors import MassPropsError

__all__ = ["COLUMNS_OF", "EXPECTED_COLUMNS", "Expected", "Deviation", "Comparison", "expected_row",
           "read_expected", "write_expected", "compare", "deviation_table", "junit_xml"]

COLUMNS_OF = {
    "volume": ("volume",), "mass": ("mass",), "center_of_mass": ("cx", "cy", "cz"),
    "inertia_com": ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz"), "principal_moments": ("I1", "I2", "I3"),
    "principal_axes": tuple(f"a{k}{c}" for k in (1, 2, 3) for c in "xyz"),
}
EXPECTED_COLUMNS = ["file", "density", "unit", "triangles", *[c for cols in COLUMNS_OF.values() for c in cols],
                    "degenerate"]
_TENSOR_INDEX = {"Ixx": (0, 0), "Iyy": (1, 1), "Izz": (2, 2), "Ixy": (0, 1), "Ixz": (0, 2), "Iyz": (1, 2)}
# Beyond this angle (radians) an axis is not determined by the tolerance: compare its subspace.
_AXIS_UNDETERMINED = 0.1


@dataclass(frozen=True)
class Expected:
    """One row: ``label`` as written, ``path`` resolved, how to compute, and the expected values by column."""

    label: str
    path: str
    density: float | None
    unit: str | None
    values: dict
    degenerate: tuple | None


@dataclass(frozen=True)
class Deviation:
    """One compared element (or axis subspace): absolute difference, relative to the quantity's scale."""

    quantity: str
    column: str
    expected: float
    actual: float
    difference: float
    relative: float
    tolerance: float

    @property
    def failed(self):
        return not self.difference <= self.tolerance


@dataclass(frozen=True)
class Comparison:
    """The outcome for one file: the worst deviation per quantity, and every element beyond tolerance."""

    expected: Expected
    worst: dict
    failures: tuple

    @property
    def failed(self):
        return bool(self.failures)


def expected_row(label, *, volume, mass, center_of_mass, inertia_com, principal, triangles, density=None,
                 unit=None):
    """A row of :data:`EXPECTED_COLUMNS` (values as ``repr`` strings, so they round-trip)."""
    row = {"file": label, "density": "" if density is None else repr(float(density)), "unit": unit or "",
           "triangles": str(int(triangles)), "volume": repr(float(volume)), "mass": repr(float(mass))}
    row.update(zip(COLUMNS_OF["center_of_mass"], (repr(float(x)) for x in center_of_mass)))
    row.update({c: repr(float(inertia_com[i][j])) for c, (i, j) in _TENSOR_INDEX.items()})
    row.update(zip(COLUMNS_OF["principal_moments"], (repr(float(x)) for x in principal.moments)))
    row.update(zip(COLUMNS_OF["principal_axes"], (repr(float(x)) for x in np.ravel(principal.axes))))
    row["degenerate"] = json.dumps([list(g) for g in principal.degenerate])
    return row


def write_expected(path, rows, *, extra_columns=()):
    """Write rows (dicts) sorted by file, columns :data:`EXPECTED_COLUMNS` then ``extra_columns``."""
    columns = EXPECTED_COLUMNS + [c for c in extra_columns if c not in EXPECTED_COLUMNS]
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, lineterminator="\n", restval="", extrasaction="ignore")
        writer.writeheader()
        writer.writerows(sorted(rows, key=lambda r: r["file"]))


def read_rows(path):
    """The raw rows (dicts of strings) and column names of a CSV; refuses one without a ``file`` column."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            columns = list(reader.fieldnames or [])
    except FileNotFoundError:
        raise MassPropsError("no such file", path=path,
                             fix="make one with `massprops regress --record EXPECTED.csv FILE...`") from None
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise MassPropsError(f"cannot read the CSV ({exc})", path=path, fix="check the file") from None
    if "file" not in columns:
        raise MassPropsError("not an expected-values CSV (no 'file' column)", path=path,
                             fix="make one with `massprops regress --record EXPECTED.csv FILE...`")
    return rows, columns


def _number(text, column, line, path):
    try:
        return float(text)
    except ValueError:
        raise MassPropsError(f"line {line}: column {column} is {text!r}, not a number", path=path,
                             fix="fix the value or re-record the baseline") from None


def read_expected(path):
    """The rows of an expected-values CSV as :class:`Expected` objects, paths resolved against its folder."""
    rows, _ = read_rows(path)
    folder = os.path.dirname(os.path.abspath(path))
    out = []
    for line, row in enumerate(rows, 2):
        if (row.get("status") or "ok") != "ok":
            continue                                   # a failed row of a batch CSV holds no values
        values = {c: _number(row[c], c, line, path) for cols in COLUMNS_OF.values() for c in cols
                  if (row.get(c) or "").strip()}
        if not values:
            raise MassPropsError(f"line {line}: no expected values for {row['file']!r}", path=path,
                                 fix="fill in the quantity columns or re-record the baseline")
        density = (row.get("density") or "").strip()
        degenerate = (row.get("degenerate") or "").strip()
        out.append(Expected(row["file"], os.path.join(folder, row["file"]),
                            _number(density, "density", line, path) if density else None,
                            (row.get("unit") or "").strip() or None, values,
                            tuple(tuple(g) for g in json.loads(degenerate)) if degenerate else None))
    return out


def _element(quantity, column, expected, actual, scale, tolerance):
    difference = abs(actual - expected)
    return Deviation(quantity, column, expected, actual, difference, difference / scale if scale else difference,
                     tolerance)


def _actual_values(properties):
    values = {"volume": properties.volume, "mass": properties.mass}
    values.update(zip(COLUMNS_OF["center_of_mass"], properties.center_of_mass))
    values.update({c: properties.inertia_com[i, j] for c, (i, j) in _TENSOR_INDEX.items()})
    values.update(zip(COLUMNS_OF["principal_moments"], properties.principal.moments))
    return {k: float(v) for k, v in values.items()}


def _scales(expected, actual):
    """The scale each quantity's elements are judged against (see the module docstring)."""
    get = lambda c: expected.get(c, actual[c])  # noqa: E731 - a missing expected cell falls back to ours
    inertia = max(abs(get(c)) for c in COLUMNS_OF["inertia_com"])
    gyration = math.sqrt(inertia / abs(get("mass"))) if get("mass") else 0.0
    return {"volume": abs(get("volume")), "mass": abs(get("mass")),
            "center_of_mass": max(gyration, *(abs(get(c)) for c in COLUMNS_OF["center_of_mass"])),
            "inertia_com": inertia, "principal_moments": max(abs(get(c)) for c in COLUMNS_OF["principal_moments"])}


def _axis_groups(moments, degenerate, rtol, scale):
    """Index groups whose axes are compared together: equal moments on either side, or too close to tell."""
    groups = [[0]]
    for k in (1, 2):
        equal = any(k - 1 in g and k in g for g in degenerate)
        if equal or rtol * scale > _AXIS_UNDETERMINED * (moments[k] - moments[k - 1]):
            groups[-1].append(k)
        else:
            groups.append([k])
    return groups


def _axes_deviations(expected, principal, rtol, scale):
    columns = COLUMNS_OF["principal_axes"]
    if not all(c in expected.values for c in columns):
        return []
    axes = np.array([expected.values[c] for c in columns]).reshape(3, 3)
    moments = [expected.values.get(f"I{k + 1}", principal.moments[k]) for k in range(3)]
    out = []
    for group in _axis_groups(moments, [*(expected.degenerate or ()), *principal.degenerate], rtol, scale):
        others = [moments[k] for k in range(3) if k not in group]
        if not others:
            continue                              # three equal moments: every axis is principal
        gap = min(abs(moments[g] - o) for g in group for o in others)
        tolerance = rtol * max(1.0, scale / gap) if gap > 0 else math.inf
        if len(group) == 1:
            k = group[0]
            ours, theirs = principal.axes[k], axes[k]
            # Up to sign: the SPEC's sign rule decides only ties, which rounding can flip.
            theirs = theirs if np.abs(ours - theirs).max() <= np.abs(ours + theirs).max() else -theirs
            i = int(np.argmax(np.abs(ours - theirs)))
            out.append(_element("principal_axes", columns[3 * k + i], float(theirs[i]), float(ours[i]), 1.0,
                                tolerance))
        else:
            projector = sum(np.outer(axes[k], axes[k]) for k in group)
            ours = sum(np.outer(principal.axes[k], principal.axes[k]) for k in group)
            difference = float(np.abs(projector - ours).max())
            name = ",".join(f"a{k + 1}" for k in group) + " subspace"
            out.append(Deviation("principal_axes", name, math.nan, math.nan, difference, difference, tolerance))
    return out


def compare(expected, properties, *, rtol=1e-9, atol=0.0):
    """Compare recomputed :class:`massprops.model.properties.MassProperties` with an :class:`Expected` row.

    Returns
    -------
    Comparison
    """
    actual = _actual_values(properties)
    scales = _scales(expected.values, actual)
    deviations = []
    for quantity, columns in COLUMNS_OF.items():
        if quantity != "principal_axes":
            tolerance = atol + rtol * scales[quantity]
            deviations += [_element(quantity, c, expected.values[c], actual[c], scales[quantity], tolerance)
                           for c in columns if c in expected.values]
    deviations += _axes_deviations(expected, properties.principal, rtol, scales["principal_moments"])
    worst = {}
    for d in deviations:
        relative = d.relative if d.relative == d.relative else math.inf     # NaN counts as the worst
        worst[d.quantity] = max(worst.get(d.quantity, 0.0), relative)
    return Comparison(expected, worst, tuple(d for d in deviations if d.failed))


def describe(deviation):
    """One line naming the quantity, expected and actual values, the deviation and the tolerance."""
    d = deviation
    if d.column.endswith("subspace"):
        head = f"{d.column} differs by {d.difference:.3g} (projector, largest element)"
    else:
        head = f"{d.column} = {d.actual!r}, expected {d.expected!r}: off by {d.difference:.3g}"
    return f"{head} ({d.relative:.2g} relative), tolerance {d.tolerance:.3g}"


_TABLE_COLUMNS = (("volume", "volume"), ("mass", "mass"), ("center_of_mass", "COM"), ("inertia_com", "inertia"),
                  ("principal_moments", "moments"), ("principal_axes", "axes"))


def deviation_table(labels, comparisons):
    """A text table: per file the worst relative deviation of each quantity, and ok / FAIL / error.

    ``comparisons[i]`` is a :class:`Comparison`, or None when ``labels[i]`` could not be computed.
    """
    width = max([len("file")] + [len(label) for label in labels])
    lines = [f"{'file':<{width}}  " + "".join(f"{head:>9}" for _, head in _TABLE_COLUMNS) + "  status"]
    for label, comparison in zip(labels, comparisons):
        if comparison is None:
            lines.append(f"{label:<{width}}  " + "".join(f"{'-':>9}" for _ in _TABLE_COLUMNS) + "  error")
            continue
        cells = [comparison.worst.get(q) for q, _ in _TABLE_COLUMNS]
        text = "".join(f"{'-' if c is None else ('0' if c == 0 else f'{c:.1e}'):>9}" for c in cells)
        lines.append(f"{label:<{width}}  {text}  {'FAIL' if comparison.failed else 'ok'}")
    return "\n".join(lines)


def junit_xml(cases, *, rtol, atol):
    """JUnit XML text, one test case per file.

    Parameters
    ----------
    cases : sequence of (label, Comparison or None, error message or None, seconds)
    """
    from ..report.junit import junit

    suite = []
    for label, comparison, error, seconds in cases:
        case = {"name": label, "classname": "massprops.validation.regress", "time": seconds}
        if comparison is None:
            case["error"] = {"message": error or "could not be computed", "text": error}
        elif comparison.failed:
            case["failure"] = {"message": f"{len(comparison.failures)} deviation(s) beyond tolerance: "
                                          + ", ".join(d.column for d in comparison.failures),
                               "text": "\n".join(describe(d) for d in comparison.failures)}
        suite.append(case)
    return junit([{"name": "massprops regress", "cases": suite,
                   "properties": {"tolerance": f"rtol={rtol:g} atol={atol:g}"}}])
