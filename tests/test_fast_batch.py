"""The batch's short ways give what the general ones give (issue 24).

- a batch's CSV rows are built from a brief result object (only what a row
  reads): every row equals the one ``props --format csv`` writes from the full
  object, whatever ``--only``, the material, the unit and the pose;
- the compiled STL and OBJ parsers never unpack an archive, so a zip under
  their name is refused as a malformed file without the archive check;
- the compiled Jacobi gives the principal moments of tensors with exact
  rational eigenvalues within its backward-error bound, and a matrix with a
  non-finite element comes back unrotated.
"""

import csv
import io
import math
import zipfile
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import massprops
import massprops.cli
from massprops.io.obj import write as write_obj
from massprops.io.stl import write_binary
from massprops.model.errors import MeshFormatError
from massprops.model.principal import _jacobi
from massprops.validation import solids
from conftest import random_rotation


@pytest.fixture(scope="module")
def parts(tmp_path_factory):
    folder = tmp_path_factory.mktemp("parts")
    bracket = solids.l_bracket(3.0, 1.0, 0.5).transformed(random_rotation(3), np.array([0.5, -1.25, 2.0]))
    prism = solids.regular_prism(9, 1.5, 0.75).transformed(random_rotation(4), np.array([-3.0, 1.0, 0.25]))
    write_binary(folder / "bracket.stl", bracket.triangles)
    write_obj(folder / "prism.obj", prism.vertices, prism.faces)
    write_binary(folder / "cube.stl", solids.box((2.0, 2.0, 2.0)).triangles)       # degenerate moments
    return sorted(str(p) for p in folder.iterdir())


def _rows(text):
    rows = list(csv.DictReader(io.StringIO(text)))
    for row in rows:
        assert row.pop("elapsed_s")                     # timed in each run: the one cell that differs
    return rows


@pytest.mark.parametrize("args", [(), ("--only", "volume"), ("--only", "mass,center_of_mass"),
                                  ("--only", "inertia"), ("--only", "principal"),
                                  ("--density", "7850", "--unit", "mm", "--translate", "1e3,-2,0.5")])
def test_batch_rows_are_the_rows_props_writes(runner, parts, tmp_path, args):
    props = runner.invoke(massprops.cli.main, ["props", "--format", "csv", *args, *parts])
    assert props.exit_code == 0, props.output
    report = tmp_path / "report.csv"
    batch = runner.invoke(massprops.cli.main, ["batch", "-j", "1", "-q", "-o", str(report), *args, *parts])
    assert batch.exit_code == 0, batch.output
    expected = [dict(r, status="ok", message="") for r in _rows(props.stdout)]
    got = _rows(report.read_text())
    assert got == expected and len(got) == len(parts)


def test_a_zip_named_stl_or_obj_is_refused_as_malformed(tmp_path):
    for name in ("bomb.stl", "bomb.obj"):
        path = tmp_path / name
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
            with archive.open("model.stl", "w", force_zip64=True) as member:
                for _ in range(65):                 # 65 MiB of spaces, past the archive limit; 65 kB packed
                    member.write(b" " * (1 << 20))
        with pytest.raises(MeshFormatError) as raised:
            massprops.mass_properties(path)
        assert "unpacks to" not in str(raised.value) and name in str(raised.value)


def _rational_rotation(p, q, r):
    """The Cayley transform of the skew matrix of (p, q, r): an exactly rational rotation."""
    d = 1 + p * p + q * q + r * r
    return [[(1 + p * p - q * q - r * r) / d, 2 * (p * q - r) / d, 2 * (p * r + q) / d],
            [2 * (p * q + r) / d, (1 - p * p + q * q - r * r) / d, 2 * (q * r - p) / d],
            [2 * (p * r - q) / d, 2 * (q * r + p) / d, (1 - p * p - q * q + r * r) / d]]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(-40, 40), min_size=3, max_size=3),
       st.lists(st.integers(-10 ** 6, 10 ** 6), min_size=3, max_size=3), st.integers(-300, 300))
def test_jacobi_moments_are_within_their_backward_error_of_the_exact_eigenvalues(params, numerators, exponent):
    rotation = _rational_rotation(*(Fraction(x, 5) for x in params))
    moments = [Fraction(n, 997) * Fraction(2) ** exponent for n in numerators]
    exact = [[sum(rotation[i][k] * moments[k] * rotation[j][k] for k in range(3)) for j in range(3)]
             for i in range(3)]
    rows = [[float(x) for x in row] for row in exact]
    for i in range(3):
        for j in range(i):
            rows[i][j] = rows[j][i]                 # exactly symmetric, as principal() passes it
    # the rounded tensor's eigenvalues are within ‖rounding‖₂ ≤ Σ|rounding_ij| of the exact ones (Weyl)
    distance = sum(abs(Fraction(rows[i][j]) - exact[i][j]) for i in range(3) for j in range(3))
    got, vectors, bound = _jacobi(rows)
    assert got == sorted(got)
    for value, exact_value in zip(got, sorted(moments)):
        assert abs(Fraction(value) - exact_value) <= Fraction(bound) + distance
    columns = np.array(vectors)
    np.testing.assert_allclose(columns.T @ columns, np.eye(3), atol=1e-12)


def test_jacobi_leaves_a_non_finite_or_zero_matrix_unrotated():
    for rows in ([[1.0, math.nan, 0.0], [math.nan, 2.0, 0.0], [0.0, 0.0, 3.0]],
                 [[math.inf, 0.5, 0.0], [0.5, 2.0, 0.0], [0.0, 0.0, 3.0]], [[0.0] * 3] * 3):
        moments, vectors, bound = _jacobi(rows)
        assert moments == [rows[0][0], rows[1][1], rows[2][2]]
        assert vectors == [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] and bound == 0.0


def test_a_batch_row_of_a_name_that_needs_quoting_is_the_row_props_writes(runner, tmp_path):
    """The row formed from the result's numbers quotes a file name with a comma or a quote as props does."""
    part = tmp_path / 'bracket, "left".stl'
    write_binary(part, solids.l_bracket(3.0, 1.0, 0.5).transformed(random_rotation(5), np.array([1.0, 2.0, 3.0])).triangles)
    props = runner.invoke(massprops.cli.main, ["props", "--format", "csv", str(part)])
    assert props.exit_code == 0, props.output
    report = tmp_path / "report.csv"
    batch = runner.invoke(massprops.cli.main, ["batch", "-j", "1", "-q", "-o", str(report), str(part)])
    assert batch.exit_code == 0, batch.output
    got, expected = _rows(report.read_text()), _rows(props.stdout)
    assert got == [dict(r, status="ok", message="") for r in expected] and got[0]["file"] == str(part)
