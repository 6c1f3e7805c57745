"""Is a declared inertial valid, and does it agree with the link's geometry?  If not, what went wrong?

**Validity**, as simulators test it: every number finite; mass > 0 (or 0 for
a frame link or a fixed base); the tensor positive definite; its principal
moments satisfying ``A + B >= C`` with no tolerance, as MuJoCo tests them
(``user_objects.cc``: eigenvalues of the tensor, then the three sums).  A
violation is *certified*: "real" when no tensor within the rounding of the
written decimals (half a unit in each one's last digit) is valid, else
"within rounding" (write more digits).  ``A + B >= C`` for every ordering is
``(tr J / 2) I − J ⪰ 0`` (that matrix is ``∫ s sᵀ dm``), so both tests are on
a smallest eigenvalue, and Weyl's inequality bounds what the rounding box can
move it.

**Against the geometry**, at equal mass: implied density (declared mass /
volume), center-of-mass distance (absolute, and relative to the diagonal of
the link geometry's box), and ``max|J_declared − J| / max|J|``.

**Diagnoses** try transformations of the computed tensor ``J`` (or of the
geometry) that a known mistake would apply, and name those that turn ``J``
into the declared tensor within ``diagnosis_rtol`` when ``J`` itself is off:

========================= ===================================================================
``product_sign``          the products written with CAD's positive sign (``+∫xy dm``)
``about_link_origin``     the tensor about the link origin, not the center of mass
``rpy_inverted``          the inertial frame's rotation applied the wrong way (transposed,
                          ignored, or the Euler angles composed in the reverse order)
``units``                 a power of ten: mm² (1e6), cm² (1e4), g (1e3), g·mm² (1e9), ...;
                          or a center of mass in mm or cm
``missing_scale``         a mesh read without the scale it needs (mm, cm, inch meshes), or
                          with its scale applied once instead of squared to the inertia
``transcription``         one element (or two swapped) wrong while the others agree
``triangle_inequality``   ``A + B >= C`` violated (validity)
``not_positive_definite`` a principal moment ≤ 0 (validity)
``beyond_geometry``       no density inside the link's geometry gives the declared second moments
``com_outside_geometry``  the declared center of mass is outside the convex hull of the geometry
``non_uniform``           none of the above: the declared values pass every test a density
                          inside the geometry must pass, and differ from the uniform solid's
========================= ===================================================================

**Against the geometry's reach**, certified (:func:`geometry_findings`): the
link's geometry lies inside the convex hull of points ``P`` (mesh vertices;
polytopes around the primitives, :func:`massprops.robot.geometry.enclosing_points`).
For a direction ``n`` let ``a ≤ n·x ≤ b`` over ``P`` (floats widened by
their rounding).  A mass ``m`` inside the geometry with center ``c`` has
``a ≤ n·c ≤ b`` (else ``com_outside_geometry``) and, by the Bhatia–Davis
inequality, ``nᵀΣn ≤ m (b − n·c)(n·c − a)`` with ``Σ = ∫(x−c)(x−c)ᵀ dm =
tr(J)/2 · 1 − J``; and, for an ellipsoid ``E = {x : (x−c₀)ᵀM(x−c₀) ≤ 1}``
holding ``P``, the pseudo-inertia condition of Wensing, Kim and Slotine
(2017), ``tr(J_p Q_E) ≥ 0``, which reads ``tr(M (Σ + m (c−c₀)(c−c₀)ᵀ)) ≤ m``.
A violation of either is ``beyond_geometry``.  Directions: the hull's face
normals, the eigenvectors of ``Σ``, the link axes and 200 spread ones;
ellipsoids: the one around the box of ``P`` and the smallest one around
``P`` (Khachiyan), each scaled until it holds every point with a margin.
The inequalities are evaluated in rationals from the floats.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U
from ..model.frames import Pose
from .model import ELEMENTS, tensor_from_elements

__all__ = ["Tolerances", "Validity", "declared_validity", "Comparison", "compare", "diagnose", "DIAGNOSES", "CAUSES",
           "geometry_findings"]

DIAGNOSES = ("product_sign", "about_link_origin", "rpy_inverted", "units", "missing_scale", "transcription",
             "triangle_inequality", "not_positive_definite", "beyond_geometry", "com_outside_geometry", "non_uniform")
# What usually causes each diagnosis, and what `robot write` would change (one line each at the end of the text).
CAUSES = {
    "product_sign": ("a CAD export of +∫xy dm (URDF, SDF and MJCF want −∫xy dm)",
                     "writes the products with the geometry's sign"),
    "about_link_origin": ("a CAD tool reporting the tensor about the output frame, not the center of mass",
                          "writes the tensor about the center of mass"),
    "rpy_inverted": ("a frame error: the inertial's rotation applied the wrong way",
                     "writes the tensor in link axes with no rotation (or principal axes with --frame principal)"),
    "units": ("a CAD export in mm, cm or g", "writes SI values"),
    "missing_scale": ("a mesh in mm, cm or inches read without its scale",
                      "writes values from the scaled geometry; give the mesh its scale too"),
    "transcription": ("a number typed by hand", "writes every element from the geometry"),
    "triangle_inequality": ("moments rounded or estimated by hand", "writes valid moments from the geometry"),
    "not_positive_definite": ("moments rounded or estimated by hand", "writes valid moments from the geometry"),
    "beyond_geometry": ("rotor inertia of a motor added to the link, a different (larger) CAD model, or a "
                        "collision geometry smaller than the part (compare with --geometry visual)",
                        "writes the geometry's uniform solid, dropping that inertia: keep the declared values if "
                        "the rotor is meant (or give it as the joint's armature)"),
    "com_outside_geometry": ("a frame error (the center of mass in another frame), a different CAD model, or a "
                             "collision geometry smaller than the part",
                             "puts the center of mass inside the geometry, at its centroid"),
    "non_uniform": ("several materials (motors, batteries, metal and plastic) in a multi-material CAD model",
                    "replaces it with a uniform solid of the same mass, usually a worse estimate: keep it"),
}
_UNIT_FACTORS = {1e6: "the tensor in kg·mm² (×1e6)", 1e4: "the tensor in kg·cm² (×1e4)",
                 1e3: "a factor 1e3 (g for kg, or a length scale applied once instead of squared)",
                 1e9: "the tensor in g·mm² (×1e9)", 1e7: "the tensor in g·cm² (×1e7)",
                 1e-6: "a factor 1e-6 (m² where mm² was meant)", 1e-4: "a factor 1e-4",
                 1e-3: "a factor 1e-3 (kg for g)", 1e-9: "a factor 1e-9", 1e-7: "a factor 1e-7"}
_LENGTH_FACTORS = {1e3: "mm", 1e2: "cm", 1e-3: "km for m", 1 / 0.0254: "inches"}
MESH_SCALES = {0.001: "millimetres", 0.01: "centimetres", 0.0254: "inches"}


@dataclass(frozen=True)
class Tolerances:
    """When a declared inertial counts as agreeing with the geometry.

    ``inertia_rtol``: ``max|ΔJ| / max|J|``; ``com_rtol``: COM distance over the
    link size; ``diagnosis_rtol``: how close a transformed ``J`` must come to the
    declared tensor for its diagnosis to be named.
    """

    inertia_rtol: float = 0.1
    com_rtol: float = 0.1
    diagnosis_rtol: float = 0.02


@dataclass(frozen=True)
class Validity:
    """What is wrong with a declared inertial on its own: problems (messages) and validity diagnoses."""

    problems: tuple = ()
    diagnoses: tuple = ()
    details: tuple = ()
    massless: bool = False

    @property
    def valid(self):
        return not self.problems


def _half_units(written):
    """Half a unit in the last written digit of each tensor element (3×3 Fractions)."""
    half = [[Fraction(0)] * 3 for _ in range(3)]
    index = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}
    for name, (i, j) in index.items():
        half[i][j] = half[j][i] = written[name].half_unit
    return half


def _rounding_reach(half):
    """How far the rounding box of the written decimals can move the smallest eigenvalue of J and of C.

    Weyl: ``|Δλ| ≤ ‖ΔJ‖₂ ≤ ‖H‖_F`` (H the half-units, off-diagonals counted
    twice); ``ΔC = tr(ΔJ)/2 I − ΔJ`` adds ``(h_xx + h_yy + h_zz)/2``.
    """
    frobenius = math.sqrt(sum(float(h) * float(h) for row in half for h in row))      # x * x: inf, never OverflowError
    return frobenius, frobenius + sum(float(half[k][k]) for k in range(3)) / 2


def declared_validity(inertial, *, massless_allowed, massless_reason=""):
    """:class:`Validity` of a declared inertial (not ``auto``)."""
    mass = inertial.mass.value
    written = inertial.written
    numbers = [mass, *inertial.center_of_mass, *(v.value for v in written.values())]
    if not all(math.isfinite(v) for v in numbers):
        return Validity(("a number is not finite (NaN or infinity)",))
    tensor = tensor_from_elements({k: v.value for k, v in written.items()})
    if mass == 0:
        # A frame link or a fixed base: simulators ignore its tensor (pybullet: mass 0 is static).
        if massless_allowed:
            return Validity(massless=True)
        return Validity(("mass 0 on a link that has geometry and moves — label it massless ({massless=GLOB}) "
                         "or give its mass",))
    if mass <= 0:
        return Validity((f"mass {inertial.mass.text} is not positive",))
    problems, diagnoses, details = [], [], []
    moments = np.linalg.eigvalsh(tensor)
    reach_j, reach_c = _rounding_reach(_half_units(written))
    # A diagonal tensor's eigenvalues are its entries, exactly; otherwise allow the eigen-solver its rounding.
    diagonal = not np.any(tensor - np.diag(np.diag(tensor)))
    solver = 0.0 if diagonal else 16 * _U * float(np.abs(tensor).max())
    if moments[0] <= 0:
        real = moments[0] + reach_j + solver <= 0
        problems.append(f"not positive definite: smallest principal moment {moments[0]:.6g}")
        diagnoses.append("not_positive_definite")
        details.append({"name": "not_positive_definite", "smallest_moment": float(moments[0]),
                        "certified": "real" if real else "within rounding", "rounding_reach": reach_j,
                        "message": _certified_text(real, reach_j)})
    a, b, c = moments
    if a + b < c:
        if diagonal:
            # Exactly: the smallest A + B − C of the written values, against the digits' half-units.
            entries = [Fraction(float(x)) for x in np.diag(tensor)]
            slack = min(sum(entries) - 2 * e for e in entries)
            real = slack + sum(_half_units(written)[k][k] for k in range(3)) < 0
        else:
            central = np.linalg.eigvalsh(0.5 * np.trace(tensor) * np.eye(3) - tensor)[0]
            real = central + reach_c + solver < 0
        problems.append(f"principal moments violate A + B >= C: {a:.9g} + {b:.9g} < {c:.9g} "
                        f"(by {c - a - b:.3g})")
        diagnoses.append("triangle_inequality")
        details.append({"name": "triangle_inequality", "violation": float(c - a - b),
                        "certified": "real" if real else "within rounding", "rounding_reach": reach_c,
                        "message": _certified_text(real, reach_c)})
    return Validity(tuple(problems), tuple(diagnoses), tuple(details))


def _certified_text(real, reach):
    if real:
        return f"real: more than the rounding of the written decimals can explain (±{reach:.2g})"
    return (f"within the rounding of the written decimals (±{reach:.2g}): the solid may be valid; "
            "write more digits (`massprops robot write`)")


@dataclass(frozen=True)
class Comparison:
    """Declared against computed, at the declared mass."""

    implied_density: float
    com_distance: float
    com_distance_relative: float
    inertia_difference: float
    mismatched: tuple = ()

    def as_dict(self):
        return {"implied_density": self.implied_density, "com_distance": self.com_distance,
                "com_distance_relative": self.com_distance_relative,
                "inertia_difference": self.inertia_difference}


def _relative(declared, computed):
    scale = float(np.abs(computed).max())
    difference = float(np.abs(np.asarray(declared) - np.asarray(computed)).max())
    return difference / scale if scale else (0.0 if difference == 0 else math.inf)


def compare(inertial, props, size, tolerances):
    """:class:`Comparison` of a declared inertial with computed ``props`` (already at the declared mass)."""
    distance = float(np.linalg.norm(inertial.center_of_mass - props.center_of_mass))
    relative_distance = distance / size if size > 0 else (0.0 if distance == 0 else math.inf)
    difference = _relative(inertial.inertia_com, props.inertia_com)
    mismatched = []
    if relative_distance > tolerances.com_rtol:
        mismatched.append("center_of_mass")
    if difference > tolerances.inertia_rtol:
        mismatched.append("inertia")
    return Comparison(inertial.mass.value / props.volume, distance, relative_distance, difference,
                      tuple(mismatched))


@dataclass
class _Finding:
    name: str
    residual: float
    message: str
    extra: dict = field(default_factory=dict)


def _tensor_candidates(inertial, props):
    """``(name, tensor in link axes that the mistake would have written, what)`` for the tensor-level mistakes."""
    computed, mass, com = props.inertia_com, inertial.mass.value, props.center_of_mass
    rotation = inertial.rotation
    in_written = rotation.T @ computed @ rotation
    flipped = -in_written
    np.fill_diagonal(flipped, np.diag(in_written))
    yield "product_sign", rotation @ flipped @ rotation.T, \
        "the products of inertia have the opposite sign (CAD's +∫xy dm convention): write −∫xy dm"
    for label, point in (("computed", com), ("declared", inertial.center_of_mass)):
        shifted = computed + mass * (float(point @ point) * np.eye(3) - np.outer(point, point))
        yield "about_link_origin", shifted, \
            f"the tensor is about the link origin, not the center of mass ({label} COM): subtract m(|c|²I − ccᵀ)"
    if not np.allclose(rotation, np.eye(3), rtol=0, atol=1e-12):
        # W written; D = R W Rᵀ read.  Transposed: W = R J Rᵀ.  Ignored: W = J.
        yield "rpy_inverted", rotation @ (rotation @ computed @ rotation.T) @ rotation.T, \
            "the inertial frame's rotation was applied the wrong way (transposed): write Rᵀ J R"
        yield "rpy_inverted", rotation @ computed @ rotation.T, \
            "the tensor is in link axes but an inertial rotation (rpy) is given: drop the rpy or rotate the tensor"
        if inertial.rpy is not None:
            r, p, y = inertial.rpy
            reverse = Pose.from_euler("zyx", [y, p, r], degrees=False).rotation      # Rx(r) Ry(p) Rz(y)
            written = reverse.T @ computed @ reverse
            yield "rpy_inverted", rotation @ written @ rotation.T, \
                "the rpy angles were composed in the reverse order (Rx Ry Rz): URDF's is R = Rz(y) Ry(p) Rx(r)"
    for factor, what in _UNIT_FACTORS.items():
        yield "units", computed * factor, f"{what}: divide by {factor:g}"


def _leading_digits(value, count=3):
    """The first ``count`` significant digits of ``|value|`` and its decimal exponent."""
    text = f"{abs(value):.{count - 1}e}"
    mantissa, _, exponent = text.partition("e")
    return mantissa.replace(".", ""), int(exponent)


def _significant(value):
    """Significant digits of a float's shortest decimal form."""
    mantissa = repr(abs(float(value))).partition("e")[0].replace(".", "").lstrip("0")
    return len(mantissa.rstrip("0")) or 1


