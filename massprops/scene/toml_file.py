"""The TOML scene format (described in the README): parts, frames, a report request.

A part is one placement (``position``, ``rotation``) or, for the same mesh
placed many times, a compact list of placements read in bulk with numpy:
``instances = "FILE.csv"`` (columns ``name?, x, y, z, qw?, qx?, qy?, qz?``; or a
``.npy`` array of those numbers)
or inline ``positions = [[x, y, z], ...]`` with optional
``quaternions = [[w, x, y, z], ...]`` and ``names = [...]``.
"""

from __future__ import annotations

import math
import os

import numpy as np

from ..model.errors import MassPropsError, MeshFormatError, reason
from ..model.frames import Pose, quat_to_matrix
from ..model.properties import unit_factor
from .model import DEFAULT_QUANTITIES, Frame, Part, Placements, ReportRequest, Scene

__all__ = ["toml_scene", "read_instances"]

_RESERVED = ("origin", "com", "total")
_PART_KEYS = {"mesh", "density", "mass", "position", "rotation", "density_field", "density_map",
              "instances", "positions", "quaternions", "names"}
_FRAME_KEYS = {"position", "rotation", "part"}
_REPORT_KEYS = {"parts", "total", "quantities", "principal", "about", "unit"}
_ROTATION_FORMS = ('give exactly one of quaternion = [w, x, y, z], euler = [a, b, c] with sequence = "ZYX" '
                   '(degrees; lower case extrinsic, upper case intrinsic), or matrix = [[...], [...], [...]]')
_CSV_COLUMNS = ("name", "x", "y", "z", "qw", "qx", "qy", "qz")
_CSV_FIX = ("write a header row name,x,y,z,qw,qx,qy,qz (name and the quaternion optional), "
            "then one instance per row")


def toml_scene(path, density):
    """Parse a TOML scene: ``[parts.NAME]``, ``[frames.NAME]``, ``[report]``."""
    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib
    try:
        with open(path, "rb") as handle:
            data = tomllib.load(handle)
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise MeshFormatError(f"not valid TOML ({exc})", path=path, fix="fix the scene file's syntax") from None
    where = "the scene"
    try:
        _known(data, {"parts", "frames", "report"})
        folder = os.path.dirname(path)
        parts = []
        for name, spec in _table(data, "parts").items():
            where = f"part {name!r}"
            parts.append(_toml_part(name, spec, folder, density))
        where = "the scene"
        if not parts:
            raise MeshFormatError("no parts", fix="add a [parts.NAME] table with mesh = \"file.stl\"")
        where = None
        frames, report = _frames_and_report(data, parts)
    except MassPropsError as exc:
        raise (exc if where is None else exc.with_context(where)).with_path(exc.path or path) from None
    return Scene(path, tuple(parts), frames, report)


def _frames_and_report(data, parts):
    """Named frames and the report; instance names are listed only when a frame or ``about`` needs them."""
    frames_spec, report_spec = _table(data, "frames"), _table(data, "report")
    names = set()
    if frames_spec or report_spec.get("about"):
        names = {name for part in parts for name in part.instance_names()}
        if len(names) < sum(part.count for part in parts):
            raise MeshFormatError("two parts or instances have the same name", fix="give every instance its own name")
    frames = {}
    for name, spec in frames_spec.items():
        try:
            frames[name] = _toml_frame(name, spec, names)
        except MassPropsError as exc:
            raise exc.with_context(f"frame {name!r}") from None
    try:
        report = _toml_report(report_spec, set(frames) | names)
    except MassPropsError as exc:
        raise exc.with_context("[report]") from None
    return frames, report


def _table(data, key):
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise MeshFormatError(f"{key!r} must be a table", fix=f"write it as [{key}.NAME] sections")
    return value


def _known(spec, keys):
    if not isinstance(spec, dict):
        raise MeshFormatError("must be a table of keys")
    unknown = sorted(set(spec) - keys)
    if unknown:
        raise MeshFormatError(f"unknown key {unknown[0]!r}", fix=f"use {', '.join(sorted(keys))}")


