"""How exact massprops is, what it costs, and where trimesh breaks: the ``accuracy`` report.

Two tables, each row measured, nothing assumed:

* **tessellation**: smooth analytic solids (sphere, cylinder, cone, torus,
  ellipsoid), posed off the origin, at about 100 to 1M triangles.  Errors of
  massprops and trimesh against the smooth analytic values (which the
  tessellation itself limits) and against the exact values of the polyhedron
  as stored (:func:`massprops.validation.exact.exact_properties`), with run times.
* **extreme**: offsets up to 1e8 part sizes, scales 1e-9 to 1e9, plates and
  needles of aspect 1e-6, float32 input, a million triangles — relative
  errors against the exact reference, whether massprops's reported bound
  covered its true error, and whether each tool's principal moments satisfy
  ``I1 + I2 ≥ I3`` (what a physics engine checks).

Errors are normwise relative: volume against the volume, the center of mass
against the larger of the part's size and its distance from the origin, the
inertia tensor (about the COM) against its largest element; a row's error is
the largest of the three.
"""

from __future__ import annotations

import csv
import io
import math
import time
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from . import analytic, solids
from ..model.frames import Pose
from ..mesh.surface import TriangleMesh

__all__ = ["tessellation_rows", "extreme_rows", "relative_errors", "markdown_table", "csv_text", "plot",
           "TESSELLATION_COLUMNS", "EXTREME_COLUMNS"]

# A generic pose so that products of inertia are non-zero and the part is off the origin.
POSE = Pose.from_euler("xyz", (30.0, 40.0, 50.0), translation=(3.0, -2.0, 1.0))
QUICK_LEVELS = (100, 1_000, 10_000)
FULL_LEVELS = (100, 1_000, 10_000, 100_000, 1_000_000)


@dataclass(frozen=True)
class Case:
    """One mesh to measure: its name, the mesh, its size (largest extent) and optional smooth values.

    ``smooth`` is a :class:`massprops.validation.analytic.Analytic` in the mesh's frame.
    """

    name: str
    mesh: TriangleMesh
    size: float
    smooth: object = None


def relative_errors(values, reference, size):
    """Absolute and normwise relative errors of float ``values`` against ``reference``.

    Parameters
    ----------
    values, reference : dict
        ``volume``, ``center_of_mass`` (3,), ``inertia_com`` (3, 3); the
        reference may hold Fractions (compared exactly) or floats.
    size : float
        The part's largest extent.

    Returns
    -------
    dict
        ``volume``, ``center_of_mass``, ``inertia_com`` (absolute, largest
        element), ``rel_volume``, ``rel_center_of_mass``, ``rel_inertia_com``
        and ``rel_max``; ``inf`` when a value is not finite.
    """
    def exact(x):
        return x if isinstance(x, Fraction) else Fraction(float(x))

    def worst(ours, ref):
        pairs = list(zip(np.ravel(np.asarray(ours, dtype=object)), np.ravel(np.asarray(ref, dtype=object))))
        if not all(math.isfinite(float(x)) for x, _ in pairs):
            return math.inf, max(abs(exact(y)) for _, y in pairs)
        return max(abs(exact(x) - exact(y)) for x, y in pairs), max(abs(exact(y)) for _, y in pairs)

    out = {}
    for key in ("volume", "center_of_mass", "inertia_com"):
        error, scale = worst(values[key], reference[key])
        if key == "center_of_mass":
            scale = max(scale, Fraction(size))
        out[key] = float(error)
        out["rel_" + key] = math.inf if error == math.inf else float(error / scale)
    out["rel_max"] = max(out["rel_volume"], out["rel_center_of_mass"], out["rel_inertia_com"])
    return out


def _timed(fn, repeat):
    """(best wall time of ``repeat`` runs, last value)."""
    best, value = math.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        value = fn()
        best = min(best, time.perf_counter() - start)
    return best, value


def _physical(inertia):
    """The float principal moments as a physics engine sees them: I1 > 0 and I1 + I2 ≥ I3."""
    inertia = np.asarray(inertia, dtype=float)
    if not np.all(np.isfinite(inertia)):
        return False
    i1, i2, i3 = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    return bool(i1 > 0 and i1 + i2 >= i3)


def _values(source):
    """volume, center_of_mass, inertia_com of a MassProperties or an Analytic."""
    return {"volume": source.volume, "center_of_mass": source.center_of_mass, "inertia_com": source.inertia_com}


