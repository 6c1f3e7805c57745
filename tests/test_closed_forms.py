"""Closed forms, rotated so that products of inertia are non-zero (a sign error must show)."""

import math

import numpy as np
import pytest

from conftest import random_rotation
from massprops.validation import solids
from massprops import mass_properties
from massprops.mesh.surface import TriangleMesh


def rotated(mesh, rotation, offset=(0.0, 0.0, 0.0)):
    return TriangleMesh(mesh.vertices @ rotation.T + np.asarray(offset), mesh.faces)


def assert_tensor_close(actual, expected, rtol=1e-13):
    scale = np.abs(expected).max()
    assert np.abs(np.asarray(actual) - expected).max() <= rtol * scale, (actual, expected)


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_box(seed):
    a, b, c = 1.0, 2.0, 3.0
    rotation = random_rotation(seed)
    props = mass_properties(rotated(solids.box((a, b, c)), rotation, (5.0, -2.0, 1.0)), density=2.5).properties
    mass = 2.5 * a * b * c
    expected = rotation @ np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) @ rotation.T * mass / 12
    assert props.mass == pytest.approx(mass, rel=1e-14)
    assert np.abs(expected - np.diag(np.diag(expected))).max() > 0.1   # products of inertia present
    assert_tensor_close(props.inertia_com, expected)
    np.testing.assert_allclose(props.center_of_mass, [5.0, -2.0, 1.0], rtol=0, atol=1e-14)
    # J_xy = −∫ x y dm: for a box stretched along x = y the product is negative.
    diagonal = rotated(solids.box((4.0, 1.0, 1.0)), np.array([[1, -1, 0], [1, 1, 0], [0, 0, math.sqrt(2)]]) / math.sqrt(2))
    assert mass_properties(diagonal).properties.inertia_com[0, 1] < 0


@pytest.mark.parametrize("seed", [21, 22])
def test_regular_tetrahedron(seed):
    edge = 2.0
    points = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float) * edge / (2 * math.sqrt(2))
    props = mass_properties(rotated(solids.tetrahedron(points), random_rotation(seed), (1.0, 2.0, 3.0))).properties
    volume = edge ** 3 / (6 * math.sqrt(2))
    assert props.volume == pytest.approx(volume, rel=1e-14)
    assert_tensor_close(props.inertia_com, np.eye(3) * volume * edge ** 2 / 20)


@pytest.mark.parametrize("n", [3, 5, 8, 64])
def test_regular_prism(n):
    radius, height = 1.5, 2.0
    rotation = random_rotation(n)
    props = mass_properties(rotated(solids.regular_prism(n, radius, height), rotation, (0.0, 7.0, 0.0))).properties
    theta = 2 * math.pi / n
    volume = n / 2 * radius ** 2 * math.sin(theta) * height
    axial = volume * radius ** 2 * (2 + math.cos(theta)) / 6
    transverse = volume * (radius ** 2 * (2 + math.cos(theta)) / 12 + height ** 2 / 12)
    expected = rotation @ np.diag([transverse, transverse, axial]) @ rotation.T
    assert props.volume == pytest.approx(volume, rel=1e-13)
    assert_tensor_close(props.inertia_com, expected)
    moments = np.sort([transverse, transverse, axial])
    np.testing.assert_allclose(props.principal.moments, moments, rtol=1e-13)
