"""Assemblies: parts with meshes, materials and poses, from TOML or a GLB/glTF/3MF/COLLADA scene graph.

:mod:`.model` says what a scene is, :mod:`.toml_file` and :mod:`.graph` read
one, :mod:`.assembly` computes every part and the total, and
:mod:`massprops.report.scene` renders the result.
"""

from .assembly import SceneResult, compute_scene, load_scene
from .model import Frame, Part, Placements, ReportRequest, Scene

__all__ = ["load_scene", "compute_scene", "SceneResult", "Scene", "Part", "Placements", "Frame",
           "ReportRequest"]
