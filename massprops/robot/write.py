"""Write ``<inertial>`` elements computed from the geometry, changing no other byte of the file.

Only the bytes of each selected link's ``<inertial>`` element are replaced
(or a new one inserted right after the link's start tag).  The frame written is, by default, the
center of mass with no rotation and the full tensor in link axes (importers
often mishandle the inertial frame's rotation); ``frame="principal"`` writes
the principal moments with the rotation of the principal axes.  Numbers are
Python's shortest round-trip form (``repr``): they read back as the same
floats.

The written decimals are read back and must pass the strict checks
(:func:`massprops.robot.check.declared_validity`, with a margin of a few
units in the last place so that any eigen-solver agrees).  A thin plate's
exact tensor sits on ``A + B = C``; rounding can tip it over, so its moments
are nudged by ``δ`` (``J + δ I`` raises ``A + B − C`` by ``δ``), the
smallest such, and the nudge is reported with the tensor's error bound.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field, replace
from fnmatch import fnmatchcase

import numpy as np

from ..model.errors import MassPropsError, OptionError, option
from .check import declared_validity
from .model import Decimal, Inertial, rotation_rpy

__all__ = ["WriteResult", "write_inertials", "FRAMES", "nudged"]

FRAMES = ("link", "principal")
_MARGIN_ULPS = 8


@dataclass
class WriteResult:
    """The new bytes and what was written (one dict per link, with its ``file``) or left alone (with the
    reason, and ``failed`` when the link was asked for but could not be written).

    ``data`` is the model file's new bytes; ``files`` maps every file that changed (the model file, or
    the included MJCF or xacro files that hold the inertials) to its new bytes.
    """

    data: bytes
    written: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    spans: list = field(default_factory=list)
    analysis: dict | None = None
    files: dict = field(default_factory=dict)


def _text(value):
    value = float(value)
    return "0" if value == 0 else repr(value)


def _triangle_slack(tensor):
    """``A + B − C`` for the principal moments of ``tensor`` (floats, as a reader's eigen-solver finds them)."""
    a, b, c = np.linalg.eigvalsh(tensor)
    return a + b - c, a, c


def nudged(tensor, bound):
    """``(tensor + δI, δ)`` with the smallest ``δ ≥ 0`` that leaves ``A + B − C`` and ``A`` a margin.

    The margin is ``8`` units in the last place of ``C``, so a reader's eigen-solver
    (its own rounding a few units) still finds the triangle inequality true.
    """
    tensor = np.array(tensor, dtype=float)
    slack, smallest, largest = _triangle_slack(tensor)
    margin = _MARGIN_ULPS * math.ulp(max(abs(largest), 1e-300))
    if slack >= margin and smallest >= margin:
        return tensor, 0.0
    delta = max(margin - slack, margin - smallest, 0.0)
    for _ in range(60):
        candidate = tensor + delta * np.eye(3)
        slack, smallest, _ = _triangle_slack(candidate)
        if slack >= margin and smallest >= margin:
            return candidate, delta
        delta = 2 * delta if delta else margin
    raise MassPropsError("cannot make the tensor satisfy A + B >= C by a small nudge", fix="check the geometry")


def _values(entry, frame):
    """``(center, rotation, tensor in the written axes, rpy)`` of a computed link entry, for the frame asked."""
    center = np.array(entry["center_of_mass"], dtype=float)
    tensor = np.array(entry["inertia_com"], dtype=float)
    tensor = (tensor + tensor.T) / 2
    if frame == "principal":
        rotation = np.array(entry["principal_axes"], dtype=float).T     # columns: the principal axes, link axes
        return center, rotation, np.diag(entry["principal_moments"]), rotation_rpy(rotation)
    return center, np.eye(3), tensor, (0.0, 0.0, 0.0)


_ORDER = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}


