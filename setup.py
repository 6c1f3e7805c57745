"""Build the compiled parts of massprops; all other metadata is in pyproject.toml.

Plain C against the CPython API and the buffer protocol: a C compiler and
setuptools are all the build needs (no numpy headers).  The flags keep IEEE
double semantics: no -ffast-math, and no contraction of a*b+c into fused
multiply-adds, on which the error-free transformations, the predicates and
the error bounds depend.

- ``massprops.core._core``: readers, welding, edges, shells and the moment
  kernel (``massprops/core/src``);
- ``massprops.core._intersect``: exact triangle-intersection and
  point-in-solid predicates (``massprops/core/src/isect``).
"""

import glob
import os
import sys

from setuptools import Extension, setup

HERE = os.path.dirname(os.path.abspath(__file__))


def _files(pattern):
    return sorted(os.path.relpath(path, HERE) for path in glob.glob(os.path.join(HERE, pattern)))


SOURCES = _files("massprops/core/src/*.c")
HEADERS = _files("massprops/core/src/*.h")
# The intersection search shares the thread loop (parallel.c) and core.h with the core.
ISECT_SOURCES = _files("massprops/core/src/isect/*.c") + ["massprops/core/src/parallel.c"]
ISECT_HEADERS = _files("massprops/core/src/isect/*.h") + ["massprops/core/src/core.h"]

if sys.platform == "win32":
    COMPILE = ["/O2", "/fp:strict"]
    LINK = []
else:
    COMPILE = ["-O3", "-ffp-contract=off", "-fno-fast-math", "-fno-math-errno", "-pthread",
               "-Wall", "-Wno-unused-function"]
    LINK = ["-pthread"]

setup(ext_modules=[
    Extension("massprops.core._core", sources=SOURCES, depends=HEADERS, extra_compile_args=COMPILE,
              extra_link_args=LINK, libraries=[] if sys.platform == "win32" else ["m"]),
    Extension("massprops.core._intersect", ISECT_SOURCES, depends=ISECT_HEADERS, extra_compile_args=COMPILE,
              extra_link_args=LINK, libraries=[] if sys.platform == "win32" else ["m"]),
])