def _toml_pose(spec):
    position = spec.get("position", [0.0, 0.0, 0.0])
    if not (isinstance(position, list) and len(position) == 3 and all(_is_number(v) for v in position)):
        raise MeshFormatError(f"position must be 3 finite numbers, got {position!r}", fix="write position = [x, y, z]")
    rotation = spec.get("rotation")
    if rotation is None:
        return Pose(translation=np.asarray(position, dtype=float))
    forms = {"quaternion": {"quaternion"}, "euler": {"euler", "sequence"}, "matrix": {"matrix"}}
    keys = set(rotation) if isinstance(rotation, dict) else set()
    form = next((name for name, need in forms.items() if keys == need), None)
    values = rotation.get(form) if form else None
    flat = [v for row in values for v in (row if isinstance(row, list) else [row])] if isinstance(
        values, list) else [values]
    shaped = form != "matrix" or (len(values) == 3 and all(isinstance(row, list) and len(row) == 3 for row in values))
    if form is None or not shaped or not all(_is_number(v) for v in flat):
        raise MeshFormatError(f"cannot read rotation {rotation!r} (finite numbers in the right shape are needed)",
                              fix=_ROTATION_FORMS)
    if form == "euler":
        if not isinstance(rotation["sequence"], str):
            raise MeshFormatError("the Euler sequence must be a string", fix=_ROTATION_FORMS)
        return Pose.from_euler(rotation["sequence"], rotation["euler"], degrees=True, translation=position)
    if form == "quaternion":
        return Pose.from_quat(rotation["quaternion"], translation=position)
    return Pose.from_matrix(rotation["matrix"], translation=position)