def mistyped(written, expected, tolerance):
    """How ``written`` looks like a mistyped ``expected``, or None: a wrong sign, a slipped decimal point, one
    digit wrong or two neighbours swapped in the leading three.  A written 0 is an omission, not a typo."""
    if written == 0 or expected == 0:
        return None
    if abs(written + expected) <= tolerance * abs(expected):
        return "its sign is wrong"
    ratio = abs(written / expected)
    power = round(math.log10(ratio))
    if power and abs(ratio / 10.0 ** power - 1) <= tolerance:
        return f"its decimal point has slipped by {power:+d} place(s)"
    (a, ea), (b, eb) = _leading_digits(written), _leading_digits(expected)
    if ea != eb or (written > 0) != (expected > 0) or min(_significant(written), _significant(expected)) < 3:
        return None         # a value of one or two digits is a guess or a round number, not a transcription
    differ = [k for k in range(len(a)) if a[k] != b[k]]
    if len(differ) == 1:
        return "one digit is wrong"
    if len(differ) == 2 and differ[1] == differ[0] + 1 and a[differ[0]] == b[differ[1]] \
            and a[differ[1]] == b[differ[0]]:
        return "two digits are swapped"
    return None


def _transcription(inertial, props, tolerance):
    """One written element mistyped (or two elements swapped) while the others agree, in the written axes."""
    rotation = inertial.rotation
    expected = rotation.T @ props.inertia_com @ rotation
    scale = float(np.abs(expected).max())
    index = {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}
    written = {name: inertial.written[name].value for name in ELEMENTS}
    off = {name: abs(written[name] - expected[i, j]) / scale for name, (i, j) in index.items()}
    wrong = [name for name in ELEMENTS if off[name] > tolerance]
    if len(wrong) == 1:
        name = wrong[0]
        i, j = index[name]
        how = mistyped(written[name], expected[i, j], tolerance)
        if how is None:
            return None
        return _Finding("transcription", max(off[n] for n in ELEMENTS if n != name),
                        f"{name} = {inertial.written[name].text} but the geometry gives {expected[i, j]:.6g} "
                        f"while the other elements agree: {how}", {"elements": [name]})
    if len(wrong) == 2:
        a, b = wrong
        (ia, ja), (ib, jb) = index[a], index[b]
        if abs(written[a] - expected[ib, jb]) / scale <= tolerance and \
                abs(written[b] - expected[ia, ja]) / scale <= tolerance:
            return _Finding("transcription", 0.0, f"{a} and {b} are swapped", {"elements": [a, b]})
    return None


