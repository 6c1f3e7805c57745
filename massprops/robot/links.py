"""A link's mass properties from its geometry: the geometries computed, their densities chosen, then combined.

Density of each geometry, first that applies (the *mass policy* ``density``):

1. the config file's ``[geometries."LINK/NAME"]`` (``density``, ``mass`` or ``material``);
2. the config file's ``[links."GLOB"]`` (``density``, ``material``; a link ``mass``
   is the link's total, spread over its geometries by 3–5);
3. the format's own: SDF ``<collision><density>`` (or the link's
   ``<inertial><density>``), MJCF geom ``density``/``mass``;
4. ``--density``;
5. 1000 kg/m³ (water, sdformat's and MuJoCo's default), with a warning.

With the policy ``keep`` (the default of ``check`` and ``write``) a link
that declares a positive mass gets that mass, spread over its geometries in
proportion to the masses 1–5 give; ``density`` is then the implied one.

Several geometries of a link are combined by :func:`massprops.robot.overlap.link_solid`:
their union, each point counted once (the parallel-axis sums of
:func:`massprops.model.combine.combine_parts` where they do not overlap).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.rounding import U as _U
from ..model.errors import MassPropsError
from .geometry import OnOpen, geometry_properties
from .overlap import link_solid

__all__ = ["MassSettings", "LinkProps", "link_properties", "scaled_to_mass", "DEFAULT_DENSITY",
           "assumed_density_warning"]

DEFAULT_DENSITY = 1000.0


@dataclass(frozen=True)
class MassSettings:
    """How link geometry becomes mass: policy, densities, which geometry, what to do with bad meshes."""

    policy: str = "density"
    density: float | None = None
    geometry: str = "collision"
    repair: bool = False
    on_open: OnOpen = OnOpen()
    config: object = None
    tolerance: float = 1e-9          # relative bound asked of the union of overlapping primitives
    limits: tuple = ()               # the mesh readers' graph limits, (name, value) pairs (see RobotSettings.limits)


@dataclass(frozen=True, eq=False)
class LinkProps:
    """A link's computed properties (link frame) and how they were made.

    ``props`` is None when the link has no geometry with volume.
    ``geometries`` holds one JSON-able dict per geometry; ``bounds`` (2, 3)
    is the box of the link's geometry in the link frame, or None;
    ``checks`` what combining them found (:class:`massprops.robot.overlap.LinkSolid`).
    ``density_mass`` is the mass the densities give (before a declared or config mass replaces it);
    ``assumed_density`` says a geometry's density fell back to the default (the caller warns once per model).
    """

    props: object
    geometries: tuple = ()
    warnings: tuple = ()
    triangles: int = 0
    bounds: np.ndarray | None = None
    mass_source: str = ""
    results: tuple = field(default=(), repr=False)
    checks: dict = field(default_factory=dict)
    density_mass: float | None = None
    assumed_density: bool = False

    @property
    def size(self):
        """The diagonal of the geometry's box in the link frame (metres), 0 without geometry."""
        return 0.0 if self.bounds is None else float(np.linalg.norm(self.bounds[1] - self.bounds[0]))


def scaled_to_mass(props, mass, *, exact_mass=True):
    """The same solid with its density scaled so the mass is ``mass``.

    ``mass`` is taken as exact (a declared value) unless ``exact_mass`` is
    False; the inertia's bound grows by the relative error of the ratio.
    """
    k = float(mass) / props.mass
    relative = props.error.mass / props.mass + 2 * _U
    inertia = None if props.inertia_com is None else props.inertia_com * k
    error = replace(props.error, mass=0.0 if exact_mass else props.error.mass * k,
                    inertia_com=props.error.inertia_com * k + (
                        0.0 if inertia is None else relative * float(np.abs(inertia).max())))
    return replace(props, mass=float(mass), density=props.density * k, inertia_com=inertia, error=error)


def _density_for(link, geometry, settings):
    """``(density or None, mass or None, source)`` for one geometry by the chain above."""
    config = settings.config
    if config is not None:
        found = config.geometry_material(link.name, geometry.name)
        if found is not None:
            return found
        found = config.link_material(link.name)
        if found is not None and found[0] is not None:
            return found
    if geometry.mass is not None:
        return None, float(geometry.mass), "format (geometry mass)"
    if geometry.density is not None:
        return float(geometry.density), None, "format"
    if settings.density is not None:
        return float(settings.density), None, "{density}"
    return DEFAULT_DENSITY, None, "default"


def _policy(link, settings):
    config = settings.config
    policy = config.link_policy(link.name) if config is not None else None
    return policy or settings.policy


