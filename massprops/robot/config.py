"""``--config robot.toml``: materials, per-link and per-geometry density or mass, policies, package paths.

```toml
[packages]                       # package:// and model:// roots, relative to this file
my_robot_description = "../my_robot_description"

[materials]                      # kg/m³
aluminium = 2700
steel = 7850

[links."arm_*"]                  # glob on link names; every matching table applies, later keys win
material = "aluminium"           # or density = 2700, or mass = 1.25 (the link's total, kg)
mass_policy = "density"          # or "keep" (the declared mass)
massless = false                 # true: a frame link, mass 0 is valid

[geometries."gripper/collision[0]"]   # glob on LINK/GEOMETRY (the element's name, or ROLE[k])
material = "steel"               # or density = ..., or mass = ... (this geometry's mass)
```
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from fnmatch import fnmatchcase

from ..model.errors import MeshReadError, OptionError

__all__ = ["RobotConfig", "load_config", "POLICIES"]

POLICIES = ("density", "keep")
_LINK_KEYS = {"material", "density", "mass", "mass_policy", "massless"}
_GEOMETRY_KEYS = {"material", "density", "mass"}


@dataclass(frozen=True)
class RobotConfig:
    """A parsed config file (see the module docstring); every lookup is by glob, later tables winning."""

    path: str = ""
    packages: dict = field(default_factory=dict)
    materials: dict = field(default_factory=dict)
    links: tuple = ()
    geometries: tuple = ()

    def _merged(self, tables, name):
        merged = {}
        for glob, table in tables:
            if fnmatchcase(name, glob):
                merged.update(table)
        return merged

    def _material(self, table, where):
        if "mass" in table:
            return None, float(table["mass"]), f"config {where} mass"
        if "density" in table:
            return float(table["density"]), None, f"config {where} density"
        if "material" in table:
            return float(self.materials[table["material"]]), None, f"config {where} material {table['material']}"
        return None

    def geometry_material(self, link, geometry):
        """``(density, mass, source)`` the config gives geometry ``LINK/NAME``, or None."""
        return self._material(self._merged(self.geometries, f"{link}/{geometry}"), "[geometries]")

    def link_material(self, link):
        """``(density, None, source)`` of a link's material or density, or None (a link mass is :meth:`link_mass`)."""
        table = {k: v for k, v in self._merged(self.links, link).items() if k != "mass"}
        return self._material(table, "[links]")

    def link_mass(self, link):
        value = self._merged(self.links, link).get("mass")
        return None if value is None else float(value)

    def link_policy(self, link):
        return self._merged(self.links, link).get("mass_policy")

    def massless(self, link):
        return bool(self._merged(self.links, link).get("massless", False))


def _positive(value, where, path):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise OptionError(f"{where} = {value!r}: a positive number is needed", path=path)
    return float(value)


def _tables(data, section, keys, materials, path):
    tables = []
    for glob, table in (data.get(section) or {}).items():
        if not isinstance(table, dict):
            raise OptionError(f"[{section}.{glob!r}] must be a table", path=path)
        unknown = set(table) - keys
        if unknown:
            raise OptionError(f"[{section}.{glob!r}]: unknown key {sorted(unknown)[0]!r}", path=path,
                              fix=f"use {', '.join(sorted(keys))}")
        given = [k for k in ("material", "density", "mass") if k in table]
        if len(given) > 1:
            raise OptionError(f"[{section}.{glob!r}]: give one of material, density, mass (got {', '.join(given)})",
                              path=path)
        for key in ("density", "mass"):
            if key in table:
                _positive(table[key], f"[{section}.{glob!r}] {key}", path)
        if "material" in table and table["material"] not in materials:
            raise OptionError(f"[{section}.{glob!r}]: material {table['material']!r} is not in [materials]",
                              path=path, fix=f"define it, or use one of {', '.join(materials) or '(none)'}")
        if table.get("mass_policy", "density") not in POLICIES:
            raise OptionError(f"[{section}.{glob!r}]: mass_policy {table['mass_policy']!r}", path=path,
                              fix=f"use {' or '.join(POLICIES)}")
        tables.append((glob, dict(table)))
    return tuple(tables)


def load_config(path):
    """Read and check a config file (TOML)."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python < 3.11
        import tomli as tomllib
    from ..io.inputs import check_input
    path = os.fspath(path)
    check_input(path, what="config file")
    try:
        with open(path, "rb") as handle:
            data = tomllib.load(handle)
    except FileNotFoundError:
        raise MeshReadError("no such config file", path=path, fix="check the {config} path") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise OptionError(f"not valid TOML ({exc})", path=path) from None
    unknown = set(data) - {"packages", "materials", "links", "geometries"}
    if unknown:
        raise OptionError(f"unknown table [{sorted(unknown)[0]}]", path=path,
                          fix="use [packages], [materials], [links.\"GLOB\"], [geometries.\"GLOB\"]")
    folder = os.path.dirname(os.path.abspath(path))
    packages = {name: os.path.normpath(os.path.join(folder, str(value)))
                for name, value in (data.get("packages") or {}).items()}
    materials = {name: _positive(value, f"[materials] {name}", path)
                 for name, value in (data.get("materials") or {}).items()}
    return RobotConfig(path, packages, materials, _tables(data, "links", _LINK_KEYS, materials, path),
                       _tables(data, "geometries", _GEOMETRY_KEYS, materials, path))
