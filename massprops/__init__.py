"""massprops: exact mass properties of solids from meshes.

>>> import massprops
>>> result = massprops.mass_properties("part.stl", density=7850, unit="mm")  # doctest: +SKIP
>>> result.properties.inertia_com                                            # doctest: +SKIP

Nothing heavy is imported here: trimesh, scipy and meshio load only when a
reader or command needs them.
"""

import gc as _gc

# Importing makes tens of thousands of long-lived objects (numpy's and ours): the cyclic garbage
# collector, run every 2,000 of them, would find nothing to free in them, at a tenth of the start-up
# time (issue 24).  It is paused while they load and left as it was found.
_collecting = _gc.isenabled()
_gc.disable()
try:
    from .api import mass_properties
    from .result import Result
    from .model.errors import MassPropsError
    from .model.frames import Pose
    from .mesh import TriangleMesh
    from .model.properties import ErrorBounds, MassProperties
finally:
    if _collecting:
        _gc.enable()
    del _collecting

__all__ = ["mass_properties", "Result", "MassProperties", "ErrorBounds", "Pose", "TriangleMesh", "MassPropsError"]
__version__ = "0.1.0"
