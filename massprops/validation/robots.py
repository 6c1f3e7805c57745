"""Small URDF, SDF and MJCF robots built from the reference solids, with their exact expected inertials.

``massprops solids --robots DIR`` writes them (and ``sample_meshes/robot/``
holds the sample one).  Every link's expected values are computed here in
exact rational arithmetic, independently of the code that reads the robots:
meshes by :func:`massprops.exact.exact_properties` on the coordinates as
written, a mesh ``scale`` applied to the exact moments as the rational
decimal it is, primitives by their closed forms with ``π`` taken as the
rational value of ``math.pi``, poses by the rationals of their float
rotation matrices, several geometries by exact parallel-axis sums (less
the intersection of two overlapping boxes).  Each value is rounded once at
the end.

The robots have clean links (primitives; scaled, rotated and mirrored
meshes; several geometries per link, two of them overlapping; an inertial
frame with a rotation), a frame link, a link without inertial, an open
mesh, and one declared inertial for each mistake
:mod:`massprops.robot.check` diagnoses.  ``expected.json`` says, per format
and link, what ``robot props --density 2700`` computes (``computed``), what
the file declares, and the status and diagnoses ``robot check`` must give.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from .robot_files import (BRACKET, BRACKET_MM, DENSITY, ELEMENTS, OPEN, PACKAGE, PRISM, matrix, mesh_files, mjcf,
                            mul, rational, sdf, transpose, urdf)
from ..robot.model import rpy_rotation

__all__ = ["write_robots", "write_sample", "DENSITY", "PACKAGE"]

_PI = Fraction(math.pi)


@dataclass(frozen=True)
class Shape:
    """One geometry: ``kind``, full-length ``size`` (decimal strings), pose ``xyz``/``rpy``, mesh file and scale."""

    kind: str
    size: dict = field(default_factory=dict)
    xyz: tuple = ("0", "0", "0")
    rpy: tuple = ("0", "0", "0")
    mesh: str | None = None
    scale: tuple | None = None


@dataclass(frozen=True)
class Spec:
    """One link: its shapes, what it declares (``exact``, a mistake's name, or None) and its joint."""

    name: str
    shapes: tuple = ()
    declared: str | None = "exact"
    joint: str = "revolute"
    origin: tuple = ("0", "0", "0.1")
    status: str = "ok"
    diagnoses: tuple = ()
    computes: bool = True


# -- exact values -------------------------------------------------------------------

def _primitive(kind, size):
    """``(volume, center, J)`` of a primitive in its own frame, density 1, Fractions (π as ``Fraction(math.pi)``)."""
    if kind == "box":
        a, b, c = (rational(x) for x in size["size"])
        v = a * b * c
        return v, [0, 0, 0], _diag(v / 12 * (b * b + c * c), v / 12 * (a * a + c * c), v / 12 * (a * a + b * b))
    if kind == "sphere":
        r = rational(size["radius"])
        v = Fraction(4, 3) * _PI * r ** 3
        return v, [0, 0, 0], _diag(*[Fraction(2, 5) * v * r * r] * 3)
    if kind == "ellipsoid":
        a, b, c = (rational(x) for x in size["radii"])
        v = Fraction(4, 3) * _PI * a * b * c
        return v, [0, 0, 0], _diag(v / 5 * (b * b + c * c), v / 5 * (a * a + c * c), v / 5 * (a * a + b * b))
    r, h = rational(size["radius"]), rational(size["length"])
    if kind == "cylinder":
        v = _PI * r * r * h
        side = v * (3 * r * r + h * h) / 12
        return v, [0, 0, 0], _diag(side, side, v * r * r / 2)
    if kind == "cone":                       # base at −h/2, apex at +h/2: center at −h/4
        v = _PI * r * r * h / 3
        side = v * (Fraction(3, 20) * r * r + Fraction(3, 80) * h * h)
        return v, [0, 0, -h / 4], _diag(side, side, Fraction(3, 10) * v * r * r)
    if kind == "capsule":                    # a cylinder and two hemispheres, each about its own center
        cylinder = _primitive("cylinder", size)
        hemisphere = Fraction(2, 3) * _PI * r ** 3
        offset = h / 2 + Fraction(3, 8) * r
        # A hemisphere about its center of mass: 2/5 m r² about the flat face's center, less m (3r/8)² across.
        across = Fraction(2, 5) * hemisphere * r * r - hemisphere * (Fraction(3, 8) * r) ** 2
        caps = [(hemisphere, [0, 0, s * offset], _diag(across, across, Fraction(2, 5) * hemisphere * r * r))
                for s in (1, -1)]
        return _union([cylinder, *caps])
    raise ValueError(kind)


def _diag(a, b, c):
    return [[a, 0, 0], [0, b, 0], [0, 0, c]]


def _union(parts):
    """Disjoint parts ``(volume, center, J about it)`` as one, exactly (parallel axis about the common center)."""
    volume = sum(v for v, _, _ in parts)
    center = [sum(v * c[k] for v, c, _ in parts) / volume for k in range(3)]
    inertia = [[Fraction(0)] * 3 for _ in range(3)]
    for v, c, j in parts:
        d = [c[k] - center[k] for k in range(3)]
        dd = sum(x * x for x in d)
        for i in range(3):
            for k in range(3):
                inertia[i][k] += j[i][k] + v * ((dd if i == k else 0) - d[i] * d[k])
    return volume, center, inertia


def _scaled(values, scale):
    """``(V, c, J)`` of the solid mapped by ``diag(scale)``: ``C' = |det S| S C S`` on ``C = tr(J)/2 I − J``."""
    volume, center, inertia = values
    s = [rational(x) for x in scale]
    det = abs(s[0] * s[1] * s[2])
    trace = sum(inertia[k][k] for k in range(3)) / 2
    second = [[(trace if i == k else 0) - inertia[i][k] for k in range(3)] for i in range(3)]
    second = [[det * s[i] * s[k] * second[i][k] for k in range(3)] for i in range(3)]
    new_trace = sum(second[k][k] for k in range(3))
    return det * volume, [s[k] * center[k] for k in range(3)], \
        [[(new_trace if i == k else 0) - second[i][k] for k in range(3)] for i in range(3)]


def _posed(values, xyz, rpy):
    volume, center, inertia = values
    r = matrix(rpy_rotation([float(rational(a)) for a in rpy]))
    t = [Fraction(float(rational(x))) for x in xyz]
    moved = [sum(r[i][k] * center[k] for k in range(3)) + t[i] for i in range(3)]
    return volume, moved, mul(mul(r, inertia), transpose(r))


def _mesh_values(path):
    from .exact import exact_properties
    from ..io import read
    mesh = read(path)
    exact = exact_properties(mesh.vertices[mesh.faces])
    return exact["volume"], list(exact["center_of_mass"]), exact["inertia_com"]


def exact_link(shapes, meshes, density=DENSITY):
    """``(mass, center, J)`` of a link's shapes at ``density``, exact Fractions in the link frame.

    The shapes are disjoint, except boxes without rotation: where two of those
    overlap, their intersection (a box) is subtracted, so each point counts once.
    """
    parts = []
    for shape in shapes:
        values = _mesh_values(meshes[shape.mesh]) if shape.kind == "mesh" else _primitive(shape.kind, shape.size)
        if shape.scale is not None:
            values = _scaled(values, shape.scale)
        parts.append(_posed(values, shape.xyz, shape.rpy))
    boxes = [s for s in shapes if s.kind == "box" and all(rational(a) == 0 for a in s.rpy)]
    for k, first in enumerate(boxes):
        for second in boxes[k + 1:]:
            common = _box_intersection(first, second)
            if common is not None:
                volume, center, inertia = _posed(_primitive("box", {"size": common[0]}), common[1], ("0", "0", "0"))
                parts.append((-volume, center, [[-x for x in row] for row in inertia]))
    volume, center, inertia = _union(parts)
    rho = Fraction(density)
    return rho * volume, center, [[rho * x for x in row] for row in inertia]


def _box_intersection(first, second):
    """``(size, center)`` of two unrotated boxes' intersection (decimal strings of exact values), or None."""
    size, center = [], []
    for k in range(3):
        low = max(rational(s.xyz[k]) - rational(s.size["size"][k]) / 2 for s in (first, second))
        high = min(rational(s.xyz[k]) + rational(s.size["size"][k]) / 2 for s in (first, second))
        if high <= low:
            return None
        size.append(high - low)
        center.append((low + high) / 2)
    return tuple(map(_decimal, size)), tuple(map(_decimal, center))


def _decimal(value):
    """A Fraction with a finite decimal expansion, as that decimal's text (exact)."""
    text = f"{float(value)!r}"
    if rational(text) != value:
        raise ValueError(f"{value} has no short decimal form")
    return text


def _floats(values):
    mass, center, inertia = values
    return float(mass), [float(x) for x in center], [[float(x) for x in row] for row in inertia]


# -- the robots -------------------------------------------------------------------

_ROTATED = ("0.3", "-0.5", "0.7")        # an inertial frame rotation with no symmetry


def _specs(fmt):
    """The links of the robot in format ``fmt`` (urdf, sdf, mjcf)."""
    tilt = ("0.4", "-0.3", "0.9")
    bracket = Shape("mesh", xyz=("0.01", "-0.02", "0.03"), rpy=tilt, mesh=BRACKET, scale=("0.5", "0.25", "2"))
    specs = [
        Spec("base_link", (Shape("box", {"size": ("0.4", "0.3", "0.1")}, xyz=("0", "0", "0.05")),), joint="root"),
        Spec("bracket", (bracket,)),
        Spec("mirrored", (Shape("mesh", xyz=("0", "0.05", "0"), rpy=("0.2", "0.1", "-0.3"), mesh=BRACKET,
                                scale=("-1", "1", "1")),)),
        Spec("multi", (Shape("cylinder", {"radius": "0.03", "length": "0.2"}, xyz=("0", "0", "0.1")),
                       Shape("sphere", {"radius": "0.05"}, xyz=("0", "0", "0.25")),
                       Shape("mesh", xyz=("0.1", "0", "0"), rpy=("0", "0", "0.5"), mesh=PRISM))),
        # Two boxes that overlap: the link is their union (each point once), as props unites overlapping shells.
        Spec("overlapping", (Shape("box", {"size": ("0.2", "0.1", "0.1")}, xyz=("0.1", "0.05", "0.05")),
                             Shape("box", {"size": ("0.1", "0.15", "0.12")}, xyz=("0.15", "0.1", "0.08")))),
        Spec("rotated_frame", (bracket,), declared="rotated"),
        Spec("tool0", (), declared=None, joint="fixed", status="massless"),
        Spec("sensor", (Shape("box", {"size": ("0.02", "0.03", "0.04")}),), declared=None, status="missing"),
        Spec("open_part", (Shape("mesh", mesh=OPEN),), declared="exact_of_box", status="error", computes=False),
        Spec("flipped", (bracket,), declared="product_sign", status="mismatch", diagnoses=("product_sign",)),
        Spec("about_origin", (Shape("box", {"size": ("0.1", "0.05", "0.02")}, xyz=("0.2", "0.1", "0.05"),
                                    rpy=("0.3", "0.2", "0.1")),), declared="about_link_origin",
             status="mismatch", diagnoses=("about_link_origin",)),
        Spec("inverted", (bracket,), declared="rpy_inverted", status="mismatch", diagnoses=("rpy_inverted",)),
        Spec("millimetres", (bracket,), declared="units", status="mismatch", diagnoses=("units",)),
        Spec("unscaled", (Shape("mesh", xyz=("0.02", "0", "0"), mesh=BRACKET_MM),), declared="missing_scale",
             status="mismatch", diagnoses=("missing_scale",)),
        Spec("typo", (Shape("box", {"size": ("0.1", "0.08", "0.06")}, xyz=("0.05", "0", "0.02"),
                            rpy=("0.5", "0.4", "0.3")),), declared="transcription", status="mismatch", diagnoses=("transcription",)),
        Spec("plate", (Shape("box", {"size": ("0.2", "0.2", "0.002")}),), declared="triangle_inequality",
             status="invalid", diagnoses=("triangle_inequality",)),
        Spec("thin_plate", (Shape("box", {"size": ("0.2", "0.101", "0.000001")}),), declared="rounded_plate",
             status="invalid", diagnoses=("triangle_inequality",)),
        Spec("negative", (bracket,), declared="not_positive_definite", status="invalid",
             diagnoses=("not_positive_definite", "triangle_inequality")),
    ]
    if fmt != "urdf":
        specs.insert(4, Spec("rounded", (Shape("capsule", {"radius": "0.02", "length": "0.1"}, xyz=("0", "0", "0.05")),
                                         Shape("ellipsoid" if fmt == "mjcf" else "cone",
                                               {"radii": ("0.03", "0.02", "0.01")} if fmt == "mjcf" else
                                               {"radius": "0.04", "length": "0.06"},
                                               xyz=("0.1", "0", "0"), rpy=("0.5", "0", "0")))))
    return specs


def _declared(spec, exact, meshes):
    """``(mass, center, written tensor (3×3 floats), rpy, texts)`` the file declares for a spec, from the exact values.

    ``texts`` overrides the decimals of some elements (the rounded plate and the typo).
    """
    mass, center, inertia = exact
    kind = spec.declared
    rpy, texts = ("0", "0", "0"), {}
    tensor = [row[:] for row in inertia]
    if kind == "product_sign":
        tensor = [[x if i == j else -x for j, x in enumerate(row)] for i, row in enumerate(inertia)]
    elif kind == "about_link_origin":
        dd = sum(x * x for x in center)
        tensor = [[inertia[i][j] + mass * ((dd if i == j else 0) - center[i] * center[j]) for j in range(3)]
                  for i in range(3)]
    elif kind in ("rotated", "rpy_inverted"):
        rpy = _ROTATED
        r = matrix(rpy_rotation([float(rational(a)) for a in rpy]))
        # Correct: W = Rᵀ J R.  Inverted: W = R J Rᵀ.
        tensor = mul(mul(transpose(r), inertia), r) if kind == "rotated" else mul(mul(r, inertia), transpose(r))
    elif kind == "units":
        tensor = [[x * 10 ** 6 for x in row] for row in inertia]
    elif kind == "missing_scale":
        # The right values are those of the mesh in metres (scale 0.001), which the file forgot.
        shapes = tuple(Shape(s.kind, s.size, s.xyz, s.rpy, s.mesh, ("0.001",) * 3) for s in spec.shapes)
        mass, center, tensor = exact_link(shapes, meshes)
    elif kind == "transcription":
        texts = _typo(inertia)
    elif kind == "triangle_inequality":
        tensor = [row[:] for row in inertia]
        tensor[2][2] = inertia[2][2] * Fraction(11, 10)
    elif kind == "rounded_plate":
        texts = {name: f"{float(inertia[i][j]):.4g}" for name, (i, j) in ELEMENTS.items()}
    elif kind == "not_positive_definite":
        a = inertia[0][0]
        tensor = [[a, 2 * a, 0], [2 * a, a, 0], [0, 0, a]]
    return mass, center, tensor, rpy, texts


def _typo(inertia):
    """One element with its first significant digit mistyped: the first such element and digit that leaves a
    valid tensor moved by over 15 % of its largest element."""
    tensor = np.array([[float(x) for x in row] for row in inertia])
    scale = float(np.abs(tensor).max())
    for name in ("ixz", "ixy", "iyz", "izz", "iyy", "ixx"):
        i, j = ELEMENTS[name]
        digits = f"{tensor[i, j]:.6e}"
        sign, digits = ("-", digits[1:]) if digits.startswith("-") else ("", digits)
        for first in "123456789":
            typed = sign + first + digits[1:]
            changed = tensor.copy()
            changed[i, j] = changed[j, i] = float(typed)
            moments = np.linalg.eigvalsh(changed)
            if abs(float(typed) - tensor[i, j]) > 0.15 * scale and moments[0] > 0 \
                    and moments[0] + moments[1] > moments[2]:
                return {name: typed}
    raise ValueError("no valid typo")


SAMPLE_LINKS = ("base_link", "bracket", "multi", "overlapping", "tool0", "sensor", "flipped", "thin_plate")


_FILES = {"urdf": ("urdf/robot.urdf", urdf), "sdf": ("sdf/robot.sdf", sdf), "mjcf": ("mjcf/robot.xml", mjcf)}


def _write_format(package, fmt, specs, meshes):
    """Write one format's robot; its entry of ``expected.json``."""
    exact = {s.name: exact_link(s.shapes, meshes) for s in specs if s.shapes and s.computes}
    box = (Shape("box", {"size": ("0.05", "0.05", "0.05")}),)        # what the open mesh's link declares
    declared = {spec.name: _declared(spec, exact.get(spec.name) or exact_link(box, meshes), meshes)
                for spec in specs if spec.declared is not None}
    relative, write = _FILES[fmt]
    texts = {relative: write(specs, declared)}
    if fmt == "mjcf":
        texts["mjcf/robot_geometry.xml"] = mjcf(specs, declared, geometry_only=True)
    for name, text in texts.items():
        os.makedirs(os.path.dirname(os.path.join(package, name)), exist_ok=True)
        with open(os.path.join(package, name), "w", encoding="utf-8", newline="\n") as handle:
            handle.write(text)
    links = {}
    for spec in specs:
        if fmt == "mjcf" and (spec.name == "open_part" or (not spec.shapes and spec.name != "tool0")):
            continue
        entry = {"status": _status(spec, fmt), "diagnoses": list(spec.diagnoses)}
        if spec.name in exact:
            mass, center, inertia = _floats(exact[spec.name])
            entry["computed"] = {"mass": mass, "center_of_mass": center, "inertia_com": inertia}
        links[spec.name] = entry
    return {"model": os.path.join(PACKAGE, relative), "links": links}


def write_robots(directory, *, formats=("urdf", "sdf", "mjcf"), links=None):
    """Write the fixture robots (a ROS package ``massprops_robot``) and ``expected.json`` into ``directory``.

    Parameters
    ----------
    links : sequence of str, optional
        Only these links (all by default).

    Returns
    -------
    dict
        What ``expected.json`` holds.
    """
    directory = os.fspath(directory)
    package = os.path.join(directory, PACKAGE)
    chosen = {fmt: [s for s in _specs(fmt) if links is None or s.name in links] for fmt in formats}
    used = {shape.mesh for specs in chosen.values() for spec in specs for shape in spec.shapes if shape.mesh}
    meshes = mesh_files(os.path.join(package, "meshes"), used)
    with open(os.path.join(package, "package.xml"), "w", encoding="utf-8") as handle:
        handle.write(f'<?xml version="1.0"?>\n<package format="3">\n  <name>{PACKAGE}</name>\n  <version>0.1.0'
                     "</version>\n  <description>massprops robot fixtures</description>\n"
                     "  <maintainer email=\"massprops@example.com\">massprops</maintainer>\n"
                     "  <license>MIT</license>\n</package>\n")
    if "sdf" in formats:
        with open(os.path.join(package, "model.config"), "w", encoding="utf-8") as handle:
            handle.write(f'<?xml version="1.0"?>\n<model>\n  <name>{PACKAGE}</name>\n  <sdf version="1.11">'
                         "sdf/robot.sdf</sdf>\n</model>\n")
    expected = {"density": DENSITY, "package": PACKAGE}
    for fmt in formats:
        expected[fmt] = _write_format(package, fmt, chosen[fmt], meshes)
    with open(os.path.join(directory, "expected.json"), "w", encoding="utf-8", newline="\n") as handle:
        json.dump(expected, handle, indent=1)
        handle.write("\n")
    return expected


def _status(spec, fmt):
    if fmt == "sdf" and spec.name == "rounded":
        return "ok"
    if fmt == "sdf" and spec.status == "missing":
        return "missing"
    return spec.status


def write_sample(directory):
    """The sample robot of ``sample_meshes/robot/``: a few links of the URDF package (clean ones, a frame link,
    a missing inertial, a sign-flipped one, a thin plate written with too few digits)."""
    return write_robots(directory, formats=("urdf",), links=SAMPLE_LINKS)