def _com_findings(inertial, props, size, tolerance):
    declared, computed = inertial.center_of_mass, props.center_of_mass
    if not np.any(declared) or not np.any(computed):
        return
    for factor, unit in _LENGTH_FACTORS.items():
        if float(np.abs(declared - factor * computed).max()) <= tolerance * float(np.abs(declared).max()):
            yield _Finding("units", 0.0, f"the center of mass looks like it is in {unit} (×{factor:g})")
    reach = max(size, float(np.abs(computed).max()), 1e-300)
    wrong = [k for k in range(3) if abs(declared[k] - computed[k]) > tolerance * reach]
    if len(wrong) == 1:
        k = wrong[0]
        how = mistyped(declared[k], computed[k], tolerance)
        if how is not None:
            yield _Finding("transcription", 0.0, f"the center of mass's {'xyz'[k]} = {declared[k]:.6g} but the "
                                                  f"geometry gives {computed[k]:.6g}, the others agree: {how}")


def _spread_directions(count=200):
    """``count`` unit vectors spread over the sphere (a Fibonacci lattice)."""
    k = np.arange(count) + 0.5
    z = 1 - 2 * k / count
    phi = k * math.pi * (3 - 5 ** 0.5)
    rho = np.sqrt(1 - z * z)
    return np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])