def _geometries(link, settings, resolver):
    """Each chosen geometry computed at its density: ``(results, infos, warnings, defaulted)``.

    ``results`` holds ``(geometry, MassProperties, GeometryResult)`` for those with volume;
    ``infos`` one JSON-able dict per geometry; ``defaulted`` whether a density fell back to 1000.
    """
    results, infos, warnings, defaulted = [], [], [], False
    for geometry in link.chosen(settings.geometry):
        density, mass, source = _density_for(link, geometry, settings)
        try:
            result = geometry_properties(geometry, density if density is not None else 1.0, resolver=resolver,
                                         repair=settings.repair, on_open=settings.on_open, limits=settings.limits)
        except MassPropsError as exc:
            raise type(exc)(f"link {link.name!r}: {exc.problem}", path=exc.path, fix=exc.fix) from None
        where = geometry.where or geometry.name
        warnings += [w if w.startswith("link ") else f"link {link.name!r}, {w}" if w.startswith(f"{where}: ")
                     else f"link {link.name!r}, {where}: {w}" for w in result.warnings]
        info = {"kind": geometry.kind, "role": geometry.role, "name": geometry.name, "uri": geometry.uri,
                "resolved_path": result.resolved_path, "resolved_by": result.resolved_by}
        if geometry.scale is not None:
            info["scale"] = [float(s) for s in geometry.scale]
        infos.append(info)
        if result.props is None:
            info["included"] = False
            continue
        props = scaled_to_mass(result.props, mass) if mass is not None else result.props
        defaulted = defaulted or (mass is None and source == "default")
        info.update(volume=props.volume, mass=props.mass, density=props.density, density_source=source,
                    triangles=result.triangles, included=True)
        results.append((geometry, props, result))
    return results, infos, warnings, defaulted


def _link_mass(link, settings):
    """``(mass, source)`` the link's total is scaled to (a config mass, or the declared one), or ``(None, "")``."""
    link_mass = settings.config.link_mass(link.name) if settings.config is not None else None
    if link_mass is not None:
        return link_mass, "config mass"
    declared = link.declared
    if declared is not None and declared.mass is not None and math.isfinite(declared.mass.value) \
            and declared.mass.value > 0 and (_policy(link, settings) == "keep" or declared.auto):
        return declared.mass.value, ("declared mass (auto inertial)" if declared.auto
                                     else "declared mass ({mass_policy=keep})")
    return None, ""


def link_properties(model, link, settings, resolver):
    """The :class:`LinkProps` of ``link`` under ``settings``.

    Raises
    ------
    MassPropsError
        A geometry that cannot be computed (missing or open mesh, bad size), with
        the link, the element and the URI named.
    """
    results, infos, warnings, defaulted = _geometries(link, settings, resolver)
    if not results:
        return LinkProps(None, tuple(infos), tuple(warnings))
    solid = link_solid(link.name, results, repair=settings.repair, tolerance=settings.tolerance)
    total = solid.props
    warnings += solid.warnings
    densities = {props.density for _, props, _ in results}
    if len(densities) == 1:
        total = replace(total, density=densities.pop())      # one material: its density, not mass / volume
    density_mass = total.mass
    mass, mass_source = _link_mass(link, settings)
    if mass is not None:
        ratio = mass / total.mass
        total = scaled_to_mass(total, mass)
        for info in infos:
            if info.get("included"):
                info.update(mass=info["mass"] * ratio, density=info["density"] * ratio, density_source=mass_source)
    assumed = mass is None and defaulted and not (link.declared is not None and link.declared.mass is not None
                                                  and link.declared.mass.value == 0)
    boxes = [r.bounds for _, _, r in results if r.bounds is not None]
    bounds = np.array([np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)]) \
        if boxes else None
    return LinkProps(total, tuple(infos), tuple(warnings), sum(r.triangles for _, _, r in results), bounds,
                     mass_source or "density", tuple(results), _with_own_overlaps(solid.checks, results),
                     density_mass, assumed)


def _with_own_overlaps(checks, results):
    """The link's ``checks`` with each mesh's own overlap (its shells counted once; m³ after its scale) added."""
    own = sum(float((r.checks or {}).get("overlap") or 0.0) for _, _, r in results)
    if not own:
        return checks
    return {**checks, "overlap": float(checks.get("overlap") or 0.0) + own}


def assumed_density_warning(links, policy):
    """The one model-level warning for the links whose density fell back to the default, or None."""
    if not links:
        return None
    named = ", ".join(repr(name) for name in links[:5]) + (f" and {len(links) - 5} more" if len(links) > 5 else "")
    keep = "" if policy == "keep" else ", or keep the declared masses ({mass_policy=keep})"
    return (f"no density given for {len(links)} link(s) ({named}): {DEFAULT_DENSITY:g} kg/m³ (water) assumed — "
            f"give {{density}} or a [links] density in {{config}}{keep}")
