"""Signed-tetrahedron integrals of 1, x and x xᵀ over a closed triangle mesh, with error bounds.

Each face (a, b, c) and the reference point span a tetrahedron of signed volume
``det[a b c] / 6``.  Summed over a closed surface, with ``s = a + b + c``::

    ∫ 1 dV     = Σ det / 6
    ∫ x dV     = Σ det · s / 24
    ∫ x xᵀ dV  = Σ det · (s sᵀ + a aᵀ + b bᵀ + c cᵀ) / 120

The sums are formed by the compiled core in the frame of :mod:`.frame`
(exact shift, power-of-two scale); each face's determinant carries
Shewchuk's certified bound, hard faces are re-evaluated (corner rotation,
double-double, exact), and every sum carries a rigorous bound on its error
against exact arithmetic on the coordinates as given.  When the tetrahedra
cancel heavily, the sums are redone with every term in double-double.
"""

from __future__ import annotations


import numpy as np

from ..model.records import record
from . import _core
from .arrays import as_indices, as_points
from .frame import frame_of
from .threads import threads_for

__all__ = ["Moments", "integrate"]

# Above this ratio Σ|det| / |Σ det| the fast pass loses more than ~4 bits to cancellation.
_CANCELLATION_LIMIT = 16.0
# Faces above which the sums run on several threads: below, starting a thread costs more than it saves.
_PARALLEL_ABOVE = 1 << 14


@record
class Moments:
    """Raw volume moments of a closed mesh in scaled, shifted coordinates.

    Coordinates are ``y = (x − reference) · 2**-scale_exp``.  In those units
    ``det_sum = Σ det``, ``first = Σ det·s`` (3,), ``second = Σ det·(s sᵀ + a aᵀ +
    b bᵀ + c cᵀ)`` (3, 3), and ``area2 = Σ |(b − a) × (c − a)|``.  Each ``*_error``
    is an absolute bound on that sum's largest element error.  ``order`` says
    which moments were formed (0: volume only, 1: and first, 2: and second).
    """

    reference: np.ndarray
    scale_exp: int
    order: int
    det_sum: float
    det_error: float
    first: np.ndarray
    first_error: float
    second: np.ndarray
    second_error: float
    area2: float
    faces: int
    refined_faces: int
    exact_faces: int

    def negated(self):
        """The moments of the same surface with every face's winding reversed."""
        return Moments(self.reference, self.scale_exp, self.order, -self.det_sum, self.det_error,
                       -self.first, self.first_error, -self.second, self.second_error, self.area2,
                       self.faces, self.refined_faces, self.exact_faces)


def integrate(vertices, faces, *, order=2, weights=None, measure="volume", frame=None, scaled=None):
    """Integrate the volume moments of a closed, consistently wound surface.

    Parameters
    ----------
    vertices : array_like, shape (n, 3), float
        Local-frame coordinates, mesh units.
    faces : array_like, shape (m, 3), int
        Triangles, outward winding.
    order : {0, 1, 2}
        Highest moment to form: 0 volume, 1 first moments, 2 second moments.
    weights : array_like, shape (m,), float, optional
        A factor per face term, taken as exact (a cell's density, see
        :mod:`massprops.volume`); its product adds one rounding to the bounds.
    measure : {"volume", "area"}
        "area" replaces each face's ``det`` by ``|(b − a) × (c − a)|`` (twice its
        area), so the sums become surface integrals (:mod:`massprops.shell`).
    frame : Frame, optional
        :func:`massprops.core.frame.frame_of` of these vertices, if already found.
    scaled : ndarray, shape (n, 3), float64, optional
        The vertices in ``frame`` exactly as the core scales them
        (:attr:`massprops.core.intersect.ExactGeometry.unsnapped`), if at hand:
        used instead of scaling them again.

    Returns
    -------
    Moments

    Raises
    ------
    IndexError
        A face refers to a vertex that does not exist.
    """
    if measure not in ("volume", "area"):
        raise ValueError(f"measure: expected 'volume' or 'area', got {measure!r}")
    vertices = as_points(vertices)
    faces = as_indices(faces)
    if weights is not None:
        weights = np.ascontiguousarray(weights, dtype=np.float64)
        if weights.shape != (faces.shape[0],):
            raise ValueError(f"weights: expected shape ({faces.shape[0]},), got {weights.shape}")
    frame = frame_of(vertices) if frame is None else frame
    arguments = (vertices, faces, frame.reference, frame.scale_exp, frame.radius, order, measure == "area",
                 weights, threads_for(faces.shape[0], _PARALLEL_ABOVE))
    sums = _core.integrate(*arguments, False, scaled)
    area2 = sums["area2"]
    if measure == "volume" and sums["abs_sum"] > _CANCELLATION_LIMIT * abs(sums["det_sum"]):
        # The tetrahedra cancel heavily: redo the sums (weighted or not) in double-double.
        sums = _core.integrate(*arguments, True)
    xx, yy, zz, xy, yz, zx = sums["second"]
    second = np.array([[xx, xy, zx], [xy, yy, yz], [zx, yz, zz]])
    return Moments(np.array(frame.reference), frame.scale_exp, order, sums["det_sum"], sums["det_error"],
                   np.array(sums["first"]), sums["first_error"], second, sums["second_error"], area2,
                   faces.shape[0], sums["refined"], sums["exact"])