def _smallest_ellipsoid(points, steps=200):
    """Khachiyan's smallest enclosing ellipsoid, roughly: ``(c₀, M)`` with ``(x−c₀)ᵀM(x−c₀) ≤ ~1`` on the points."""
    n = points.shape[0]
    q = np.vstack([points.T, np.ones(n)])
    u = np.full(n, 1.0 / n)
    for _ in range(steps):
        x = q @ (u[:, None] * q.T)
        reach = ((q.T @ np.linalg.inv(x)) * q.T).sum(axis=1)
        j = int(np.argmax(reach))
        step = (reach[j] - 4) / (4 * (reach[j] - 1))
        if step < 1e-4:
            break
        u *= 1 - step
        u[j] += step
    centre = points.T @ u
    spread = points.T @ (u[:, None] * points) - np.outer(centre, centre)
    return centre, np.linalg.inv(spread) / 3


def _enclosing(points, margin, centre, matrix):
    """``matrix`` scaled so the ellipsoid at ``centre`` holds every point widened by ``margin`` (None if it fails)."""
    if not np.all(np.isfinite(matrix)):
        return None
    matrix = (matrix + matrix.T) / 2
    top = float(np.linalg.eigvalsh(matrix).max())
    if not top > 0 or float(np.linalg.eigvalsh(matrix).min()) <= 0:
        return None
    d = points - centre
    q = float(((d @ matrix) * d).sum(axis=1).max())
    radius = (math.sqrt(q) * (1 + 1e-9) + math.sqrt(top) * margin * 2) * (1 + 1e-9)
    return matrix / (radius * radius)


