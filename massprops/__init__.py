"""massprops: exact mass properties of solids from meshes.

>>> import massprops
>>> result = massprops.mass_properties("part.stl", density=7850, unit="mm")  # doctest: +SKIP
>>> result.properties.inertia_com                                            # doctest: +SKIP

Nothing heavy is imported here: trimesh, scipy and meshio load only when a
reader or command needs them.
"""

from .api import mass_properties
from .result import Result
from .model.errors import MassPropsError
from .model.frames import Pose
from .mesh import TriangleMesh
from .model.properties import ErrorBounds, MassProperties

__all__ = ["mass_properties", "Result", "MassProperties", "ErrorBounds", "Pose", "TriangleMesh", "MassPropsError"]
__version__ = "0.1.0"
