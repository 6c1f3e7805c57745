"""One model, start to end: read it, compute every link, check what it declares, and the robot's total.

:func:`analyze` returns the SPEC's ``robot`` JSON object for one model (a
plain dict, so models can be analysed in worker processes); it never raises
for a bad model: a model that cannot be read at all gives an object with
``status`` ``error`` and its message, and a link that fails gets status
``error`` while the others are still reported.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field, replace
from fnmatch import fnmatchcase

from ..model.errors import MassPropsError, render_options
from .check import Tolerances, compare, declared_validity, diagnose, MESH_SCALES
from .geometry import parse_on_open
from .links import MassSettings, assumed_density_warning, link_properties, scaled_to_mass

__all__ = ["RobotSettings", "analyze", "prepare", "STATUSES", "FAILING"]

STATUSES = ("ok", "mismatch", "invalid", "missing", "no-geometry", "massless", "error")
FAILING = ("invalid", "error")


@dataclass(frozen=True)
class RobotSettings:
    """Everything a ``robot`` command computes a model with (picklable, for worker processes).

    ``mass_policy`` None takes the command's default: ``density`` for props,
    ``keep`` for check and write.
    """

    command: str = "props"
    geometry: str = "collision"
    mass_policy: str | None = None
    density: float | None = None
    packages: tuple = ()
    config_path: str | None = None
    joints: str | None = None
    repair: bool = False
    on_open: str | None = None
    tolerances: Tolerances = field(default_factory=Tolerances)
    massless: tuple = ()
    declared_only: bool = False
    xacro_args: tuple = ()
    allow_env: bool = False               # xacro's $(env ...), $(optenv ...) and $(cwd) may read the environment
    roots: tuple = ()                     # folders the model may read from besides its own package (--root)
    option_style: str = "python"          # how messages spell options: "python" (repair=True) or "cli" (--repair)
    tolerance: float = 1e-9               # relative bound asked of a link's union of overlapping primitives
    max_instances: int | None = None      # instance-graph limits of the mesh readers (3MF, COLLADA); None: default
    max_depth: int | None = None

    @property
    def limits(self):
        """The mesh readers' graph limits given, as ``(name, value)`` pairs (hashable: a cache key)."""
        return tuple((name, value) for name, value in (("max_instances", self.max_instances),
                                                       ("max_depth", self.max_depth)) if value is not None)

    @property
    def policy(self):
        return self.mass_policy or ("density" if self.command == "props" else "keep")


@dataclass
class Prepared:
    """A model read and its settings resolved: what :func:`analyze` and the writer share."""

    model: object
    resolver: object
    mass: MassSettings
    config: object
    values: dict
    poses: dict


def prepare(path, settings):
    """Read the config and the model, resolve the mass settings and the link poses (raises MassPropsError)."""
    from .config import load_config
    from .kinematics import link_poses, parse_joint_values
    from .load import load_model
    from .resolve import Resolver
    config = load_config(settings.config_path) if settings.config_path else None
    resolver = Resolver(os.fspath(path), dict(settings.packages), dict(config.packages) if config else {},
                        roots=tuple(settings.roots))
    model = load_model(path, resolver, xacro_args=dict(settings.xacro_args), allow_env=settings.allow_env)
    mass = MassSettings(settings.policy, settings.density, settings.geometry, settings.repair,
                        parse_on_open(settings.on_open), config, tolerance=settings.tolerance,
                        limits=settings.limits)
    values = parse_joint_values(settings.joints, model)
    return Prepared(model, resolver, mass, config, values, link_poses(model, values))


def _message(exc):
    return exc.problem + (f" — {exc.fix}" if exc.fix else "") if isinstance(exc, MassPropsError) else (
        f"internal error ({type(exc).__name__}: {exc}) — please report it; rerun with MASSPROPS_DEBUG=1")


def analyze(path, settings):
    """The ``robot`` JSON object of one model (never raises for a bad model: see the module docstring)."""
    start = time.perf_counter()
    path = os.fspath(path)
    try:
        prepared = prepare(path, settings)
    except Exception as exc:  # noqa: BLE001 - one bad model must not stop the others
        if os.environ.get("MASSPROPS_DEBUG") and not isinstance(exc, MassPropsError):
            raise
        return _spelled({"model": path, "status": "error", "message": _message(exc), "links": [], "total": None,
                         "elapsed_s": time.perf_counter() - start}, settings.option_style)
    return _spelled(_analyzed(prepared, settings, start), settings.option_style)


