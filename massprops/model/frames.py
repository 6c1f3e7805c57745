"""Poses, rotation parsing, and moving inertia tensors between frames.

Convention (used everywhere in massprops): a pose is a proper rotation ``A``
(3×3, det +1) and a translation ``t``; a local point ``x'`` of the part sits at
``x = A x' + t`` in the global frame.  Quaternions are ``(w, x, y, z)``, scalar
first, unless ``scalar_first=False``.  Euler sequences follow scipy: lower-case
letters are extrinsic rotations (about the fixed axes), upper-case intrinsic.
"""

from __future__ import annotations

import math
from dataclasses import field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:                       # numpy.typing costs 0.4 ms at start-up
    from numpy.typing import ArrayLike

from .records import record
from .errors import OptionError

__all__ = ["Pose", "frozen_array", "matmul", "matvec", "quat_to_matrix", "quat_from_matrix", "quat_multiply", "quat_conjugate",
           "axis_angle_quat", "rotate_inertia", "parallel_axis", "inertia_about_frame", "skew"]

_ORTHONORMAL_TOL = 1e-9


def frozen_array(value, shape=None, *, name="array"):
    """A read-only float64 copy of ``value`` (of ``shape`` if given, finite), for immutable results.

    An array that is already read-only float64 of that shape is returned as is.
    """
    if type(value) is np.ndarray and value.dtype == np.float64 and not value.flags.writeable \
            and (shape is None or value.shape == shape):
        return value
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise OptionError(f"{name} must be numbers of shape {shape}, got {value!r}") from None
    if shape is not None and array.shape != shape:
        raise OptionError(f"{name} must have shape {shape}, got {array.shape}")
    array.setflags(write=False)
    return array


def matmul(a, b):
    """``a @ b`` for (stacks of) 3×3 matrices, shapes (..., 3, 3).

    Each element is ``(a₀b₀ + a₁b₁) + a₂b₂``, every product and sum rounded
    once, so the result is the same bits on every machine (BLAS kernels
    differ in order and in fused multiply-adds with the CPU).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return ((a[..., :, 0, None] * b[..., None, 0, :] + a[..., :, 1, None] * b[..., None, 1, :])
            + a[..., :, 2, None] * b[..., None, 2, :])


def matvec(a, v):
    """``a @ v`` for (stacks of) 3×3 matrices (..., 3, 3) and vectors (..., 3), as :func:`matmul` rounds."""
    a = np.asarray(a, dtype=float)
    v = np.asarray(v, dtype=float)
    return (a[..., 0] * v[..., None, 0] + a[..., 1] * v[..., None, 1]) + a[..., 2] * v[..., None, 2]


def skew(v):
    """The cross-product matrix ``ṽ`` with ``ṽ w = v × w``."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _axis_rotation(axis, angle):
    c, s = math.cos(angle), math.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(3)
    m[i, i] = m[j, j] = c
    m[j, i], m[i, j] = s, -s
    return m


def quat_multiply(p, q):
    """Hamilton product ``p ⊗ q`` of scalar-first quaternions, shapes (..., 4)."""
    pw, pv = p[..., :1], p[..., 1:]
    qw, qv = q[..., :1], q[..., 1:]
    return np.concatenate([pw * qw - np.sum(pv * qv, axis=-1, keepdims=True),
                           pw * qv + qw * pv + np.cross(pv, qv)], axis=-1)


def quat_to_matrix(q):
    """Rotation matrices (..., 3, 3) of quaternions (..., 4), normalised first."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                     np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                     np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def quat_from_matrix(rotation):
    """Unit quaternions (..., 4), ``w ≥ 0``, of proper rotation matrices (..., 3, 3).

    Shepperd's method: the largest of ``4w², 4x², 4y², 4z²`` is taken from the
    diagonal and the rest from off-diagonal sums, so no component is formed
    from a small difference.
    """
    m = np.asarray(rotation, dtype=float)
    trace = np.trace(m, axis1=-2, axis2=-1)
    diagonal = np.stack([trace, m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]], axis=-1)
    big = np.argmax(diagonal, axis=-1)[..., None]
    scale = np.sqrt(np.maximum(1.0 + 2.0 * np.take_along_axis(diagonal, big, -1) - trace[..., None], 0.0))
    sums = np.stack([
        np.stack([scale[..., 0] ** 2, m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                  m[..., 1, 0] - m[..., 0, 1]], -1),
        np.stack([m[..., 2, 1] - m[..., 1, 2], scale[..., 0] ** 2, m[..., 0, 1] + m[..., 1, 0],
                  m[..., 0, 2] + m[..., 2, 0]], -1),
        np.stack([m[..., 0, 2] - m[..., 2, 0], m[..., 0, 1] + m[..., 1, 0], scale[..., 0] ** 2,
                  m[..., 1, 2] + m[..., 2, 1]], -1),
        np.stack([m[..., 1, 0] - m[..., 0, 1], m[..., 0, 2] + m[..., 2, 0], m[..., 1, 2] + m[..., 2, 1],
                  scale[..., 0] ** 2], -1)], -2)
    q = np.take_along_axis(sums, big[..., None], -2)[..., 0, :] / (2.0 * scale)
    return q * np.where(q[..., :1] < 0, -1.0, 1.0)


def axis_angle_quat(axis, angle):
    """Quaternions (..., 4) of rotations by ``angle`` (...) about unit ``axis`` (..., 3)."""
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * np.asarray(axis, dtype=float)], axis=-1)


def quat_conjugate(q):
    """The inverse rotation of unit quaternions (..., 4)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