def measure(case, *, repeat=None):
    """massprops and trimesh on one case against the exact (and smooth) values: one row dict."""
    from ..compute import mesh_result
    from .crosscheck import trimesh_values
    from .exact import exact_properties

    mesh = case.mesh
    repeat = repeat or (3 if mesh.faces.shape[0] < 100_000 else 1)
    exact = exact_properties(mesh.triangles)
    seconds, result = _timed(lambda: mesh_result(mesh), repeat)
    trimesh_seconds, theirs = _timed(lambda: trimesh_values(mesh.vertices, mesh.faces), repeat)
    props = result.properties
    ours = _values(props)
    ours_exact = relative_errors(ours, exact, case.size)
    row = {"case": case.name, "triangles": int(mesh.faces.shape[0]), "massprops_s": seconds,
           "trimesh_s": trimesh_seconds, "massprops_exact": ours_exact,
           "trimesh_exact": relative_errors(theirs, exact, case.size),
           "bound_covers": all(ours_exact[key] <= getattr(props.error, key)
                               for key in ("volume", "center_of_mass", "inertia_com")),
           "bound_rel_inertia": props.error.inertia_com / float(np.abs(props.inertia_com).max()),
           "massprops_physical": _physical(props.inertia_com) and result.checks["triangle_inequality"],
           "trimesh_physical": _physical(theirs["inertia_com"]),
           "input_resolution": props.error.input_resolution["coordinates"]}
    if case.smooth is not None:
        row["massprops_smooth"] = relative_errors(ours, _values(case.smooth), case.size)
        row["trimesh_smooth"] = relative_errors(theirs, _values(case.smooth), case.size)
    return row


# -- the smooth solids -----------------------------------------------------


def _segment(start, end, count):
    """``count`` points from ``start`` towards ``end`` (end excluded), (count, 2)."""
    t = np.arange(count)[:, None] / count
    return np.asarray(start, float) + t * (np.asarray(end, float) - np.asarray(start, float))


