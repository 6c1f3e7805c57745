"""The compiled parts of massprops (the rest of the build is in pyproject.toml)."""

import sys

from setuptools import Extension, setup

_POSIX = sys.platform != "win32"

setup(
    ext_modules=[
        Extension(
            "massprops.core._intersect",
            ["massprops/core/_intersect.c"],
            depends=["massprops/core/predicates.h"],
            # Contracting a*b + c into one fused operation would change the roundings the
            # predicates' error bounds are derived for.
            extra_compile_args=(["-O2", "-ffp-contract=off", "-fno-fast-math", "-pthread"] if _POSIX
                                else ["/O2", "/fp:strict"]),
            extra_link_args=["-pthread"] if _POSIX else [],
            libraries=["m"] if _POSIX else [],
        ),
    ],
)
