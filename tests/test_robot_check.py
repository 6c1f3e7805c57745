"""Validity of declared inertials (as MuJoCo tests it, and certified against the written digits), and the
nudge that keeps a thin plate's written moments valid."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from massprops.robot.check import declared_validity
from massprops.robot.model import ELEMENTS, Decimal, Inertial, tensor_from_elements
from massprops.robot.write import nudged

U = 2.0 ** -53


def _inertial(mass, **texts):
    written = {name: Decimal.parse(texts.get(name, "0"), what=name) for name in ELEMENTS}
    tensor = tensor_from_elements({k: v.value for k, v in written.items()})
    return Inertial(Decimal.parse(str(mass), what="mass"), np.zeros(3), tensor, np.eye(3), written)


@pytest.mark.parametrize("text,half", [("0.001584", Fraction(1, 2 * 10 ** 6)), ("1.5e-3", Fraction(1, 2 * 10 ** 4)),
                                       ("12", Fraction(0)), ("0", Fraction(0)), ("-2.50", Fraction(1, 200)),
                                       ("3.", Fraction(1, 2))])
def test_half_unit_of_the_last_written_digit(text, half):
    assert Decimal.parse(text, what="x").half_unit == half


def test_a_valid_tensor_passes():
    assert declared_validity(_inertial(1, ixx="0.2", iyy="0.3", izz="0.4", ixy="-0.01"),
                             massless_allowed=False).valid


def test_triangle_inequality_violation_is_real_when_the_digits_cannot_explain_it():
    validity = declared_validity(_inertial(1, ixx="0.100", iyy="0.100", izz="0.250"), massless_allowed=False)
    assert validity.diagnoses == ("triangle_inequality",)
    assert validity.details[0]["certified"] == "real"
    # One digit each: "0.1" may stand for 0.149, and 0.149 + 0.149 >= 0.25 — within the rounding.
    coarse = declared_validity(_inertial(1, ixx="0.1", iyy="0.1", izz="0.25"), massless_allowed=False)
    assert coarse.details[0]["certified"] == "within rounding"


def test_triangle_inequality_violation_within_the_rounding_of_the_digits():
    # A thin plate 0.2 × 0.101: A + B = C exactly; four digits each round A and B down and C up.
    validity = declared_validity(_inertial(5.454e-05, ixx="4.636e-08", iyy="1.818e-07", izz="2.282e-07"),
                                 massless_allowed=False)
    assert validity.diagnoses == ("triangle_inequality",)
    assert validity.details[0]["certified"] == "within rounding"


def test_triangle_inequality_is_tested_with_no_tolerance():
    # A + B falls short of C by one unit in the last place: MuJoCo refuses it, and so do we.
    c = 0.3
    a = 0.1
    b = float(np.nextafter(c - a, 0.0))
    assert a + b < c
    validity = declared_validity(_inertial(1, ixx=repr(a), iyy=repr(b), izz=repr(c)), massless_allowed=False)
    assert "triangle_inequality" in validity.diagnoses


def test_full_tensor_triangle_inequality_uses_its_eigenvalues():
    # Diagonal entries satisfy A + B >= C but the principal moments of the rotated plate do not.
    rotation = np.array([[0.6, -0.8, 0.0], [0.8, 0.6, 0.0], [0.0, 0.0, 1.0]])
    tensor = rotation @ np.diag([0.1, 0.1, 0.25]) @ rotation.T
    texts = {name: repr(float(tensor[i, j])) for name, (i, j) in
             zip(ELEMENTS, [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)])}
    assert tensor[0, 0] + tensor[2, 2] >= tensor[1, 1]
    assert "triangle_inequality" in declared_validity(_inertial(1, **texts), massless_allowed=False).diagnoses


def test_not_positive_definite_and_mass():
    negative = declared_validity(_inertial(1, ixx="0.100", iyy="0.100", izz="0.100", ixy="0.200"),
                                 massless_allowed=False)
    assert negative.diagnoses[0] == "not_positive_definite" and negative.details[0]["certified"] == "real"
    assert declared_validity(_inertial(0), massless_allowed=True).massless
    assert not declared_validity(_inertial(0), massless_allowed=False).valid
    assert not declared_validity(_inertial(-1, ixx="1", iyy="1", izz="1"), massless_allowed=True).valid
    assert not declared_validity(_inertial("nan", ixx="1", iyy="1", izz="1"), massless_allowed=True).valid


def _slack(tensor):
    a, b, c = np.linalg.eigvalsh(tensor)
    return a + b - c


@settings(max_examples=40, deadline=None)
@given(st.floats(0.05, 2.0), st.floats(0.05, 2.0), st.floats(1e-12, 1e-7),
       st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1), st.floats(0.1, 1)))
def test_nudge_makes_a_thin_plate_valid_by_a_few_ulps(a, b, thickness, quaternion):
    from massprops.model.frames import Pose
    mass = 1.0
    plate = mass / 12 * np.diag([b * b + thickness ** 2, a * a + thickness ** 2, a * a + b * b])
    rotation = Pose.from_quat(quaternion).rotation
    tensor = rotation @ plate @ rotation.T
    tensor = (tensor + tensor.T) / 2
    written, delta = nudged(tensor, 0.0)
    assert _slack(written) > 0 and np.linalg.eigvalsh(written)[0] > 0
    largest = float(np.abs(tensor).max())
    assert delta <= 64 * np.spacing(largest) + 1e-300
    # The written decimals read back to the same floats and pass the strict test.
    texts = {name: repr(float(written[i, j])) for name, (i, j) in
             zip(ELEMENTS, [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)])}
    assert declared_validity(_inertial(1, **texts), massless_allowed=False).valid


def test_no_nudge_when_there_is_room():
    tensor = np.diag([0.2, 0.3, 0.4])
    written, delta = nudged(tensor, 0.0)
    assert delta == 0.0 and np.array_equal(written, tensor)


@pytest.mark.parametrize("written,expected,how", [
    (-0.0123, 0.0123, "sign"), (0.123, 0.0123, "decimal point"), (0.00123, 0.0123, "decimal point"),
    (0.0153, 0.0123, "one digit"), (0.0132, 0.0123, "swapped"), (0.0, 0.0123, None), (0.0456, 0.0123, None),
    (0.0124, 0.0123, "one digit")])
def test_what_counts_as_a_typo(written, expected, how):
    from massprops.robot.check import mistyped
    found = mistyped(written, expected, 0.02)
    assert (found is None) if how is None else (how in found)


def test_a_value_written_with_one_digit_is_no_typo():
    from massprops.robot.check import mistyped
    assert mistyped(-0.03, -0.02, 0.02) is None