def geometry_findings(inertial, points, margin):
    """``(findings, tests)``: ``beyond_geometry`` and ``com_outside_geometry`` findings (see the module docstring),
    and a description of the tests passed (for ``non_uniform``)."""
    m = Fraction(float(inertial.mass.value))
    c = inertial.center_of_mass
    j = inertial.inertia_com
    cf = [Fraction(float(x)) for x in c]
    jf = [[Fraction(float(x)) for x in row] for row in j]
    half = sum(jf[k][k] for k in range(3)) / 2
    sigma = [[(half if a == b else 0) - jf[a][b] for b in range(3)] for a in range(3)]
    sigma_float = 0.5 * np.trace(j) * np.eye(3) - j
    directions = [np.eye(3), -np.eye(3), _spread_directions()]
    try:
        from scipy.spatial import ConvexHull
        hull = ConvexHull(points)
        directions.append(hull.equations[:, :3])
        corners = points[hull.vertices]
    except Exception:  # noqa: BLE001 - a flat or degenerate cloud: spread directions only
        corners = points
    if np.all(np.isfinite(sigma_float)):
        directions.append(np.linalg.eigh(sigma_float)[1].T)
    away = c - corners.mean(axis=0)
    if np.any(away):
        directions.append(away[None, :] / np.linalg.norm(away))
    directions = np.vstack(directions)
    projected = corners @ directions.T
    slack = margin + 8 * _U * float(np.abs(corners).max()) * 3
    high = projected.max(axis=0) + slack
    low = projected.min(axis=0) - slack
    findings = []
    worst_out, worst_ratio = None, None
    # Floats first, pessimistic by far more than their rounding (δ): only the directions that may violate a
    # test are decided in rationals.
    delta = 1e-9 * max(float(np.abs(corners).max()), float(np.abs(c).max()), 1e-300)
    mu_f = directions @ c
    variance_f = ((directions @ sigma_float) * directions).sum(axis=1)
    allowed_f = float(m) * np.maximum(high - mu_f - delta, 0) * np.maximum(mu_f - low - delta, 0)
    candidates = (mu_f > high - delta) | (mu_f < low + delta) | (variance_f * (1 + 1e-9) >= allowed_f)
    for k in np.flatnonzero(candidates):
        n = directions[k]
        nf = [Fraction(float(x)) for x in n]
        mu = sum(a * b for a, b in zip(nf, cf))
        b, a = Fraction(float(high[k])), Fraction(float(low[k]))
        if mu > b or mu < a:
            out = float(max(mu - b, a - mu))
            if worst_out is None or out > worst_out[0]:
                worst_out = (out, n)
            continue
        variance = sum(nf[p] * sigma[p][q] * nf[q] for p in range(3) for q in range(3))
        allowed = m * (b - mu) * (mu - a)
        if variance > allowed:
            ratio = float(variance / allowed) if allowed > 0 else math.inf
            if worst_ratio is None or ratio > worst_ratio[0]:
                worst_ratio = (ratio, n)
    if worst_out is not None:
        out, n = worst_out
        findings.append(_Finding("com_outside_geometry", None,
                                 f"the declared center of mass is {out:.3g} m outside the convex hull of the link's "
                                 f"geometry (along {_direction(n)}): no mass inside the geometry has it",
                                 {"distance": out}))
    ellipsoids = []
    low_box, high_box = corners.min(axis=0), corners.max(axis=0)
    box_half = np.maximum((high_box - low_box) / 2, 1e-300)
    ellipsoids.append(((low_box + high_box) / 2, np.diag(1 / (3 * box_half ** 2))))
    if corners.shape[0] >= 4:
        try:
            ellipsoids.append(_smallest_ellipsoid(corners))
        except np.linalg.LinAlgError:
            pass
    pseudo = None
    for centre, matrix in ellipsoids:
        matrix = _enclosing(points, margin + 8 * _U * float(np.abs(points).max()), centre, matrix)
        if matrix is None:
            continue
        mf = [[Fraction(float(x)) for x in row] for row in matrix]
        d = [cf[k] - Fraction(float(centre[k])) for k in range(3)]
        moment = sum(mf[p][q] * (sigma[q][p] + m * d[q] * d[p]) for p in range(3) for q in range(3))
        if moment > m:
            ratio = float(moment / m)
            if pseudo is None or ratio > pseudo:
                pseudo = ratio
    if worst_ratio is not None or pseudo is not None:
        parts = []
        if worst_ratio is not None:
            parts.append(f"along {_direction(worst_ratio[1])} its second moment is {worst_ratio[0]:.3g}× the most "
                         "any mass inside the geometry's extent can have")
        if pseudo is not None:
            parts.append(f"it needs {pseudo:.3g}× the mass-weighted spread an ellipsoid holding the geometry allows "
                         "(pseudo-inertia test)")
        findings.append(_Finding("beyond_geometry", None, "the declared inertia needs mass farther out than the "
                                 "link's geometry reaches: " + "; ".join(parts),
                                 {"ratio": max(worst_ratio[0] if worst_ratio else 0.0, pseudo or 0.0)}))
    tests = (f"the center of mass inside the geometry's convex hull and the second moments within its reach along "
             f"{len(directions)} directions and inside {len(ellipsoids)} ellipsoids holding it")
    return findings, tests