def _is_number(value):
    """A finite TOML number (TOML has nan and inf literals; neither is a coordinate, a density or an angle)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _toml_part(name, spec, folder, density):
    _known(spec, _PART_KEYS)
    if name in _RESERVED:
        raise MeshFormatError(f"the name {name!r} is reserved", fix="rename the part")
    mesh = spec.get("mesh")
    if not isinstance(mesh, str) or not mesh:
        raise MeshFormatError("needs mesh = \"path\" (relative to the scene file)")
    for key in ("density", "mass"):
        if key in spec and not _is_number(spec[key]):
            raise MeshFormatError(f"{key} must be a finite number, got {spec[key]!r}")
    field, mapping = _cell_densities(spec)
    mass = spec.get("mass")
    # A density field gives every cell its density: the scene's default density does not apply.
    default = None if mass is not None or field is not None else density
    placements = _placements(spec, folder)
    return Part(name, os.path.normpath(os.path.join(folder, mesh)),
                _toml_pose(spec) if placements is None else Pose(), density=spec.get("density", default),
                mass=mass, density_field=field, density_map=mapping, placements=placements)


def _cell_densities(spec):
    """``density_field = "NAME"`` and ``density_map = {GROUP = VALUE, ...}`` of a volume-mesh part."""
    field, mapping = spec.get("density_field"), spec.get("density_map")
    if field is not None and not (isinstance(field, str) and field):
        raise MeshFormatError(f"density_field must name a cell-data array, got {field!r}")
    if field is not None and "density" in spec:
        raise MeshFormatError("give density or density_field, not both")
    if mapping is not None and not (isinstance(mapping, dict) and mapping
                                    and all(_is_number(v) for v in mapping.values())):
        raise MeshFormatError(f"cannot read density_map {mapping!r}",
                              fix='write density_map = { steel = 7850, "2" = 2700 } (group names or tags)')
    return field, None if mapping is None else {str(k): float(v) for k, v in mapping.items()}


def _placements(spec, folder):
    """The compact list of instances, or None for a part placed once."""
    compact = [key for key in ("instances", "positions", "quaternions", "names") if key in spec]
    if not compact:
        return None
    if "position" in spec or "rotation" in spec:
        raise MeshFormatError(f"give position/rotation (one placement) or {compact[0]} (many), not both")
    if "instances" in spec:
        if len(compact) > 1:
            raise MeshFormatError(f"give instances = \"FILE.csv\" or {compact[1]}, not both")
        if not isinstance(spec["instances"], str) or not spec["instances"]:
            raise MeshFormatError("instances must name a .csv or .npy file", fix=_CSV_FIX)
        return read_instances(os.path.normpath(os.path.join(folder, spec["instances"])))
    if "positions" not in spec:
        raise MeshFormatError(f"{compact[0]} needs positions = [[x, y, z], ...]")
    positions = _number_rows(spec, "positions", 3)
    quaternions = _number_rows(spec, "quaternions", 4) if "quaternions" in spec else None
    names = spec.get("names")
    if names is not None and not (isinstance(names, list) and all(isinstance(n, str) and n for n in names)):
        raise MeshFormatError("names must be a list of strings")
    for key, rows in (("quaternions", quaternions), ("names", names)):
        if rows is not None and len(rows) != len(positions):
            raise MeshFormatError(f"{key} has {len(rows)} entries but positions has {len(positions)}")
    return _checked_placements(positions, quaternions, names, lambda k: f"entry {k}")


def _number_rows(spec, key, width):
    rows = spec[key]
    if not (isinstance(rows, list) and rows):
        raise MeshFormatError(f"{key} must be a list of [{', '.join(['…'] * width)}] rows")
    values = np.array(rows, dtype=object)
    if values.shape != (len(rows), width) or not all(_is_number(v) for v in values.flat):
        bad = next(k for k, row in enumerate(rows) if not (isinstance(row, list) and len(row) == width
                                                           and all(_is_number(v) for v in row)))
        raise MeshFormatError(f"{key} entry {bad} is not {width} finite numbers: {rows[bad]!r}")
    return values.astype(float)


def _checked_placements(positions, quaternions, names, row_name):
    """Placements from arrays; a non-finite value or a zero quaternion is named by ``row_name(k)``."""
    quaternions = np.tile([1.0, 0.0, 0.0, 0.0], (len(positions), 1)) if quaternions is None else quaternions
    bad = ~np.isfinite(positions).all(axis=1) | ~np.isfinite(quaternions).all(axis=1)
    if bad.any():
        raise MeshFormatError(f"{row_name(int(np.flatnonzero(bad)[0]))}: a value is not finite",
                              fix="give finite numbers")
    zero = ~((quaternions * quaternions).sum(axis=1) > 0)
    if zero.any():
        raise MeshFormatError(f"{row_name(int(np.flatnonzero(zero)[0]))}: a quaternion of zero length is no "
                              "rotation", fix="give w,x,y,z with w=1 for none")
    if names is not None and len(set(names)) < len(names):
        seen = set()
        first = next(k for k, n in enumerate(names) if n in seen or seen.add(n))
        raise MeshFormatError(f"{row_name(first)}: the name {names[first]!r} is used twice",
                              fix="give every instance its own name")
    return Placements(quat_to_matrix(quaternions), positions, None if names is None else tuple(names))


def read_instances(path):
    """Read a CSV file of instances: a header, then one row per instance.

    Columns, in any order: ``x, y, z`` (position, mesh units), optionally
    ``qw, qx, qy, qz`` (rotation, scalar first, normalised here; identity if
    absent) and ``name`` (no commas; default ``PART[k]``).  Blank lines and
    lines starting with ``#`` are skipped.  A ``.npy`` file holds the same
    numbers without names, shape (n, 3) or (n, 7): ``x, y, z[, qw, qx, qy, qz]``
    (read without parsing text: for very many instances).

    Returns
    -------
    Placements
    """
    from ..io.inputs import check_input, check_no_holes
    binary = path.lower().endswith(".npy")
    info = check_input(path, what="instances file")
    if binary:
        _check_npy_size(path, info.st_size)
    else:
        check_no_holes(path, info)
    try:
        if binary:
            values = np.load(path, allow_pickle=False)
        else:
            with open(path, encoding="utf-8") as handle:
                text = handle.read()
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        raise MeshFormatError(f"cannot read the instances file ({reason(exc, 'not readable')})", path=path,
                              fix="check the path (relative to the scene file)") from None
    try:
        if binary:
            return _instances_from_array(values)
        return _instances_from_rows(*_data_lines(text))
    except MassPropsError as exc:
        raise exc.with_path(path) from None


def _check_npy_size(path, size):
    """Refuse a ``.npy`` whose header declares more data than the file holds (numpy would allocate it first)."""
    from numpy.lib import format as npy
    try:
        with open(path, "rb") as handle:
            version = npy.read_magic(handle)
            read_header = npy.read_array_header_1_0 if version == (1, 0) else npy.read_array_header_2_0
            shape, _, dtype = read_header(handle)
            data_start = handle.tell()
    except (ValueError, OSError, EOFError, SyntaxError) as exc:
        raise MeshFormatError(f"not a readable .npy file ({exc})", path=path,
                              fix="save x, y, z[, qw, qx, qy, qz] per row with numpy.save") from None
    need = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if need > size - data_start:
        raise MeshFormatError(f"the .npy header says shape {shape} ({need} bytes of {dtype}), but the file holds "
                              f"{size - data_start} bytes of data", path=path,
                              fix="the file is truncated or damaged; save it again")


def _instances_from_array(values):
    if values.ndim != 2 or values.shape[1] not in (3, 7) or values.shape[0] == 0 or values.dtype.kind not in "fiu":
        raise MeshFormatError(f"an array of shape {values.shape} and type {values.dtype}, not numbers (n, 3) "
                              "or (n, 7)", fix="save x, y, z[, qw, qx, qy, qz] per row with numpy.save")
    values = values.astype(np.float64)
    return _checked_placements(values[:, :3], values[:, 3:] if values.shape[1] == 7 else None, None,
                               lambda k: f"row {k}")


def _data_lines(text):
    """The header, the data rows, and the line number of every row (1-based, as an editor shows them)."""
    lines = text.rstrip().splitlines()
    # The usual file has no comments and no blank lines: then no per-line test is needed.
    if "#" in text or not all(lines):
        kept = [(number, line) for number, line in enumerate(lines, 1)
                if line.strip() and not line.lstrip().startswith("#")]
        lines, numbers = [line for _, line in kept], [number for number, _ in kept]
    else:
        numbers = range(1, len(lines) + 1)
    if len(lines) < 2:
        raise MeshFormatError("no instances (a header row and at least one row are needed)", fix=_CSV_FIX)
    return lines[0], lines[1:], numbers


def _instances_from_rows(header_line, rows, numbers):
    header = [column.strip().lower() for column in header_line.split(",")]
    quaternion = [c for c in ("qw", "qx", "qy", "qz") if c in header]
    if not set(header) <= set(_CSV_COLUMNS) or len(set(header)) < len(header) or not {"x", "y", "z"} <= set(
            header) or len(quaternion) in (1, 2, 3):
        raise MeshFormatError(f"line {numbers[0]}: cannot read the header {header_line!r}", fix=_CSV_FIX)
    # Counting all commas at once is exact when every row has the header's width; else find the row.
    if "".join(rows).count(",") != len(rows) * (len(header) - 1):
        k, width = next((k, line.count(",") + 1) for k, line in enumerate(rows)
                        if line.count(",") != len(header) - 1)
        raise MeshFormatError(f"line {numbers[k + 1]}: {width} columns, the header has {len(header)}",
                              fix=_CSV_FIX)
    numeric = [header.index(c) for c in ("x", "y", "z", *quaternion)]
    try:
        values = np.loadtxt(rows, delimiter=",", usecols=numeric, ndmin=2, dtype=float)
    except ValueError:
        k, column = _first_bad_number(rows, numeric)
        raise MeshFormatError(f"line {numbers[k + 1]}: {header[column]} = {rows[k].split(',')[column].strip()!r} "
                              "is not a number", fix=_CSV_FIX) from None
    names = None
    if "name" in header:
        column = header.index("name")
        names = [line.split(",", column + 1)[column].strip() for line in rows]
        if not all(names):
            raise MeshFormatError(f"line {numbers[names.index('') + 1]}: the name is empty", fix=_CSV_FIX)
    return _checked_placements(values[:, :3], values[:, 3:] if quaternion else None, names,
                               lambda k: f"line {numbers[k + 1]}")


def _first_bad_number(rows, numeric):
    """(row, column) of the first entry that is not a number (the error path only)."""
    for k, line in enumerate(rows):
        row = line.split(",")
        for column in numeric:
            try:
                float(row[column])
            except ValueError:
                return k, column
    return 0, numeric[0]


def _toml_frame(name, spec, part_names):
    _known(spec, _FRAME_KEYS)
    if name in part_names or name in _RESERVED:
        raise MeshFormatError(f"the name {name!r} is already a part's or reserved", fix="rename the frame")
    part = spec.get("part")
    if part is not None and part not in part_names:
        raise MeshFormatError(f"is attached to unknown part {part!r}", fix="name a part or an instance")
    return Frame(name, _toml_pose(spec), part)


def _toml_report(spec, frame_names):
    _known(spec, _REPORT_KEYS)
    quantities = spec.get("quantities", sorted(DEFAULT_QUANTITIES))
    bad = [q for q in quantities if not isinstance(q, str) or q not in DEFAULT_QUANTITIES] if isinstance(
        quantities, list) and quantities else [quantities]
    if bad:
        raise MeshFormatError(f"unknown quantity {bad[0]!r}", fix=f"pick from {', '.join(sorted(DEFAULT_QUANTITIES))}")
    principal = spec.get("principal", "total")
    scopes = {True: {"total"}, False: set(), "none": set(), "total": {"total"}, "parts": {"parts"},
              "all": {"total", "parts"}}
    if not isinstance(principal, (bool, str)) or principal not in scopes:
        raise MeshFormatError(f"principal = {principal!r} is not understood",
                              fix="use \"total\", \"parts\", \"all\", \"none\", true or false")
    about = spec.get("about", [])
    unknown = [a for a in about if not isinstance(a, str) or a not in frame_names] if isinstance(
        about, list) else [about]
    if unknown:
        raise MeshFormatError(f"about names unknown frame or part {unknown[0]!r}",
                              fix="name frames from [frames.NAME] or parts from [parts.NAME]")
    if about and "inertia" not in quantities:
        raise MeshFormatError("about needs the inertia", fix='add "inertia" to quantities')
    unit = spec.get("unit")
    if unit is not None:
        unit_factor(unit)
    flags = {key: spec.get(key, True) for key in ("parts", "total")}
    if not all(isinstance(v, bool) for v in flags.values()):
        raise MeshFormatError("parts and total must be true or false")
    return ReportRequest(flags["parts"], flags["total"], frozenset(quantities), frozenset(scopes[principal]),
                         tuple(about), unit)
