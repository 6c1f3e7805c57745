"""Moments of a mesh under a linear map ``P`` (a non-uniform scale, a mirror): exact up to one rounding each."""

from __future__ import annotations

import math
from dataclasses import replace
from fractions import Fraction

import numpy as np

from ..core.rounding import U as _U

__all__ = ["stretched_moments", "stretched_area2"]


def stretched_moments(moments, stretch):
    """Raw moments of the mesh mapped by ``P`` (``x'' = P x'``), exactly up to one rounding each.

    With ``y`` the scaled coordinates of :class:`massprops.core.Moments`,
    ``Σdet ↦ |det P| Σdet``, ``first ↦ |det P| P first``, ``second ↦
    |det P| P second Pᵀ``, and the reference point ``↦ P ref`` (kept exact as
    rationals).  The area is not a function of the moments; it is set by the
    caller from the faces (see :func:`stretched_area2`).

    ``stretch`` holds floats, or Fractions for a map given in decimals (a
    robot mesh's ``scale="0.001"`` is 1/1000 exactly, not the float nearest it).
    """
    p = [[x if isinstance(x, Fraction) else Fraction(float(x)) for x in row] for row in stretch]
    det = abs(p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0])
              + p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]))
    norm = float(max(sum(abs(x) for x in row) for row in p))

    def mapped(vector):
        return [sum(row[k] * vector[k] for k in range(3)) for row in p]

    det_sum = float(Fraction(moments.det_sum) * det)
    first = np.array([float(x * det) for x in mapped([Fraction(v) for v in moments.first])])
    second_rows = [mapped([Fraction(float(v)) for v in column]) for column in np.asarray(moments.second).T]
    second = np.array([[float(det * sum(p[i][k] * second_rows[k][j] for k in range(3))) for j in range(3)]
                       for i in range(3)])
    d = float(det) * (1 + 4 * _U)
    return replace(moments, reference=tuple(mapped([Fraction(x) for x in moments.reference])),
                   det_sum=det_sum, det_error=moments.det_error * d + _U * abs(det_sum),
                   first=first, first_error=moments.first_error * d * norm + _U * float(np.abs(first).max()),
                   second=second,
                   second_error=moments.second_error * d * norm ** 2 + _U * float(np.abs(second).max()))


def stretched_area2(mesh, stretch, scale_exp):
    """``Σ |cof(P) n_f|`` in the moments' scaled units: twice the stretched surface's area."""
    triangles = mesh.vertices[mesh.faces]
    normal = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    cofactor = np.linalg.det(stretch) * np.linalg.inv(stretch).T
    return math.ldexp(float(np.linalg.norm(normal @ cofactor.T, axis=1).sum()), -2 * scale_exp)
