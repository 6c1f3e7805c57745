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
========================= ===================================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U
from ..frames import Pose
from .model import ELEMENTS, tensor_from_elements

__all__ = ["Tolerances", "Validity", "declared_validity", "Comparison", "compare", "diagnose", "DIAGNOSES"]

DIAGNOSES = ("product_sign", "about_link_origin", "rpy_inverted", "units", "missing_scale", "transcription",
             "triangle_inequality", "not_positive_definite")
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


def diagnose(inertial, props, comparison, tolerances, *, rescaled=None):
    """The diagnoses (names, best first) and their details for a mismatched link.

    ``rescaled`` maps a mesh scale ``s`` to the link's properties with its
    unscaled meshes scaled by ``s`` (and ``"linear:s"`` to those with a scaled
    mesh's factor applied once), at the declared mass: the ``missing_scale`` test.
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
    findings.sort(key=lambda f: (f.residual, DIAGNOSES.index(f.name)))
    names, details = [], []
    for finding in findings:                    # the best explanation of each kind
        if finding.name in names:
            continue
        names.append(finding.name)
        details.append({"name": finding.name, "residual": finding.residual, "message": finding.message,
                        **finding.extra})
    return names, details
