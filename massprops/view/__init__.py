"""Pictures of mass properties: the part, its centre of mass, principal axes and equivalent inertia box.

:mod:`~massprops.view.geometry` holds the closed forms (equivalent box and
ellipsoid, tessellations, decimation for display); :mod:`~massprops.view.picture`
turns results into a :class:`~massprops.view.picture.Picture` (what to draw,
renderer-neutral); :mod:`~massprops.view.html` draws it as a self-contained
web page (plotly, the ``view`` extra) and :mod:`~massprops.view.png` as a PNG
(matplotlib, the ``plot`` extra).  Nothing here imports plotly or matplotlib
until a page or an image is written.
"""

from __future__ import annotations

import os

__all__ = ["write_picture", "SUFFIXES"]

SUFFIXES = (".html", ".htm", ".png")


def write_picture(picture, path):
    """Draw ``picture`` into ``path``: a self-contained web page (.html, .htm) or an image (.png); returns ``path``.

    Raises
    ------
    MassPropsError
        Another suffix, or the package the format needs (plotly, matplotlib) missing.
    """
    suffix = os.path.splitext(os.fspath(path))[1].lower()
    if suffix in (".html", ".htm"):
        from .html import write_html
        write_html(picture, path)
        return path
    if suffix == ".png":
        from .png import write_png
        write_png(picture, path)
        return path
    from ..model.errors import MassPropsError
    raise MassPropsError(f"cannot draw into a {suffix or 'file without a suffix'}", path=os.fspath(path),
                         fix="name the output .html (a web page) or .png (an image)")
