"""The integration frame: an exact shift to a point near the part and a power-of-two scale.

Coordinates are integrated as ``y = (x − reference) · 2**-scale_exp``.  Both
steps must be exact, so the bounds speak about the coordinates as given: the
reference is chosen per axis so that ``x − reference`` is exact for every
coordinate, and the scale is a power of two (exact unless a scaled value is
subnormal, which the kernel's underflow allowance covers).

The reference is the box's centre (a short number near it) where the
compiled core confirms that subtracting it is exact for every coordinate — a
reference inside the part leaves few faces whose plane passes near it, and
little cancellation — else a point of the box that is provably exact for any
coordinates in it (both chosen in one compiled call, :func:`frame_of`).  The scale ``2**scale_exp``
is the smallest power of two at least the largest extent.

The range a part must lie in: in the frame, its box's volume (the product
of its extents over ``2**(3 scale_exp)``) at least 2**-900, since the
kernel's underflow allowance is 2**-1000 per face (:func:`frame_of`), so
that extents of 1e200 and 1e-100 in one part are refused naming them rather
than integrated as "zero volume"; and, for a solid whose shells are compared
in mesh units, its box's volume between 2**-1000 and 2**1023 mesh units³
(about 1e-301 to 9e307, :func:`check_box_range`).  A part flat along an axis
(an extent of zero) is not refused: it is flat.
"""

from __future__ import annotations

import math

from ..model.errors import MeshGeometryError
from ..model.records import tuple_record
from . import _core

__all__ = ["reference_frame", "Frame", "frame_of", "check_box_range"]


_LOG2_BOX = (-1000.0, 1023.0)      # log2 of the box volume, mesh units³
_LOG2_SCALED_BOX = -900.0           # log2 of the box volume in the frame (extents over 2**scale_exp)


def _log_box(extents):
    """log2 of the box volume (the sum of the extents' logs: no product to overflow or underflow)."""
    return sum(math.log2(e) for e in extents)


def _box_text(extents):
    """``("X by Y by Z", the volume as text such as "1e+924")``, for a refusal's message."""
    decimal = _log_box(extents) * math.log10(2)
    return " by ".join(f"{e:.3g}" for e in extents), f"{10 ** (decimal % 1):.2g}e{math.floor(decimal):+d}"


def check_box_range(extents):
    """Refuse a box (its three extents, mesh units) whose volume in mesh units³ is outside 2**-1000 to 2**1023."""
    if not all(0 < e < math.inf for e in extents):
        return                                  # flat, or non-finite (refused where found)
    log_box = _log_box(extents)
    if _LOG2_BOX[0] <= log_box <= _LOG2_BOX[1]:
        return                                  # every part but a refused one: no text to format
    shown, volume = _box_text(extents)
    if log_box < _LOG2_BOX[0]:
        raise MeshGeometryError(f"the part is too small for double precision (its volume would underflow): its "
                                f"box is {shown} mesh units, a volume of at most {volume}, below 1e-301 (2**-1000)",
                                fix="export the mesh in a smaller length unit (larger numbers)")
    if log_box > _LOG2_BOX[1]:
        raise MeshGeometryError(f"the part is too large for double precision (its volume would overflow): its "
                                f"box is {shown} mesh units, a volume up to {volume}, above 9e+307 (2**1023)",
                                fix="export the mesh in a larger length unit (smaller numbers)")


def _check_scaled_range(extents, scale_exp):
    """Refuse a part whose box, in the frame, is too small a fraction of its largest extent cubed."""
    if not all(e > 0 for e in extents):
        return
    if _log_box(extents) - 3 * scale_exp < _LOG2_SCALED_BOX:
        shown, _ = _box_text(extents)
        raise MeshGeometryError(f"the part's extents span too many orders of magnitude for double precision: its "
                                f"box is {shown} mesh units, a volume below 2**-900 of its largest extent cubed",
                                fix="check the file for a stray vertex far from the part; a part this thin cannot "
                                    "be integrated")


@tuple_record
class Frame:
    """Where and at what scale a part is integrated."""

    reference: tuple            # 3 floats, subtracted exactly
    scale_exp: int              # lengths are divided by 2**scale_exp
    radius: float               # max |x − reference| · 2**-scale_exp, exact (from the box)


def frame_of(vertices):
    """The :class:`Frame` of vertices, shape (n, 3), C-contiguous float64.

    Compiled (``massprops/core/src/post.c``, one call: the box, the reference
    per axis, the exact-shift test of the box's centre, the scale and the
    radius): a short number near the centre where subtracting it is exact for
    every coordinate, else a point of the box that is provably exact for any
    coordinate in it (a short centre when every ``|x| >= 2**k`` with
    ``2**k >= extent``; the box's low or high end when Sterbenz's lemma holds;
    else 0); the scale the smallest power of two at least the largest extent.
    """
    if vertices.shape[0] == 0:
        return Frame((0.0, 0.0, 0.0), 0, 0.0)
    low, high, reference, scale_exp, radius, status = _core.frame(vertices)
    if status == 1:
        raise MeshGeometryError(f"the mesh spans more than the largest double (from {min(low):.3g} to "
                                f"{max(high):.3g})", fix="rescale it (give it in a larger length unit)")
    if status == 2:
        _check_scaled_range([hi - lo for lo, hi in zip(low, high)], scale_exp)
    return Frame(reference, scale_exp, radius)


def reference_frame(vertices):
    """An exact shift and power-of-two scale that bring the part near the origin at unit size.

    Parameters
    ----------
    vertices : array_like, shape (n, 3)
        Coordinates, mesh units.

    Returns
    -------
    reference : ndarray, shape (3,)
        Subtracted from every vertex, exactly.
    scale_exp : int
        Lengths are then divided by ``2**scale_exp``.
    """
    import numpy as np
    from .arrays import as_points

    frame = frame_of(as_points(vertices))
    return np.array(frame.reference), frame.scale_exp