# The report's sentences, where messages name options as placeholders (massprops.model.errors).
_SENTENCES = frozenset({"message", "warnings", "mass_source", "density_source", "notes"})


def _spelled(obj, style):
    """``obj`` with the option placeholders of its sentences spelled for ``style``."""
    if isinstance(obj, dict):
        return {k: (_spelled_text(v, style) if k in _SENTENCES else _spelled(v, style)) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_spelled(v, style) for v in obj]
    return obj


def _spelled_text(value, style):
    if isinstance(value, str):
        return render_options(value, style)
    if isinstance(value, list):
        return [_spelled_text(v, style) for v in value]
    return _spelled(value, style)


def _analyzed(prepared, settings, start):
    model, poses = prepared.model, prepared.poses
    links, placed, warnings, assumed = [], [], list(model.warnings), []
    for link in model.links:
        began = time.perf_counter()
        computed, error = None, link.error
        if error is None and not settings.declared_only:
            try:
                computed = link_properties(model, link, prepared.mass, prepared.resolver)
            except Exception as exc:  # noqa: BLE001 - the link fails, the others go on
                if os.environ.get("MASSPROPS_DEBUG") and not isinstance(exc, MassPropsError):
                    raise
                error = _message(exc)
                if error.startswith(f"link {link.name!r}: "):
                    error = error[len(f"link {link.name!r}: "):]
        entry = _link_entry(model, link, computed, error, prepared, settings, poses[link.name])
        entry["elapsed_s"] = time.perf_counter() - began
        links.append(entry)
        if computed is not None and computed.props is not None:
            placed.append((computed.props, poses[link.name]))
        if computed is not None and computed.assumed_density:
            assumed.append(link.name)
    warnings += prepared.resolver.notices()
    density_warning = assumed_density_warning(assumed, settings.policy)
    if density_warning:
        warnings.append(density_warning)
    broken = model.extra.get("broken_joints")
    if broken:
        warnings.append(f"no total: joint(s) {', '.join(map(repr, broken))} could not be read, so links are not "
                        "placed")
    total = None if broken else _total(placed, links)
    statuses = {s: sum(1 for link in links if link["status"] == s) for s in STATUSES}
    return {"model": model.path, "format": model.format, "name": model.name, "geometry": settings.geometry,
            "mass_policy": settings.policy, "default_density": _default_density(settings), "status": "ok",
            "frame": model.frame,
            "joints": {j.name: prepared.values.get(j.name, 0.0) for j in model.joints if j.moves},
            "links": links, "total": total, "summary": {k: v for k, v in statuses.items() if v},
            "resolutions": prepared.resolver.resolutions(), "warnings": warnings,
            "writable": model.writable is None, "elapsed_s": time.perf_counter() - start}


def _default_density(settings):
    """kg/m³ for geometry the file and the config give no density or mass: ``--density``, else 1000."""
    from .links import DEFAULT_DENSITY
    if settings.declared_only:
        return None                     # no geometry is computed
    return float(settings.density) if settings.density is not None else DEFAULT_DENSITY


def _total(placed, links):
    from .kinematics import robot_total
    total = robot_total(placed)
    if total is None:
        return None
    left_out = [link["link"] for link in links if link["status"] == "error"]
    out = {"mass": total.mass, "volume": total.volume, "center_of_mass": total.center_of_mass.tolist(),
           "inertia_com": total.inertia_com.tolist(),
           "error": {"mass": total.error.mass, "center_of_mass": total.error.center_of_mass,
                     "inertia_com": total.error.inertia_com},
           "links": len(placed)}
    if left_out:
        out["left_out"] = left_out
    return out


def _declared_dict(inertial):
    if inertial is None:
        return None
    if inertial.auto:
        return {"auto": True, "mass": None if inertial.mass is None else inertial.mass.value,
                "center_of_mass": None, "inertia_com": None}
    out = {"mass": inertial.mass.value, "center_of_mass": inertial.center_of_mass.tolist(),
           "inertia_com": inertial.inertia_com.tolist(), "rotation": inertial.rotation.tolist(),
           "written": {k: v.text for k, v in inertial.written.items()}}
    if inertial.rpy is not None:
        out["rpy"] = list(inertial.rpy)
    if inertial.line is not None:
        out["line"] = inertial.line
    return out


