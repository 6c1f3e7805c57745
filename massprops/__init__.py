"""massprops: exact mass properties of solids from meshes.

>>> import massprops
>>> result = massprops.mass_properties("part.stl", density=7850, unit="mm")  # doctest: +SKIP
>>> result.properties.inertia_com                                            # doctest: +SKIP

Nothing heavy is imported here: trimesh, scipy and meshio load only when a
reader or command needs them, and numpy and the pipeline when a name below is
first used (``massprops.mass_properties``, ``from massprops import Pose``).
So ``import massprops.cli`` loads no numpy, and the command line can choose
numpy's BLAS threads before numpy starts them (:mod:`massprops.cli`).
"""

import gc as _gc
import importlib as _importlib

# name -> the module that defines it
_EXPORTS = {
    "mass_properties": ".api",
    "Result": ".result",
    "MassPropsError": ".model.errors",
    "Pose": ".model.frames",
    "TriangleMesh": ".mesh",
    "ErrorBounds": ".model.properties",
    "MassProperties": ".model.properties",
}

__all__ = ["mass_properties", "Result", "MassProperties", "ErrorBounds", "Pose", "TriangleMesh", "MassPropsError"]
__version__ = "0.1.0"


def __getattr__(name):
    """Load the public names on first use (PEP 562), all at once; or a subpackage named (``massprops.io``)."""
    if name in _EXPORTS:
        loaded = _load_quietly(lambda: {key: getattr(_importlib.import_module(module, __name__), key)
                                       for key, module in _EXPORTS.items()})
        globals().update(loaded)
        return loaded[name]
    if not name.startswith("_"):
        try:
            return _load_quietly(lambda: _importlib.import_module(f".{name}", __name__))
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}":
                raise
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))


def _load_quietly(load):
    """``load()`` with the cyclic garbage collector paused, and left as it was found.

    Importing makes tens of thousands of long-lived objects (numpy's and
    ours): the collector, run every 2,000 of them, would find nothing to free
    in them, at a tenth of the start-up time (issue 24).
    """
    collecting = _gc.isenabled()
    _gc.disable()
    try:
        return load()
    finally:
        if collecting:
            _gc.enable()
