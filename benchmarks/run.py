"""Run the benchmarks and print their tables: ``python3 benchmarks/run.py [--quick] [names...]``.

Each ``benchmarks/bench_<name>.py`` defines ``run(quick: bool) -> str`` (a
Markdown table, side by side with trimesh/scipy where relevant) and generates
its own meshes under ``benchmarks/_data/``.  ``bench_props`` (speed and memory
of ``massprops props``) runs first.  Names select benchmarks (``props``,
``batch``, ...); none means all.  Speed is only ever measured, never asserted.
"""

from __future__ import annotations

import argparse
import glob
import importlib.util
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def available():
    """Benchmark names, ``props`` first."""
    names = sorted(os.path.basename(p)[len("bench_"):-len(".py")] for p in glob.glob(os.path.join(HERE, "bench_*.py")))
    return sorted(names, key=lambda name: name != "props")


def load(name):
    spec = importlib.util.spec_from_file_location(f"bench_{name}", os.path.join(HERE, f"bench_{name}.py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module           # so that worker processes can unpickle its functions
    spec.loader.exec_module(module)
    return module


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller meshes, fewer repeats (< 1 minute each)")
    parser.add_argument("names", nargs="*", help=f"benchmarks to run (default all: {', '.join(available())})")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.names) - set(available()))
    if unknown:
        parser.error(f"unknown benchmark {unknown[0]!r}; pick from {', '.join(available())}")
    failed = 0
    for name in args.names or available():
        begin = time.perf_counter()
        print(f"## {name}\n", flush=True)
        try:
            print(load(name).run(quick=args.quick))
        except Exception as exc:       # one broken benchmark must not hide the others' tables
            failed += 1
            print(f"benchmark {name} failed: {type(exc).__name__}: {exc}")
        print(f"\n({name}: {time.perf_counter() - begin:.0f} s)\n", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
