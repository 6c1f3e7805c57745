"""Meshes and what solid they describe: the triangle container and its checks (:mod:`.surface`),
repair on request (:mod:`.repair`), surfaces as thin sheets (:mod:`.sheet`) and volume meshes
(:mod:`.volume`)."""

from .surface import MeshChecks, TriangleMesh, check_mesh

__all__ = ["TriangleMesh", "MeshChecks", "check_mesh"]
