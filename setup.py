"""Build the compiled parts of massprops; all other metadata is in pyproject.toml.

Plain C against the CPython API and the buffer protocol: a C compiler and
setuptools are all the build needs (no numpy headers).  The flags keep IEEE
double semantics: no -ffast-math, and no contraction of a*b+c into fused
multiply-adds, on which the error-free transformations, the predicates and
the error bounds depend.

- ``massprops.core._core``: readers, welding, edges, shells and the moment
  kernel (``massprops/core/src``);
- ``massprops.core._intersect``: exact triangle-intersection and
  point-in-solid predicates (``massprops/core/_intersect.c``).
"""

import glob
import os
import sys

from setuptools import Extension, setup

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCES = sorted(os.path.relpath(path, HERE) for path in glob.glob(os.path.join(HERE, "massprops/core/src/*.c")))
HEADERS = sorted(os.path.relpath(path, HERE) for path in glob.glob(os.path.join(HERE, "massprops/core/src/*.h")))

if sys.platform == "win32":
    COMPILE = ["/O2", "/fp:strict"]
    LINK = []
else:
    COMPILE = ["-O3", "-ffp-contract=off", "-fno-fast-math", "-fno-math-errno", "-pthread",
               "-Wall", "-Wno-unused-function"]
    LINK = ["-pthread"]

setup(ext_modules=[
    Extension("massprops.core._core", sources=SOURCES, depends=HEADERS, extra_compile_args=COMPILE,
              extra_link_args=LINK),
    Extension("massprops.core._intersect", ["massprops/core/_intersect.c"], depends=["massprops/core/predicates.h"],
              extra_compile_args=COMPILE, extra_link_args=LINK, libraries=[] if sys.platform == "win32" else ["m"]),
])