@record(eq=False)
class Pose:
    """Where a part sits: ``x = rotation @ x' + translation``.

    Build one with :meth:`from_quat`, :meth:`from_euler`, :meth:`from_matrix`
    or :meth:`parse`; the identity is ``Pose()``.
    """

    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        # Read-only copies: a pose is a value, and results cache what they derive from it.
        rotation = frozen_array(self.rotation, (3, 3), name="a pose's rotation")
        translation = frozen_array(self.translation, (3,), name="a pose's translation")
        if not (np.isfinite(rotation).all() and np.isfinite(translation).all()):
            raise OptionError("a pose needs finite numbers", fix="give a finite rotation and translation")
        object.__setattr__(self, "rotation", rotation)
        object.__setattr__(self, "translation", translation)

    @classmethod
    def from_quat(cls, quat: ArrayLike, *, scalar_first: bool = True, translation: ArrayLike = (0.0, 0.0, 0.0)) -> Pose:
        """Pose from a quaternion (normalised here; zero length is refused)."""
        q = np.asarray(quat, dtype=float)
        if q.shape != (4,) or not np.all(np.isfinite(q)):
            raise OptionError(f"a quaternion needs 4 finite numbers, got {quat!r}")
        if not float(q @ q) > 0:          # zero, or so small that its square underflows
            raise OptionError("a quaternion of zero length is no rotation", fix="give w,x,y,z with w=1 for none")
        rotation = quat_to_matrix(q if scalar_first else np.roll(q, 1))
        return cls(rotation, translation)

    @classmethod
    def from_euler(cls, seq: str, angles: ArrayLike, *, degrees: bool = True,
                   translation: ArrayLike = (0.0, 0.0, 0.0)) -> Pose:
        """Pose from Euler angles, scipy's convention (``"xyz"`` extrinsic, ``"XYZ"`` intrinsic)."""
        if not (1 <= len(seq) <= 3) or not (seq.islower() or seq.isupper()) \
                or any(ch not in "xyzXYZ" for ch in seq):
            raise OptionError(f"Euler sequence {seq!r} is not valid",
                              fix="use 1 to 3 letters of xyz (extrinsic) or XYZ (intrinsic), e.g. zyx or ZYX")
        angles = np.atleast_1d(np.asarray(angles, dtype=float))
        if angles.shape != (len(seq),):
            raise OptionError(f"Euler sequence {seq!r} needs {len(seq)} angles, got {angles.size}")
        if not np.isfinite(angles).all():
            raise OptionError(f"Euler angles must be finite numbers, got {', '.join(map(str, angles))}")
        if degrees:
            angles = np.radians(angles)
        rotation = np.eye(3)
        for letter, angle in zip(seq, angles):
            step = _axis_rotation("xyz".index(letter.lower()), angle)
            # Extrinsic: each new rotation applies after (left of) the previous ones.
            rotation = matmul(step, rotation) if seq.islower() else matmul(rotation, step)
        return cls(rotation, translation)

    @classmethod
    def from_matrix(cls, matrix: ArrayLike, *, translation: ArrayLike = (0.0, 0.0, 0.0)) -> Pose:
        """Pose from a 3×3 rotation matrix; refused unless orthonormal with det +1."""
        m = np.asarray(matrix, dtype=float)
        if m.shape != (3, 3) or not np.all(np.isfinite(m)):
            raise OptionError(f"a rotation matrix needs 9 finite numbers, got {np.size(m)}")
        off = float(np.abs(matmul(m, m.T) - np.eye(3)).max())
        if off > _ORTHONORMAL_TOL:
            raise OptionError(f"the rotation matrix is not orthonormal (|A Aᵀ − I| = {off:.3g})",
                              fix="give a proper rotation, or use a quaternion")
        if np.linalg.det(m) < 0:
            raise OptionError("the rotation matrix has det −1 (a reflection)",
                              fix="give a proper rotation (det +1)")
        return cls(m, translation)

    @classmethod
    def parse(cls, text: str, *, translation: ArrayLike = (0.0, 0.0, 0.0)) -> Pose:
        """Parse a rotation given on the command line.

        Accepted forms: ``quat:w,x,y,z``; ``euler:SEQ:a,b,c`` (degrees);
        ``matrix:m11,m12,...,m33`` (row-major); or bare numbers — 4 of them a
        quaternion, 9 a matrix.
        """
        text = text.strip()
        kind, _, rest = text.partition(":")
        seq = None
        if kind == "euler":
            seq, _, rest = rest.partition(":")
        elif kind not in ("quat", "matrix"):
            kind, rest = None, text
        values = _numbers(rest)
        if values is None:
            raise OptionError(f"cannot read rotation {text!r}",
                              fix="use quat:w,x,y,z, euler:zyx:a,b,c (degrees) or matrix:9 numbers")
        if kind == "euler":
            return cls.from_euler(seq, values, translation=translation)
        if kind == "quat" or (kind is None and len(values) == 4):
            return cls.from_quat(values, translation=translation)
        if kind == "matrix" or (kind is None and len(values) == 9):
            return cls.from_matrix(np.reshape(values, (3, 3)) if len(values) == 9 else values,
                                   translation=translation)
        raise OptionError(f"cannot read rotation {text!r}: {len(values)} numbers",
                          fix="use quat:w,x,y,z, euler:zyx:a,b,c (degrees) or matrix:9 numbers")

    def apply(self, points: ArrayLike) -> np.ndarray:
        """Map local points (…, 3) to the global frame."""
        return matvec(self.rotation, points) + self.translation

    def as_quat(self, *, scalar_first: bool = True) -> np.ndarray:
        """The rotation as a unit quaternion with w ≥ 0 (:func:`quat_from_matrix`)."""
        q = quat_from_matrix(self.rotation)
        return q if scalar_first else np.roll(q, -1)

    def compose(self, inner: Pose) -> Pose:
        """The pose of ``inner`` placed inside this pose: ``self ∘ inner``."""
        return Pose(matmul(self.rotation, inner.rotation), matvec(self.rotation, inner.translation) + self.translation)

    def inverse(self) -> Pose:
        return Pose(self.rotation.T.copy(), -matvec(self.rotation.T, self.translation))


