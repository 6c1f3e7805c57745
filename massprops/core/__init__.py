"""The compiled core: parse, weld, match edges, find shells, and integrate with error bounds.

Like shapely's ``lib`` under its API: the C extension :mod:`._core` does the
per-element work without the GIL and on every core, and these small modules
give it numpy arrays in and out, documented shapes and units, and the
package's errors.  Policy (what to refuse, which frame, what to report) stays
with the callers.

- :mod:`.readers`: STL and OBJ files to welded ``vertices, faces``;
- :mod:`.weld`: corners or indexed vertices welded by exact coordinates;
- :mod:`.topology`: edge counts, shells, duplicate faces;
- :mod:`.frame` and :mod:`.moments`: the integration frame and the moment sums;
- :mod:`.determinants`: signed volumes of tetrahedra and shells, with bounds;
- :mod:`.threads`: ``MASSPROPS_THREADS``;
- :mod:`.rounding`: the unit roundoff ``U`` and γ(k), in which every bound is written;
- :mod:`.intersect` (its own extension, ``_intersect``): exact triangle-intersection and
  point-in-solid decisions for the solid's checks (:mod:`massprops.mesh.solid`).
"""

from .determinants import shell_determinants, tetra_determinants
from .frame import reference_frame
from .moments import Moments, integrate
from .readers import read_obj, read_stl
from .rounding import U, gamma
from .threads import thread_count
from .topology import (EdgeSummary, FaceGroups, distinct_faces, edge_summary, face_groups, group_rows,
                       shells)
from .weld import weld_corners, weld_indexed

__all__ = ["U", "gamma", "Moments", "integrate", "reference_frame", "tetra_determinants", "shell_determinants",
           "read_stl", "read_obj", "weld_corners", "weld_indexed", "EdgeSummary", "edge_summary", "shells",
           "FaceGroups", "face_groups", "group_rows", "distinct_faces", "thread_count"]
