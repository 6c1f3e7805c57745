"""The one number policy of every report: the digits a value's error bound leaves significant."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["significant", "vector_text", "bound_text", "relative_difference"]


def significant(x, bound=None, digits=None):
    """``x`` as text with the digits that are significant given the absolute ``bound``.

    The last digit shown is at the bound's power of ten rounded up, so the
    digits shown are within the bound of the exact value (the last one to
    rounding); a value no larger than its bound prints as ``0``.  ``digits`` overrides (that many
    significant digits); without a bound, 15.  None (a value beyond double
    precision) prints as ``n/a``.
    """
    if x is None:
        return "n/a"
    if digits is None:
        if bound is None or not bound > 0 or not math.isfinite(bound):
            digits = 15
        elif abs(x) <= bound:
            return "0"
        else:
            digits = min(17, max(1, math.floor(math.log10(abs(x))) - math.ceil(math.log10(bound)) + 1))
    return f"{x:.{digits}g}"


def vector_text(values, bound=None, digits=None):
    """``[ a,  b, -c]``: each value as :func:`significant` shows it (``bound`` one for all, or one each)."""
    bounds = bound if isinstance(bound, list) else [bound] * len(values)
    texts = [significant(x, b, digits) for x, b in zip(values, bounds)]
    return "[" + ", ".join(t if t.startswith("-") else " " + t for t in texts) + "]"


def bound_text(bound):
    """An error bound as the reports print it after ``±``: two significant digits."""
    return f"{bound:.2g}"


def relative_difference(ours, theirs, *, floor=0.0):
    """max|ours − theirs| / max(max|ours|, floor) (0 when both are 0).

    ``floor`` keeps a quantity near zero (the center of mass of a centred
    part) from being judged against its own rounding noise: pass its scale.
    """
    ours, theirs = np.asarray(ours, float), np.asarray(theirs, float)
    scale = max(float(np.abs(ours).max()), floor)
    diff = float(np.abs(ours - theirs).max())
    return diff / scale if scale else (0.0 if diff == 0 else math.inf)
