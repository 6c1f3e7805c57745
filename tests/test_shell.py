"""Thin shells (``--shell THICKNESS``): box surfaces against rectangular-plate closed forms."""

from __future__ import annotations

import itertools
import json
from fractions import Fraction

import numpy as np
import pytest

import massprops.cli
from massprops.validation import solids
from massprops import mass_properties
from massprops.io.stl import write_binary
from massprops.mesh.surface import TriangleMesh

from test_volume import assert_matches  # exact comparison with error-bound coverage

SIZE = (2.0, 3.0, 1.5)
CENTER = (0.5, -1.0, 2.0)


def plates(size, center, *, lid=True):
    """The faces of a box as rectangles: (area, offset from the origin, extents), exact.

    ``lid=False`` leaves out the face at +z.
    """
    half = [Fraction(s) / 2 for s in size]
    out = []
    for axis, sign in itertools.product(range(3), (-1, 1)):
        if not lid and (axis, sign) == (2, 1):
            continue
        extents = [Fraction(s) for s in size]
        extents[axis] = Fraction(0)
        offset = [Fraction(c) for c in center]
        offset[axis] += sign * half[axis]
        area = extents[(axis + 1) % 3] * extents[(axis + 2) % 3]
        out.append((area, offset, extents))
    return out


def sheet_closed_form(size, center, thickness, density, *, lid=True):
    """Mass, center of mass and inertia about it of rectangular plates with area density ρ·t.

    Per plate of area A at offset o: ∫x_i² dA = A (d_i²/12 + o_i²), ∫x_i x_j dA = A o_i o_j (i ≠ j).
    """
    sigma = Fraction(density) * Fraction(thickness)
    rects = plates(size, center, lid=lid)
    mass = sigma * sum(area for area, _, _ in rects)
    com = [sigma * sum(area * o[i] for area, o, _ in rects) / mass for i in range(3)]
    m2 = [[sigma * sum(area * (o[i] * o[j] + (d[i] ** 2 / 12 if i == j else 0)) for area, o, d in rects)
           for j in range(3)] for i in range(3)]
    c = [[m2[i][j] - mass * com[i] * com[j] for j in range(3)] for i in range(3)]
    trace = c[0][0] + c[1][1] + c[2][2]
    return mass, com, [[(trace if i == j else 0) - c[i][j] for j in range(3)] for i in range(3)]


def hollow_box(size, thickness, density):
    """Mass and inertia about the center of a box with walls of ``thickness`` centred on ``size``."""
    def solid(dims):
        m = Fraction(density) * dims[0] * dims[1] * dims[2]
        return m, [m * (dims[1] ** 2 + dims[2] ** 2) / 12, m * (dims[0] ** 2 + dims[2] ** 2) / 12,
                   m * (dims[0] ** 2 + dims[1] ** 2) / 12]
    t = Fraction(thickness)
    outer = solid([Fraction(s) + t for s in size])
    inner = solid([Fraction(s) - t for s in size])
    return outer[0] - inner[0], [a - b for a, b in zip(outer[1], inner[1])]


def test_closed_box_surface_as_shell_is_the_sheet_closed_form():
    props = mass_properties(solids.box(SIZE, CENTER), shell=0.01, density=7850.0).properties
    assert_matches(props, *sheet_closed_form(SIZE, CENTER, 0.01, 7850.0))
    assert props.volume == pytest.approx(0.01 * 2 * (6 + 3 + 4.5), rel=1e-15)


def test_shell_converges_to_the_hollow_box_as_thickness_vanishes():
    """Walls of thickness t centred on the surface: the shell is off by O(t²) relative."""
    previous = None
    for t in (0.1, 0.01, 0.001):
        props = mass_properties(solids.box(SIZE), shell=t).properties
        mass, moments = hollow_box(SIZE, t, 1)
        rel_mass = abs(Fraction(props.mass) - mass) / mass
        rel_inertia = max(abs(Fraction(float(props.inertia_com[k, k])) - moments[k]) / moments[k] for k in range(3))
        assert rel_mass <= (t / min(SIZE)) ** 2 and rel_inertia <= 4 * (t / min(SIZE)) ** 2
        if previous is not None:                     # second order: ten times thinner, ~100 times closer
            assert rel_inertia < previous / 50
        previous = rel_inertia


def test_open_box_as_shell(tmp_path, runner):
    box = solids.box(SIZE, CENTER)
    top = box.vertices[box.faces][:, :, 2].min(axis=1) > CENTER[2]
    open_box = TriangleMesh(box.vertices, box.faces[~top])
    props = mass_properties(open_box, shell=0.002, density=2700.0).properties
    assert_matches(props, *sheet_closed_form(SIZE, CENTER, 0.002, 2700.0, lid=False))
    path = str(tmp_path / "open.stl")
    write_binary(path, open_box.triangles)
    refused = runner.invoke(massprops.cli.main, ["props", path])
    assert refused.exit_code == 1 and "--shell THICKNESS" in refused.stderr
    result = runner.invoke(massprops.cli.main, ["props", path, "--shell", "0.002", "--density", "2700",
                                                "--format", "json"])
    assert result.exit_code == 0, result.output
    obj = json.loads(result.stdout)[0]
    assert obj["checks"]["closed"] is False and obj["checks"]["boundary_edges"] == 4
    assert obj["checks"]["shell_thickness"] == 0.002
    assert obj["mass"] == pytest.approx(float(sheet_closed_form(SIZE, CENTER, 0.002, 2700.0, lid=False)[0]),
                                        rel=1e-14)


def test_shell_ignores_winding_and_mass_option():
    # A sheet has no inside: flipping every face changes nothing; --mass sets ρ·t.
    box = solids.box(SIZE, CENTER)
    flipped = mass_properties(box.flipped(), shell=0.05, mass=3.0).properties
    plain = mass_properties(box, shell=0.05, mass=3.0).properties
    assert flipped.mass == plain.mass == pytest.approx(3.0, rel=1e-15)
    assert np.array_equal(flipped.inertia_com, plain.inertia_com)


def test_shell_refusals(tmp_path, runner):
    box = solids.box()
    doubled = str(tmp_path / "doubled.stl")
    write_binary(doubled, np.vstack([box.triangles, box.triangles[:1]]))
    result = runner.invoke(massprops.cli.main, ["props", doubled, "--shell", "0.1"])
    assert result.exit_code == 1 and "1 faces are duplicated" in result.stderr, result.output
    result = runner.invoke(massprops.cli.main, ["props", doubled, "--shell", "-1"])
    assert result.exit_code == 2 and "--shell" in result.stderr and "must be positive" in result.stderr
    repaired = runner.invoke(massprops.cli.main, ["props", doubled, "--shell", "0.1", "--repair", "--format", "json"])
    assert repaired.exit_code == 0
    assert json.loads(repaired.stdout)[0]["warnings"] == ["removed 1 duplicated face"]
