"""The ``massprops`` command line: one click group, one module per subcommand.

Subcommand modules are imported only when their command runs (or help lists
them), so ``massprops props`` on a small mesh pays for nothing else.  Only this
package imports click, prints, or exits.
"""

from __future__ import annotations

import errno
import gc
import importlib
import os
import sys
import warnings

from .. import _load_quietly

click = _load_quietly(lambda: importlib.import_module("click"))    # the collector paused: see massprops/__init__.py

# name -> (module, function); each module is massprops/cli/<module>.py
COMMANDS = {
    "props": ("props", "props"),
    "scene": ("scene", "scene"),
    "batch": ("batch", "batch"),
    "solids": ("solids", "solids"),
    "regress": ("regress", "regress"),
    "compare": ("compare", "compare"),
    "check": ("compare", "check"),          # the old name of compare, hidden
    "accuracy": ("accuracy", "accuracy"),
    "spin": ("spin", "spin"),
    "robot": ("robot", "robot"),
    "view": ("view", "view"),
}
HIDDEN = frozenset({"check"})


# numpy's BLAS (OpenBLAS, MKL, Accelerate, BLIS) starts a thread per core when numpy is imported, and
# OpenBLAS's spin while idle: on two cores that is one core busy during start-up and the compiled core's
# second thread slowed (issue 24).  The command line does no large matrix products (3×3 ones, and
# vertices times a 3×3 rotation, which one thread streams as fast), so its process asks for one BLAS
# thread before numpy loads, unless the user set a count.  Only the command line does this: importing
# massprops (or massprops.cli) leaves the environment alone.
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "BLIS_NUM_THREADS")


class LazyGroup(click.Group):
    """A click group that imports a subcommand's module on first use.

    It is also the last edge: output that cannot be written (a full disk, a
    closed pipe) ends the command with one line and exit 1, not a traceback.
    """

    def __call__(self, *args, **kwargs):
        """The ``massprops`` script (and ``python -m massprops``): one BLAS thread, the pipeline, the command."""
        if "numpy" not in sys.modules:
            for name in BLAS_THREADS:
                os.environ.setdefault(name, "1")
        # The pipeline (and numpy) is loaded here, a few frames below the script, when a command is named
        # (not for `massprops --version`).  Loaded from the group's callback, under click's frames, the
        # imports' calls kept crossing a boundary of the interpreter's frame stack (CPython 3.11 keeps it in
        # 16 KiB chunks, mapped and unmapped as a call crosses one): 1,800 mmap/munmap pairs and as many
        # page faults, about 8 ms of a 97 ms start (issue 24).  The callback's own load is then a no-op.
        arguments = kwargs.get("args", args[0] if args else None)
        if any(argument in COMMANDS for argument in (sys.argv[1:] if arguments is None else arguments)):
            _load_pipeline()
        return super().__call__(*args, **kwargs)

    def invoke(self, ctx):
        try:
            try:
                return super().invoke(ctx)
            finally:
                sys.stdout.flush()
        except OSError as exc:
            from ..model.errors import MassPropsError
            if isinstance(exc, MassPropsError):
                raise
            _output_failed(exc)
            ctx.exit(1)

    def list_commands(self, ctx):
        import importlib.util          # for help only: a wheel's start-up does not load it otherwise
        return [name for name, (module, _) in COMMANDS.items() if name not in HIDDEN and importlib.util.find_spec(
            f"{__name__}.{module}") is not None]

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        module, attribute = COMMANDS[name]
        try:
            return getattr(_load_quietly(lambda: importlib.import_module(f"{__name__}.{module}")), attribute)
        except ModuleNotFoundError as exc:
            if exc.name == f"{__name__}.{module}":
                return None
            raise


def _load_pipeline():
    """Load the pipeline every command runs (and numpy) with the collector paused, then freeze what is loaded.

    After the script chose the BLAS threads, before the command's options are parsed.  numpy first,
    on its own: its imports nest deepest, and under massprops' own import chain they still crossed a
    chunk of the frame stack (LazyGroup.__call__).  What is loaded (modules, classes, click's commands)
    lives until the process ends: frozen (``gc.freeze``), the cyclic garbage collector does not walk it
    again, during the command or at exit.  Left unfrozen until the group's callback, the first young
    generation pass walked all of it while click parsed the options (6M instructions, issue 24).
    """
    def load():
        import numpy  # noqa: F401
        from .. import mass_properties  # noqa: F401

    _load_quietly(load)
    gc.freeze()


def _output_failed(exc):
    """Say that writing failed (unless the reader went away), and send what is still buffered nowhere."""
    if exc.errno != errno.EPIPE:
        where = f"{exc.filename}: " if exc.filename else ""
        click.echo(f"error: {where}cannot write the output ({exc.strerror or exc}) — free space or write "
                   "elsewhere", err=True)
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())          # the interpreter's last flush then succeeds
    except (OSError, ValueError, AttributeError):
        pass


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="massprops")
def main():
    """Exact mass properties of solids from meshes.

    Inertia tensors are J = ∫ (sᵀs I − s sᵀ) dm (off-diagonals are the tensor's
    own, J_xy = −∫ x y dm); a pose maps local x' to global x = A x' + t.
    """
    # Overflow and invalid values are checked and reported in words; numpy's own notes would be noise.
    if not os.environ.get("MASSPROPS_DEBUG"):
        warnings.filterwarnings("ignore", category=RuntimeWarning)
    _load_pipeline()
