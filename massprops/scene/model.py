"""What a scene is: parts (one pose, or many placements as arrays), frames, and the report request."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..compute import QUANTITIES, order_for
from ..model.frames import Pose

__all__ = ["Part", "Placements", "Frame", "ReportRequest", "Scene", "DEFAULT_QUANTITIES"]

DEFAULT_QUANTITIES = frozenset(q for q in QUANTITIES if q != "principal")


@dataclass(frozen=True, eq=False)
class Placements:
    """Many poses of one part, held as arrays (no per-instance objects).

    Attributes
    ----------
    rotation : ndarray, shape (n, 3, 3)
        ``A_k``: proper rotations, instance ``k`` at ``x = A_k x' + t_k``.
    translation : ndarray, shape (n, 3)
        ``t_k``, mesh units.
    names : tuple of str or None
        The instances' names; None names them ``PART[k]``, ``k`` from 0.
    """

    rotation: np.ndarray
    translation: np.ndarray
    names: tuple | None = None

    def __len__(self):
        return int(self.translation.shape[0])


@dataclass(frozen=True, eq=False)
class Part:
    """One placed solid, or (with ``placements``) the same solid placed many times.

    Attributes
    ----------
    name : str
    mesh : str
        Key of its mesh in :attr:`Scene.meshes` (a file path for TOML scenes).
    pose : Pose
        ``x = A x'' + t`` for points ``x''`` of the stretched mesh (the mesh itself if rigid).
        Ignored when ``placements`` is given.
    density, mass : float or None
        At most one; density 1 when neither is given (``mass`` is per instance).
    stretch : ndarray, shape (3, 3), or None
        ``P`` of a non-rigid placement (local points ``x'' = P x'``); None when rigid.
    density_field, density_map : str, dict of str to float, or None
        Per-cell density of a volume mesh (see :func:`massprops.mesh.volume.cell_densities`).
    placements : Placements or None
        The instances' poses, when the part stands for many.
    """

    name: str
    mesh: str
    pose: Pose = field(default_factory=Pose)
    density: float | None = None
    mass: float | None = None
    stretch: np.ndarray | None = None
    density_field: str | None = None
    density_map: dict | None = None
    placements: Placements | None = None

    @property
    def count(self):
        """Number of instances."""
        return 1 if self.placements is None else len(self.placements)

    def arrays(self):
        """``(rotation (n, 3, 3), translation (n, 3))`` of every instance."""
        if self.placements is None:
            return self.pose.rotation[None], self.pose.translation[None]
        return self.placements.rotation, self.placements.translation

    def instance_names(self):
        """The instances' names, in order."""
        if self.placements is None:
            return (self.name,)
        return self.placements.names or tuple(f"{self.name}[{k}]" for k in range(self.count))

    def instances(self):
        """One rigid :class:`Part` per instance (built only for per-part output)."""
        if self.placements is None:
            return (self,)
        rotation, translation = self.arrays()
        return tuple(replace(self, name=name, pose=Pose(rotation[k], translation[k]), placements=None)
                     for k, name in enumerate(self.instance_names()))


@dataclass(frozen=True, eq=False)
class Frame:
    """A named frame; ``pose`` is relative to ``part``'s frame when given, else global."""

    name: str
    pose: Pose
    part: str | None = None


@dataclass(frozen=True)
class ReportRequest:
    """What a scene asks to be reported.

    ``principal`` is a subset of ``{"total", "parts"}``; ``about`` names frames
    or parts whose frames the inertia is also expressed in (when "inertia" is
    among the quantities); ``unit`` is the meshes' length unit (outputs then SI).
    """

    parts: bool = True
    total: bool = True
    quantities: frozenset = DEFAULT_QUANTITIES
    principal: frozenset = frozenset({"total"})
    about: tuple = ()
    unit: str | None = None

    def wanted(self, scope):
        """Quantities to report for ``scope`` ("parts" or "total")."""
        return set(self.quantities) | ({"principal"} if scope in self.principal else set())

    @property
    def order(self):
        """Highest moment the request needs (0 volume/mass, 1 COM, 2 inertia)."""
        needed = set(self.quantities) | ({"principal"} if self.principal else set())
        return order_for(needed)


@dataclass(frozen=True, eq=False)
class Scene:
    """Parts, frames and the report request; ``meshes`` maps a mesh key to a path or a TriangleMesh."""

    path: str
    parts: tuple
    frames: dict = field(default_factory=dict)
    report: ReportRequest = field(default_factory=ReportRequest)
    meshes: dict = field(default_factory=dict)

    def placed_parts(self):
        """Every instance as its own rigid :class:`Part`, in order."""
        return tuple(one for part in self.parts for one in part.instances())

    def part_pose(self, name):
        """The pose of the part or instance called ``name`` (KeyError if none)."""
        for part in self.parts:
            if part.name == name and part.placements is None:
                return part.pose
        for part in self.parts:
            if part.placements is not None and name in part.instance_names():
                rotation, translation = part.arrays()
                k = part.instance_names().index(name)
                return Pose(rotation[k], translation[k])
        raise KeyError(name)

    def frame_poses(self, length=1.0):
        """Global pose of every named frame, and of every part named in ``report.about``, by name.

        ``length`` converts the scene's positions (mesh units) to the output unit.
        """
        poses = {name: _scaled(self.part_pose(name), length) for name in self.report.about
                 if name not in self.frames}
        for frame in self.frames.values():
            pose = _scaled(frame.pose, length)
            poses[frame.name] = _scaled(self.part_pose(frame.part), length).compose(pose) if frame.part else pose
        return poses


def _scaled(pose, length):
    return pose if length == 1.0 else Pose(pose.rotation, pose.translation * length)