def _valid_tensor(tensor):
    """Positive semi-definite with ``A + B >= C`` to within the eigen-solver's rounding (a rod's tensor, whose
    smallest moment is 0, included): a tensor some mass distribution has, or nearly."""
    if not np.all(np.isfinite(tensor)):
        return False
    slack = 16 * _U * float(np.abs(tensor).max())
    return bool(np.linalg.eigvalsh(tensor)[0] >= -slack and np.linalg.eigvalsh(0.5 * np.trace(tensor) * np.eye(3)
                                                                               - tensor)[0] >= -slack)


def _direction(n):
    n = np.asarray(n, float)
    k = int(np.argmax(np.abs(n)))
    if abs(abs(n[k]) - 1) < 1e-12:
        return ("+" if n[k] > 0 else "-") + "xyz"[k]
    return "[" + ", ".join(f"{x:.2f}" for x in n) + "]"


def diagnose(inertial, props, comparison, tolerances, *, rescaled=None, enclosure=None):
    """The diagnoses (names, best first) and their details for a mismatched link.

    ``rescaled`` maps a mesh scale ``s`` to the link's properties with its
    unscaled meshes scaled by ``s`` (and ``"linear:s"`` to those with a scaled
    mesh's factor applied once), at the declared mass: the ``missing_scale`` test.
    ``enclosure`` ``(points, margin)`` holds the link's geometry: the tests of
    :func:`geometry_findings`; a mismatch nothing else explains is then
    ``non_uniform`` or one of those.
    """
    tolerance = tolerances.diagnosis_rtol
    findings = []
    if "inertia" in comparison.mismatched:
        for name, tensor, message in _tensor_candidates(inertial, props):
            residual = _relative(inertial.inertia_com, tensor)
            if residual <= tolerance:
                findings.append(_Finding(name, residual, message))
        found = _transcription(inertial, props, tolerance)
        if found is not None:
            findings.append(found)
    if "center_of_mass" in comparison.mismatched:
        size = comparison.com_distance / comparison.com_distance_relative if comparison.com_distance_relative \
            else 0.0
        findings += list(_com_findings(inertial, props, size, tolerance))
    for key, other in (rescaled or {}).items():
        tensor_residual = _relative(inertial.inertia_com, other.inertia_com)
        reach = max(float(np.abs(other.center_of_mass).max()), 1e-300)
        com_residual = float(np.abs(inertial.center_of_mass - other.center_of_mass).max()) / reach
        if tensor_residual <= tolerance and com_residual <= max(tolerance, tolerances.com_rtol):
            if str(key).startswith("linear:"):
                factor = float(str(key).partition(":")[2])
                message = (f"the inertia was scaled by the mesh scale {factor:g} once instead of squared "
                           "(linear instead of quadratic scaling)")
            else:
                message = (f"a mesh looks like it is in {MESH_SCALES.get(float(key), key)}: with "
                           f"scale=\"{float(key):g} {float(key):g} {float(key):g}\" it matches")
            findings.append(_Finding("missing_scale", tensor_residual, message, {"scale": key}))
    if any(f.name == "missing_scale" for f in findings):
        findings = [f for f in findings if f.name != "units"]
    if not findings and enclosure is not None and enclosure[0] is not None and _valid_tensor(inertial.inertia_com):
        # Nothing a known mistake would do explains it: what can a density inside the geometry give?
        found, tests = geometry_findings(inertial, *enclosure)
        if not found:
            found = [_Finding("non_uniform", None, f"consistent with some non-uniform density inside the geometry "
                                                  f"(it passes the tests every such density must: {tests}), not "
                                                  "with a uniform solid")]
        findings += found
    findings.sort(key=lambda f: (math.inf if f.residual is None else f.residual, DIAGNOSES.index(f.name)))
    names, details = [], []
    for finding in findings:                    # the best explanation of each kind
        if finding.name in names:
            continue
        names.append(finding.name)
        detail = {"name": finding.name, "residual": finding.residual, "message": finding.message, **finding.extra}
        if finding.residual is None:             # a certified test, not a transformation's closeness
            del detail["residual"]
        details.append(detail)
    return names, details