def _computed_dict(link, computed):
    """What the geometry gives: the mass from the densities, and the inertia about its own center of mass at
    the declared mass (at the computed mass when none is declared), link axes; None without geometry."""
    if computed is None or computed.props is None:
        return None
    props = computed.props
    declared = link.declared
    at_declared = declared is not None and not declared.auto and declared.mass is not None and \
        math.isfinite(declared.mass.value) and declared.mass.value > 0
    if at_declared and not math.isclose(props.mass, declared.mass.value, rel_tol=1e-15):
        props = scaled_to_mass(props, declared.mass.value)
    return {"mass": computed.density_mass, "center_of_mass": props.center_of_mass.tolist(),
            "inertia_com": props.inertia_com.tolist(),
            "inertia_at": "declared mass" if at_declared else "computed mass"}


_NULL_PROPS = ("triangles", "volume", "mass", "density", "surface_area", "center_of_mass", "inertia_com",
               "principal_moments", "principal_axes", "degenerate", "center_of_mass_global", "inertia_com_global",
               "inertia_origin", "error")


def _props_dict(model, computed, pose):
    from .. import report
    from ..result import Result
    placed = computed.props.with_pose(pose)
    result = Result(file=model.path, properties=placed, triangles=computed.triangles, checks={},
                    warnings=computed.warnings)
    out = report.result_dict(result)
    for key in ("file", "elapsed_s"):
        out.pop(key, None)
    out["checks"] = dict(computed.checks)
    out["size"] = computed.size
    out["mass_source"] = computed.mass_source
    return out


def _link_entry(model, link, computed, error, prepared, settings, pose):
    """The JSON object of one link: props keys, then status, declared, diagnoses, geometries, message."""
    entry = {"link": link.name}
    if computed is not None and computed.props is not None:
        entry.update(_props_dict(model, computed, pose))
    else:
        entry.update(dict.fromkeys(_NULL_PROPS))
        entry["warnings"] = list(computed.warnings) if computed is not None else []
    entry["declared"] = _declared_dict(link.declared)
    entry["computed"] = _computed_dict(link, computed)
    entry["geometries"] = list(computed.geometries) if computed is not None else [
        {"kind": g.kind, "role": g.role, "name": g.name, "uri": g.uri, "resolved_path": None, "resolved_by": None}
        for g in link.chosen(settings.geometry)]
    status, message, diagnoses, details, comparison = _status(model, link, computed, error, prepared, settings)
    entry.update(status=status, message=message, diagnoses=diagnoses)
    if details:
        entry["diagnosis_details"] = details
    if comparison is not None:
        entry["comparison"] = comparison
    return entry


def _has_geometry(link, computed, settings):
    """Geometry with volume (computed), or, with --declared-only, geometry elements in the file."""
    if settings.declared_only:
        return bool(link.chosen(settings.geometry))
    return computed is not None and computed.props is not None


def _massless_allowed(model, link, computed, prepared, settings):
    """Mass 0 is valid for a frame link (no geometry), a fixed base (a root), or a link labelled massless."""
    labelled = any(fnmatchcase(link.name, glob) for glob in settings.massless) or (
        prepared.config is not None and prepared.config.massless(link.name))
    fixed = link.parent is None or all(not j.moves for j in model.joints if j.child == link.name)
    if labelled:
        return True, "labelled massless"
    if not _has_geometry(link, computed, settings):
        return True, "a frame link (no geometry)"
    if fixed:
        return True, "attached by a fixed joint (or a fixed base)"
    return False, ""