def _element_text(model, mass, center, tensor, rotation, rpy, indent, unit, newline):
    """The new element's text in the model's format (its first line unindented: it replaces bytes in place)."""
    e = {name: _text(tensor[i, j]) for name, (i, j) in _ORDER.items()}
    xyz = " ".join(_text(v) for v in center)
    pad, inner = indent, indent + unit
    if model.format == "urdf":
        lines = ["<inertial>", f'{inner}<origin xyz="{xyz}" rpy="{" ".join(_text(v) for v in rpy)}"/>',
                 f'{inner}<mass value="{_text(mass)}"/>',
                 f'{inner}<inertia ixx="{e["ixx"]}" ixy="{e["ixy"]}" ixz="{e["ixz"]}" iyy="{e["iyy"]}" '
                 f'iyz="{e["iyz"]}" izz="{e["izz"]}"/>', f"{pad}</inertial>"]
    elif model.format == "sdf":
        deeper = inner + unit
        lines = ["<inertial>", f"{inner}<pose>{xyz} {' '.join(_text(v) for v in rpy)}</pose>",
                 f"{inner}<mass>{_text(mass)}</mass>", f"{inner}<inertia>",
                 *(f"{deeper}<{name}>{e[name]}</{name}>" for name in _ORDER), f"{inner}</inertia>",
                 f"{pad}</inertial>"]
    else:
        if np.allclose(rotation, np.eye(3), rtol=0, atol=0):
            full = " ".join(e[k] for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
            lines = [f'<inertial pos="{xyz}" mass="{_text(mass)}" fullinertia="{full}"/>']
        else:
            from ..model.frames import Pose
            quat = " ".join(_text(v) for v in Pose(rotation).as_quat())
            diagonal = " ".join(e[k] for k in ("ixx", "iyy", "izz"))
            lines = [f'<inertial pos="{xyz}" quat="{quat}" mass="{_text(mass)}" diaginertia="{diagonal}"/>']
    return newline.join(lines)


def _indentation(data, offset):
    """The whitespace between the line start and ``offset``."""
    line_start = data.rfind(b"\n", 0, offset) + 1
    prefix = data[line_start:offset]
    return prefix.decode("utf-8", "replace") if not prefix.strip() else ""


def _unit(data, link):
    """The file's indentation step, from the link's own children (two spaces when it has none)."""
    if link.span is None or link.insert_at is None:
        return "  "
    own = _indentation(data, link.span[0])
    body = data[link.insert_at:link.span[1]]
    for line in body.split(b"\n")[1:]:
        stripped = line.lstrip(b" \t")
        if stripped and not stripped.startswith(b"</"):
            step = line[:len(line) - len(stripped)].decode("utf-8", "replace")
            if step.startswith(own) and len(step) > len(own):
                return step[len(own):]
            break
    return "  "


def _edit(model, link, text_for, data, newline):
    """``(start, end, new bytes)`` replacing the link's inertial, or inserting one."""
    unit = _unit(data, link)
    if link.declared is not None and link.declared.span is not None:
        start, end = link.declared.span
        indent = _indentation(data, start)
        return start, end, text_for(indent, unit).encode("utf-8")
    if link.span is None:
        raise MassPropsError(f"link {link.name!r}: its element could not be located in the model's files "
                             "(an unnamed body in an included file, or an element made by an entity)",
                             fix="give the element a name, or write the file that defines it")
    # A link with geometry has children, so its start tag is never self-closing: insert after it.
    indent = _indentation(data, link.span[0]) + unit
    content = link.insert_at
    return content, content, (newline + indent + text_for(indent, unit)).encode("utf-8")


def _selected(analysis, link, links_glob, all_links):
    """``(entry, None)`` for a link to write, else ``(None, why)`` (``why`` empty for a link not asked for)."""
    entry = next(e for e in analysis["links"] if e["link"] == link.name)
    status = entry["status"]
    if links_glob is not None:
        wanted = any(fnmatchcase(link.name, g) for g in links_glob)
    else:
        wanted = all_links or status in ("missing", "invalid")
    if not wanted:
        return None, ""
    if status == "error":
        return None, f"not computed: {entry['message']}"
    if entry.get("mass") is None:
        return None, "no geometry with volume to compute it from"
    return entry, None


def _planned(model, link, entry, frame, data, newline, path):
    """``(edit, record)`` for one selected link: the bytes to put in, and what was written (nudge and all)."""
    center, rotation, tensor, rpy = _values(entry, frame)
    bound = entry["error"]["inertia_com"]
    tensor, delta = nudged(tensor, bound)
    mass = entry["mass"]
    validity = declared_validity(_read_back(mass, center, tensor, rotation, rpy), massless_allowed=False)
    if not validity.valid:
        raise MassPropsError(f"link {link.name!r}: the values to write fail the checks: "
                             f"{'; '.join(validity.problems)}", path=path)

    def text_for(indent, unit):
        return _element_text(model, mass, center, tensor, rotation, rpy, indent, unit, newline)

    edit = (*_edit(model, link, text_for, data, newline), link.name)
    record = {"link": link.name, "before": entry["status"], "mass": mass, "center_of_mass": list(center),
              "frame": frame, "nudge": delta, "warnings": list(entry.get("warnings") or [])}
    if delta:
        record["nudge_note"] = (f"moments raised by {delta:.3g} kg·m² ({delta / math.ulp(np.abs(tensor).max()):.0f} "
                                "ulp) so that A + B >= C survives rounding; "
                                + ("within" if delta <= bound else "beyond") + f" the error bound {bound:.2g}")
    return edit, record


def write_inertials(path, settings, *, links_glob=None, all_links=False, frame="link", expand=False):
    """Compute and write the selected links' inertials; returns a :class:`WriteResult` (nothing is saved here).

    Parameters
    ----------
    settings : massprops.robot.analyze.RobotSettings
        ``command`` "check" semantics select the links (default: ``missing`` and ``invalid``).
    links_glob : sequence of str, optional
        Write exactly the links matching these globs (with geometry).
    all_links : bool
        Write every link with geometry.
    frame : {"link", "principal"}
    expand : bool
        For a ``.xacro`` file: write into the expanded URDF (``data``) instead of the ``.xacro`` files.
    """
    from .analyze import _analyzed, prepare
    if frame not in FRAMES:
        raise OptionError(f"unknown frame {frame!r}", fix=f"use {' or '.join(FRAMES)}")
    start = time.perf_counter()
    settings = replace(settings, command="check", declared_only=False)
    prepared = prepare(path, settings)
    model = prepared.model
    if model.writable is not None:
        raise MassPropsError(f"cannot write this file: {model.writable}", path=path)
    analysis = _analyzed(prepared, settings, start)
    if expand:
        from .xacro_sources import expanded
        if "expanded" not in model.extra:
            raise OptionError(f"{option('expand')} writes the expanded URDF of a .xacro file; this is a "
                              f"{model.format.upper()} file", path=path, fix=f"leave out {option('expand')}")
        model = expanded(model)
        if model.writable is not None:
            raise MassPropsError(f"cannot write the expanded URDF: {model.writable}", path=path)
    main = os.path.abspath(model.path)
    sources = dict(model.extra.get("sources") or {})
    sources.setdefault(main, model.source)
    link_files = model.extra.get("link_files") or {}
    unwritable = model.extra.get("unwritable") or {}
    result = WriteResult(model.source, analysis=analysis)
    edits = {}
    for link in model.links:
        entry, reason = _selected(analysis, link, links_glob, all_links)
        if entry is None:
            if reason:
                result.skipped.append({"link": link.name, "reason": reason, "failed": reason.startswith("not ")})
            continue
        if link.name in unwritable:
            result.skipped.append({"link": link.name, "reason": f"{unwritable[link.name]}; the values: "
                                   f"{_inline(entry, frame)}", "failed": True})
            continue
        file = link_files.get(link.name, main)
        data = sources[file]
        newline = "\r\n" if b"\r\n" in data else "\n"
        try:
            edit, record = _planned(model, link, entry, frame, data, newline, path)
        except MassPropsError as exc:
            result.skipped.append({"link": link.name, "reason": exc.problem, "failed": True})
            continue
        edits.setdefault(file, []).append(edit)
        record["file"] = file
        result.written.append(record)
    for file, changes in edits.items():
        data, pieces, cursor = sources[file], [], 0
        for begin, end, new, name in sorted(changes):
            pieces += [data[cursor:begin], new]
            if file == main:
                result.spans.append((begin, end, len(new), name))
            cursor = end
        pieces.append(data[cursor:])
        result.files[file] = b"".join(pieces)
    result.data = result.files.get(main, model.source)
    return result


def _inline(entry, frame):
    """The URDF ``<inertial>`` to write, on one line (what a macro's arguments must produce)."""
    center, rotation, tensor, rpy = _values(entry, frame)
    e = {name: _text(tensor[i, j]) for name, (i, j) in _ORDER.items()}
    return (f'<inertial><origin xyz="{" ".join(_text(v) for v in center)}" rpy="{" ".join(_text(v) for v in rpy)}"/>'
            f'<mass value="{_text(entry["mass"])}"/><inertia '
            + " ".join(f'{name}="{e[name]}"' for name in _ORDER) + "/></inertial>")


def _read_back(mass, center, tensor, rotation, rpy):
    """The Inertial a reader gets from the decimals written (each one's text parsed back)."""
    written = {name: Decimal(_text(tensor[i, j]), float(_text(tensor[i, j]))) for name, (i, j) in _ORDER.items()}
    return Inertial(Decimal(_text(mass), float(_text(mass))), np.array([float(_text(v)) for v in center]),
                    rotation @ tensor @ rotation.T, rotation, written, tuple(rpy))