def _numbers(text):
    """Comma- or space-separated floats, or None if any is not a number."""
    try:
        values = [float(v) for v in text.replace(" ", ",").split(",") if v]
    except ValueError:
        return None
    return values or None


def rotate_inertia(inertia, rotation):
    """``A J Aᵀ``: an inertia tensor expressed in axes rotated by ``A``."""
    a = np.asarray(rotation, dtype=float)
    return matmul(matmul(a, inertia), np.swapaxes(a, -1, -2))


def parallel_axis(mass, offset):
    """``m (rᵀr I₃ − r rᵀ)``: what the parallel-axis theorem adds at offset ``r``."""
    r = np.asarray(offset, dtype=float)
    return mass * (float((r[0] * r[0] + r[1] * r[1]) + r[2] * r[2]) * np.eye(3) - np.outer(r, r))


def inertia_about_frame(inertia_com_global, mass, center_of_mass, frame):
    """``J_o' = A_jᵀ (J_G + m (ρᵀρ I − ρ ρᵀ)) A_j`` with ``ρ = r_j − r_G``.

    Parameters
    ----------
    inertia_com_global : ndarray, shape (3, 3)
        Inertia about the center of mass, global axes.
    mass : float
    center_of_mass : ndarray, shape (3,)
        Global position of the center of mass.
    frame : Pose
        The frame j (origin ``r_j``, rotation ``A_j``).

    Returns
    -------
    ndarray, shape (3, 3)
        Inertia about frame j's origin, in frame j's axes.
    """
    rho = frame.translation - np.asarray(center_of_mass, dtype=float)
    return rotate_inertia(np.asarray(inertia_com_global) + parallel_axis(mass, rho), frame.rotation.T)
