"""The one boundary around third-party readers (trimesh, meshio, lxml, ...).

Whatever such a reader does with a bad file -- raise any exception, call
``sys.exit`` (meshio does, after printing to stdout and stderr), print stray
lines, warn -- becomes one :class:`massprops.model.errors.MeshFormatError` naming the
file, and nothing it prints reaches our stdout (a CSV report on stdout must
not start with meshio's blank lines).
"""

from __future__ import annotations

import contextlib
import io
import warnings

from ..model.errors import MassPropsError, MeshFormatError, reason as reason_of

__all__ = ["third_party"]

_LONGEST_REASON = 240


def _said(*streams):
    """What a reader printed, as one short line (blank lines dropped)."""
    lines = [line.strip().removeprefix("Error: ") for stream in streams for line in stream.getvalue().splitlines()]
    return "; ".join(line for line in lines if line)


def _short(text):
    text = " ".join(text.split())
    return text if len(text) <= _LONGEST_REASON else text[:_LONGEST_REASON - 1] + "…"


def third_party(path, library, read, *args, **kwargs):
    """``read(*args, **kwargs)``, a third-party reader of ``path``, behind the boundary.

    Parameters
    ----------
    path : str
        The file being read (named in the error).
    library : str
        The reader's name, for the message (``"meshio"``, ``"trimesh"``).

    Raises
    ------
    MeshFormatError
        For anything ``read`` raises (KeyboardInterrupt and MemoryError
        excepted) or any ``SystemExit``.
    """
    out, err = io.StringIO(), io.StringIO()
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            warnings.simplefilter("ignore")
            return read(*args, **kwargs)
    except MassPropsError:
        raise
    except SystemExit as exc:
        reason = _said(out, err) or f"it exited with status {exc.code}"
    except Exception as exc:  # noqa: BLE001 - third-party readers raise every type for bad bytes
        reason = reason_of(exc)
    raise MeshFormatError(f"cannot parse the file ({library}: {_short(reason)})", path=path,
                          fix="check that the file is a complete mesh of this format")
