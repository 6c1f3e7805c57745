"""The total of placed parts: :func:`combine_parts` (and :func:`combine_instances`, the same over instances of
distinct parts), with centred formulas and error bounds propagated through them.

Each part's ``J_Gi`` is shifted to the total center of mass (``ρ_i = r_i − r``),
so no large, nearly equal numbers are subtracted.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.rounding import U as _U
from .errors import MeshGeometryError
from .frames import Pose, matmul, matvec, rotate_inertia
from .properties import ErrorBounds, MassProperties

__all__ = ["combine_parts", "combine_instances"]


def combine_parts(parts, poses=None, *, unit=None):
    """The assembly of parts as one :class:`MassProperties` in global axes (identity pose).

    ``parts`` are :class:`MassProperties`, placed at ``poses`` (a Pose each) or,
    without ``poses``, at their own ``pose``.  See :func:`combine_instances`.
    """
    poses = [p.pose for p in parts] if poses is None else poses
    rotation = np.array([pose.rotation for pose in poses])
    translation = np.array([pose.translation for pose in poses])
    return combine_instances(list(parts), np.arange(len(parts)), rotation, translation, unit)


def combine_instances(local, index, rotation, translation, unit):
    """The total of instances ``k`` of the parts ``local[index[k]]`` at poses ``(rotation[k], translation[k])``.

    Masses and volumes add; the center of mass is the mass-weighted mean of the
    instances' global centers, accumulated relative to the heaviest one's; the
    inertia is ``Σ (A_k J_Gk' A_kᵀ + m_k (ρ_kᵀρ_k I − ρ_k ρ_kᵀ))`` with
    ``ρ_k = r_k − r``.  Error bounds add the parts' bounds, propagated
    through these formulas, and the rounding of the sums.  Everything is
    array arithmetic over the instances.

    Parameters
    ----------
    local : list of MassProperties
        Distinct parts, local frames.
    index : ndarray, shape (n,), int
    rotation : ndarray, shape (n, 3, 3)
    translation : ndarray, shape (n, 3)
        Output units.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        total = _summed(local, index, rotation, translation, unit)
    values = [total.volume, total.mass, total.surface_area, total.error.mass]
    values += [bound for bound in (total.error.center_of_mass, total.error.inertia_com) if bound is not None]
    for array in (total.center_of_mass, total.inertia_com):
        values += [] if array is None else np.ravel(array).tolist()
    if not all(map(math.isfinite, values)):
        reach = float(np.abs(translation).max()) if translation.size else 0.0
        raise MeshGeometryError(f"the assembly's totals overflow double precision (parts are placed up to "
                                f"{reach:.3g} from the origin)",
                                fix="place the parts nearer the origin, or give them in a larger length unit")
    return total


def _summed(local, index, rotation, translation, unit):
    """:func:`combine_instances`'s sums, which may overflow (checked by the caller)."""
    def per_instance(get):
        return np.array([get(p) for p in local], dtype=float)[index]

    def exact_sum(values):
        return math.fsum(values.tolist())       # lists sum far faster than numpy scalars

    mass, volume = per_instance(lambda p: p.mass), per_instance(lambda p: p.volume)
    total_mass, total_volume = exact_sum(mass), exact_sum(volume)
    gamma = (8 + int(index.size).bit_length()) * _U
    err_mass_i = per_instance(lambda p: p.error.mass)
    err_mass = exact_sum(err_mass_i) + gamma * total_mass
    error = dict(volume=exact_sum(per_instance(lambda p: p.error.volume)) + gamma * total_volume, mass=err_mass)
    com = inertia = None
    if local[0].center_of_mass is not None:
        if not total_mass > 0:
            raise MeshGeometryError(f"the parts' total mass is {total_mass:g}: no center of mass",
                                    fix="give the parts a positive density or mass")
        com, inertia, error = _combine_moments(local, index, rotation, translation, mass, err_mass_i,
                                               total_mass, gamma, error)
    surface_area = exact_sum(per_instance(lambda p: p.surface_area))
    return MassProperties(total_volume, total_mass, total_mass / total_volume, surface_area, com, inertia,
                          ErrorBounds(**error), Pose(), unit)


def _combine_moments(local, index, rotation, translation, mass, err_mass_i, total_mass, gamma, error):
    position = matvec(rotation, np.array([p.center_of_mass for p in local])[index]) + translation
    base = position[int(np.argmax(mass))]
    com = base + _pairwise_sum((position - base) * mass[:, None]) / total_mass
    rho = position - com
    reach = np.abs(rho).max(axis=1)
    # Rotations are orthonormal only to rounding; their defect scales what they carry.
    defect = np.abs(matmul(rotation, rotation.transpose(0, 2, 1)) - np.eye(3)).max(axis=(1, 2))
    err_position = np.array([p.error.center_of_mass for p in local])[index] * (1.8 + defect) + 4 * _U * (
        np.abs(position).max(axis=1))
    err_com = float(mass @ err_position + err_mass_i @ reach) / (total_mass - error["mass"]) * 1.01 + gamma * float(
        np.abs(position).max() + np.abs(com).max())
    error["center_of_mass"] = err_com
    if local[0].inertia_com is None:
        return com, None, error
    local_inertia = np.array([p.inertia_com for p in local])
    terms = rotate_inertia(local_inertia[index], rotation) - mass[:, None, None] * (
        rho[:, :, None] * rho[:, None, :])
    terms[:, range(3), range(3)] += (mass * np.einsum("ni,ni->n", rho, rho))[:, None]
    inertia = _pairwise_sum(terms.reshape(-1, 9)).reshape(3, 3)
    size = np.abs(local_inertia).max(axis=(1, 2))[index]
    # Σ m_i P(r_i − c̃) = Σ m_i P(r_i − c) + M P(c − c̃) since Σ m_i (r_i − c) = 0: the error of the
    # total COM enters only squared; the parts' own position and mass errors enter linearly.
    err_inertia = (np.array([p.error.inertia_com for p in local])[index] * 3 * (1 + defect) + 6 * defect * size
                   + 2 * err_mass_i * reach ** 2 + mass * (4 * reach * err_position + 2 * err_position ** 2))
    error["inertia_com"] = (float(err_inertia.sum()) + 2 * total_mass * err_com ** 2) * 1.01 + (
        gamma + 16 * _U) * float((3 * size + 2 * mass * reach ** 2).sum())
    return com, inertia, error


def _pairwise_sum(rows):
    """Column sums of ``rows`` (n, k), summed pairwise: rounding within gamma's (8 + log₂ n) u.

    numpy sums pairwise only along a contiguous axis (a matrix product or a
    reduction over the outer axis adds in sequence, with error growing as n u).
    """
    return np.ascontiguousarray(rows.T).sum(axis=1)