def _status(model, link, computed, error, prepared, settings):
    """``(status, message, diagnoses, details, comparison)`` of one link."""
    has_geometry = computed is not None and computed.props is not None
    if error is not None:
        return "error", error, [], [], None
    if settings.command == "props":
        if not has_geometry:
            return "no-geometry", "no geometry with volume" if not settings.declared_only else "", [], [], None
        return "ok", "", [], [], None
    declared = link.declared
    if declared is None:
        if not _has_geometry(link, computed, settings):
            return "massless", "no inertial and no geometry: a frame link", [], [], None
        return "missing", "no <inertial>" + ("" if model.format != "sdf" else
                                             " (sdformat would use mass 1 and a unit tensor)"), [], [], None
    if declared.auto:
        return "ok", "<inertial auto=\"true\">: sdformat computes it from the collisions (these values)", [], [], None
    allowed, reason = _massless_allowed(model, link, computed, prepared, settings)
    validity = declared_validity(declared, massless_allowed=allowed)
    if validity.massless:
        return "massless", f"mass 0: {reason}", [], [], None
    mismatch = _mismatch(model, link, computed, prepared, settings) if has_geometry and (
        validity.valid or _comparable(declared)) else None
    if not validity.valid:
        details = [dict(d) for d in validity.details]
        message = "; ".join(validity.problems)
        for detail in details:
            message += f" — {detail['name']}: {detail['message']}"
        names = list(validity.diagnoses)
        if mismatch is not None and mismatch[2]:
            names += [n for n in mismatch[2] if n not in names]
            details += mismatch[3]
            message += " — " + "; ".join(f"{d['name']}: {d['message']}" for d in mismatch[3][:3])
        return "invalid", message, names, details, mismatch[4] if mismatch is not None else None
    if mismatch is None and settings.declared_only:
        return "ok", "valid ({declared_only}: not compared with the geometry)", [], [], None
    if mismatch is None:
        return "no-geometry", "declared inertial is valid; no geometry to check it against", [], [], None
    return mismatch


def _comparable(declared):
    """A declared inertial with a positive, finite mass and finite numbers can be compared even if invalid."""
    values = [declared.mass.value, *declared.center_of_mass, *declared.inertia_com.ravel()]
    return declared.mass.value > 0 and all(math.isfinite(v) for v in values)


def _mismatch(model, link, computed, prepared, settings):
    """``(status, message, diagnoses, details, comparison)`` from comparing with the geometry."""
    declared = link.declared
    props = computed.props
    if not math.isclose(props.mass, declared.mass.value, rel_tol=1e-15):
        props = scaled_to_mass(props, declared.mass.value)
    comparison = compare(declared, props, computed.size, settings.tolerances)
    if not comparison.mismatched:
        return "ok", "", [], [], comparison.as_dict()
    rescaled = _rescaled(model, link, prepared, declared.mass.value)
    from .geometry import enclosing_points
    names, details = diagnose(declared, props, comparison, settings.tolerances, rescaled=rescaled,
                              enclosure=enclosing_points(computed.results))
    parts = []
    if "center_of_mass" in comparison.mismatched:
        parts.append(f"center of mass {comparison.com_distance:.3g} m off ({comparison.com_distance_relative:.1%} "
                     "of the link size)")
    if "inertia" in comparison.mismatched:
        parts.append(f"inertia differs by {comparison.inertia_difference:.1%}")
    message = "; ".join(parts)
    if details:
        message += " — " + "; ".join(f"{d['name']}: {d['message']}" for d in details[:3])
    return "mismatch", message, names, details, comparison.as_dict()


def _rescaled(model, link, prepared, mass):
    """The link recomputed as the ``missing_scale`` diagnosis supposes (see :func:`check.diagnose`)."""
    geometries = link.chosen(prepared.mass.geometry)
    meshes = [g for g in geometries if g.kind == "mesh"]
    out = {}
    if not meshes:
        return out
    unscaled = [g for g in meshes if g.scale is None or all(float(s) == 1 for s in g.scale)]
    keep = replace(prepared.mass, policy="keep")
    if unscaled:
        for factor in MESH_SCALES:
            changed = tuple(replace(g, scale=(factor,) * 3) if g in unscaled else g for g in link.geometries)
            try:
                other = link_properties(model, replace(link, geometries=changed), keep, prepared.resolver)
            except MassPropsError:
                continue
            if other.props is not None:
                out[factor] = scaled_to_mass(other.props, mass)
    scales = {tuple(float(s) for s in g.scale) for g in meshes if g.scale is not None}
    if len(scales) == 1 and len(meshes) == len(geometries):
        factors = scales.pop()
        if len(set(factors)) == 1 and factors[0] not in (1.0, -1.0):
            try:
                base = link_properties(model, link, keep, prepared.resolver)
            except MassPropsError:
                return out
            if base.props is not None:
                base = scaled_to_mass(base.props, mass)
                out[f"linear:{abs(factors[0])!r}"] = replace(base, inertia_com=base.inertia_com / abs(factors[0]))
    return out
