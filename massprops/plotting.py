"""matplotlib, imported only when a picture is drawn (the ``plot`` extra)."""

from __future__ import annotations

from .model.errors import MassPropsError

__all__ = ["pyplot"]


def pyplot(what, fix):
    """``matplotlib.pyplot`` on the file backend (Agg); a :class:`MassPropsError` naming ``what`` when missing."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise MassPropsError(f"{what} needs matplotlib, which is not installed", fix=fix) from None
    return plt