def smooth_solid(name, triangles):
    """A tessellation of a named smooth solid with about ``triangles`` faces, posed by :data:`POSE`.

    Returns
    -------
    Case
        With the smooth analytic values posed the same way.
    """
    if name == "sphere":
        n = max(6, round(math.sqrt(triangles)))
        mesh, values, size = solids.uv_sphere(n, max(3, n // 2), 1.0), analytic.sphere_values(1.0), 2.0
    elif name == "ellipsoid":
        n = max(6, round(math.sqrt(triangles)))
        axes = (1.0, 0.6, 0.35)
        mesh, values, size = solids.ellipsoid(axes, n, max(3, n // 2)), analytic.ellipsoid_values(axes), 2.0
    elif name == "torus":
        n = max(6, round(math.sqrt(1.5 * triangles)))
        mesh, size = solids.torus(n, max(3, n // 3), 1.0, 0.3), 2.6
        values = analytic.torus_values(1.0, 0.3)
    elif name == "cylinder":
        n = max(6, round(math.sqrt(triangles)))
        k = max(1, n // 8)
        profile = np.vstack([_segment((0, -1), (0.5, -1), k), _segment((0.5, -1), (0.5, 1), 2 * k),
                             _segment((0.5, 1), (0, 1), k), [(0.0, 1.0)]])
        mesh, values, size = solids.revolve(profile, n), analytic.cylinder_values(0.5, 2.0), 2.0
    elif name == "cone":
        n = max(6, round(math.sqrt(triangles)))
        k = max(1, n // 6)
        profile = np.vstack([_segment((0, 0), (1, 0), k), _segment((1, 0), (0, 2), 2 * k), [(0.0, 2.0)]])
        mesh, values, size = solids.revolve(profile, n), analytic.cone_values(1.0, 2.0), 2.0
    else:
        raise ValueError(f"unknown smooth solid {name!r}")
    return Case(name, solids.posed(mesh, POSE), size, values.posed(POSE))


SMOOTH_SOLIDS = ("sphere", "cylinder", "cone", "torus", "ellipsoid")


def tessellation_rows(*, quick=False, levels=None, names=None, progress=None):
    """Measure every smooth solid (``names``, default all) at every tessellation level: a list of row dicts."""
    rows = []
    for name in names or SMOOTH_SOLIDS:
        for triangles in levels or (QUICK_LEVELS if quick else FULL_LEVELS):
            rows.append(measure(smooth_solid(name, triangles)))
            if progress:
                progress(rows[-1])
    return rows


# -- the extreme cases -----------------------------------------------------


def _base_part(n=16):
    """An ellipsoid (1, 0.6, 0.35) of about 2n² triangles, rotated generically, centred on the origin."""
    return solids.posed(solids.ellipsoid((1.0, 0.6, 0.35), n, n // 2), Pose(rotation=POSE.rotation))


def _moved(mesh, offset=(0.0, 0.0, 0.0), scale=1.0):
    return TriangleMesh(mesh.vertices * scale + np.asarray(offset, dtype=float), mesh.faces, mesh.source_dtype)


def _float32(mesh):
    """The mesh as a binary STL stores it: every coordinate rounded to float32."""
    return TriangleMesh.from_triangles(mesh.triangles.astype(np.float32), source_dtype=np.float32)


def extreme_cases(*, quick=False):
    """The stiff and extreme cases: a list of :class:`Case` (exact references are computed by ``measure``)."""
    part = _base_part()
    direction = np.array([0.6, -0.64, 0.48])
    cases = [Case(f"offset {k:g} × size", _moved(part, 2.0 * k * direction), 2.0)
             for k in (1, 1e2, 1e4, 1e6, 1e8)]
    cases += [Case(f"scale {s:g}", _moved(part, 2.0 * s * direction, s), 2.0 * s)
              for s in (1e-9, 1e-3, 1e3, 1e9)]
    rotate = Pose(rotation=POSE.rotation)
    cases += [
        Case("plate 1 × 1 × 1e-6, rotated", solids.posed(solids.box((1.0, 1.0, 1e-6)), rotate), 1.0),
        Case("needle 1e-6 × 1e-6 × 1, rotated", solids.posed(solids.box((1e-6, 1e-6, 1.0)), rotate), 1.0),
        Case("plate 1 × 1 × 1e-6 at z = 100", solids.box((1.0, 1.0, 1e-6), (0.0, 0.0, 100.0)), 1.0),
        Case("float32 input at offset 1e5", _float32(_moved(part, (1e5, -0.5e5, 0.25e5))), 2.0),
    ]
    n = 100 if quick else 1000
    big = solids.posed(solids.ellipsoid((1.0, 0.6, 0.35), n, n // 2), POSE)
    cases.append(Case(f"{big.faces.shape[0] // 1000}k triangles", _moved(big, (20.0, 0.0, 0.0)), 2.0))
    return cases


def extreme_rows(*, quick=False, progress=None):
    """Measure every extreme case: a list of row dicts."""
    rows = []
    for case in extreme_cases(quick=quick):
        rows.append(measure(case))
        if progress:
            progress(rows[-1])
    return rows


# -- rendering ---------------------------------------------------------------

TESSELLATION_COLUMNS = ("solid", "triangles", "massprops [s]", "trimesh [s]", "vs smooth: massprops",
                        "vs smooth: trimesh", "vs exact polyhedron: massprops", "vs exact polyhedron: trimesh")
EXTREME_COLUMNS = ("case", "triangles", "massprops error", "massprops bound covers", "trimesh error",
                   "I1+I2≥I3 massprops / trimesh", "massprops [s]", "trimesh [s]")


def _e(x):
    return "inf" if not math.isfinite(x) else ("0" if x == 0 else f"{x:.1e}")


def _yes(flag):
    return "yes" if flag else "**no**"


def table_cells(row, kind):
    """The Markdown cells of one row of the ``tessellation`` or ``extreme`` table."""
    if kind == "tessellation":
        return [row["case"], str(row["triangles"]), f"{row['massprops_s']:.3g}", f"{row['trimesh_s']:.3g}",
                _e(row["massprops_smooth"]["rel_max"]), _e(row["trimesh_smooth"]["rel_max"]),
                _e(row["massprops_exact"]["rel_max"]), _e(row["trimesh_exact"]["rel_max"])]
    return [row["case"], str(row["triangles"]), _e(row["massprops_exact"]["rel_max"]), _yes(row["bound_covers"]),
            _e(row["trimesh_exact"]["rel_max"]),
            f"{_yes(row['massprops_physical'])} / {_yes(row['trimesh_physical'])}",
            f"{row['massprops_s']:.3g}", f"{row['trimesh_s']:.3g}"]


def markdown_table(rows, kind):
    """A Markdown table of rows from :func:`tessellation_rows` or :func:`extreme_rows` (kind names which)."""
    columns = TESSELLATION_COLUMNS if kind == "tessellation" else EXTREME_COLUMNS
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(table_cells(row, kind)) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def _flat(row):
    """One CSV record: every measured number of a row."""
    out = {key: value for key, value in row.items() if not isinstance(value, dict)}
    for key, value in row.items():
        if isinstance(value, dict):
            out.update({f"{key}_{k}": repr(v) for k, v in value.items() if k.startswith("rel_")})
    return out


def csv_text(rows):
    """CSV of rows (every error component, times, checks), header from the first row's keys."""
    records = [_flat(r) for r in rows]
    fields = list(dict.fromkeys(k for r in records for k in r))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows(records)
    return buffer.getvalue()


def rows_from_csv(text):
    """The rows :func:`csv_text` wrote, with what :func:`plot` reads (case, triangles, run times, errors)."""
    rows = []
    for record in csv.DictReader(io.StringIO(text)):
        row = {"case": record["case"], "triangles": int(record["triangles"])}
        for key, value in record.items():
            if key.endswith("_s"):
                row[key] = float(value)
            for tool in ("massprops", "trimesh"):
                for reference in ("smooth", "exact"):
                    prefix = f"{tool}_{reference}_"
                    if key.startswith(prefix) and value != "":
                        row.setdefault(f"{tool}_{reference}", {})[key[len(prefix):]] = float(value)
        rows.append(row)
    return rows


# Errors of exactly 0 are drawn at this floor of the log axis, with hollow markers and a dotted line.
PLOT_FLOOR = 1e-18


def plot(rows, path):
    """Log-log PNG of error against run time: smooth values (left), exact polyhedron (right).

    Both panels share the error axis, which starts at :data:`PLOT_FLOOR`: an
    error of exactly 0 (an exact result) is drawn on that floor with a hollow
    marker.  The legend sits outside the panels, right of them.

    Returns
    -------
    str: ``path``.

    Raises
    ------
    MassPropsError
        matplotlib is not installed.
    """
    from ..plotting import pyplot
    plt = pyplot("the plot", "pip install 'massprops[plot]' (or pass --no-plot)")
    from matplotlib.lines import Line2D
    figure, panels = plt.subplots(1, 2, figsize=(12, 4.8), sharex=True, sharey=True)
    names = list(dict.fromkeys(r["case"] for r in rows))
    colours = dict(zip(names, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    top = PLOT_FLOOR
    for panel, reference, title in ((panels[0], "smooth", "against the smooth analytic solid"),
                                    (panels[1], "exact", "against the exact polyhedron")):
        for name in names:
            mine = [r for r in rows if r["case"] == name]
            for tool, marker, style in (("massprops", "o", "-"), ("trimesh", "x", "--")):
                x = [r[f"{tool}_s"] for r in mine]
                error = [r[f"{tool}_{reference}"]["rel_max"] for r in mine]
                y = [max(e, PLOT_FLOOR) for e in error]
                top = max(top, *y)
                panel.loglog(x, y, linestyle=style, color=colours[name], marker=marker, markersize=5)
                exact = [(xi, PLOT_FLOOR) for xi, e in zip(x, error) if e == 0]
                if exact:
                    panel.plot(*zip(*exact), linestyle="none", marker="o", markersize=9, markerfacecolor="none",
                               markeredgecolor=colours[name], markeredgewidth=1.5)
        panel.axhline(PLOT_FLOOR, color="#777777", linestyle=":", linewidth=1)
        panel.set_title(title)
        panel.set_xlabel("run time [s]")
        panel.set_ylabel("largest relative error [–] (volume, COM, inertia)")
        panel.grid(True, which="major", alpha=0.3)
    panels[0].set_ylim(PLOT_FLOOR / 3, top * 10)
    handles = [Line2D([], [], color=colours[name], label=name) for name in names]
    handles += [Line2D([], [], color="#555555", marker="o", linestyle="-", label="massprops"),
                Line2D([], [], color="#555555", marker="x", linestyle="--", label="trimesh"),
                Line2D([], [], color="#777777", marker="o", markerfacecolor="none", linestyle=":",
                       label=f"error exactly 0 (drawn at {PLOT_FLOOR:g})")]
    figure.legend(handles=handles, loc="center left", bbox_to_anchor=(1.0, 0.5), fontsize=8, frameon=False)
    counts = [r["triangles"] for r in rows]
    figure.suptitle(f"massprops vs trimesh: error against run time, {min(counts)} to {max(counts)} triangles")
    figure.tight_layout()
    figure.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(figure)
    return path
