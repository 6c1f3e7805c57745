"""What an input must be before any reader opens it, and the limits that keep reading bounded.

* A **regular file** (or a directory where a command takes one): a FIFO would
  block forever, ``/dev/zero`` would be read until memory runs out, a socket
  cannot be read at all.  Symbolic links are followed, so a link to a device
  is refused as the device.
* A **mesh file has no holes**: a sparse file's holes read as NUL bytes,
  which no text mesh contains and no exporter writes by seeking; it is an
  incomplete copy or download, refused before gigabytes of zeros are parsed
  (binary formats too: PLY, GLB, MuJoCo .msh and VTU would read it whole).
* An **archive** (a zip container such as 3MF) may unpack to at most
  :data:`UNPACK_RATIO` times its own size, or :data:`UNPACK_FLOOR` bytes if
  that is more, unless the caller sets ``max_unpacked`` (bytes).  The sizes
  are the ones the archive declares; Python's zipfile never inflates a member
  beyond its declared size, so the check bounds what a reader can allocate.
* An **instance graph** (3MF components, COLLADA ``<instance_node>``) may
  place at most :data:`MAX_INSTANCES` meshes and nest :data:`MAX_DEPTH`
  levels, unless the caller sets ``max_instances`` / ``max_depth``
  (:func:`graph_limits`); both are counted before anything is expanded.
"""

from __future__ import annotations

import os
import stat

from ..model.errors import MeshFormatError, MeshReadError, OptionError, option

__all__ = ["check_input", "check_no_holes", "check_archive", "unpack_limit", "file_size_text", "graph_limits",
           "UNPACK_RATIO", "UNPACK_FLOOR", "MAX_INSTANCES", "MAX_DEPTH"]

UNPACK_RATIO = 100          # measured on 3MF exports: 5x to 7x; zip bombs: 1000x and more
UNPACK_FLOOR = 64 << 20
MAX_INSTANCES = 100_000     # meshes an instance graph places, counting every path through it
MAX_DEPTH = 100             # levels of nested components or nodes; exporters write 2 to 10

_KINDS = ((stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def file_size_text(size):
    """``size`` bytes for a message: ``"512 bytes"``, ``"3.1 MB"``, ``"2.0 GB"``."""
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if size >= scale:
            return f"{size / scale:.1f} {unit}"
    return f"{size} bytes"


def check_input(path, *, what="file", allow_dir=False, dir_fix=None):
    """``os.stat_result`` of ``path`` if it is a regular file (or a directory, with ``allow_dir``).

    Raises
    ------
    MeshReadError
        Missing, unreadable, a directory (unless allowed), a FIFO, a device or a socket.
    """
    path = os.fspath(path)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        broken = os.path.islink(path)
        raise MeshReadError("is a symbolic link to a missing file" if broken else "no such file", path=path,
                            fix="check the path") from None
    except OSError as exc:
        raise MeshReadError(f"cannot read the {what} ({exc.strerror or exc})", path=path,
                            fix="check the path and its permissions") from None
    if stat.S_ISREG(info.st_mode) or (allow_dir and stat.S_ISDIR(info.st_mode)):
        return info
    if stat.S_ISDIR(info.st_mode):
        raise MeshReadError(f"is a directory, not a {what}", path=path, fix=dir_fix or "name the files in it")
    kind = next((name for test, name in _KINDS if test(info.st_mode)), "not a regular file")
    target = f" (a link to {os.path.realpath(path)})" if os.path.islink(path) else ""
    raise MeshReadError(f"is {kind}{target}, not a regular file", path=path,
                        fix=f"give a {what} on disk (save the data to a file first)")


def check_no_holes(path, info):
    """Refuse a sparse file: its holes read as NUL bytes.  ``info`` is its ``os.stat_result``."""
    blocks = getattr(info, "st_blocks", None)
    seek_hole = getattr(os, "SEEK_HOLE", None)
    if blocks is None or seek_hole is None or blocks * 512 >= info.st_size:
        return                                  # not sparse (almost every file), or no way to tell
    try:
        with open(path, "rb") as handle:
            hole = os.lseek(handle.fileno(), 0, seek_hole)
    except OSError:
        return                                  # the file system cannot say where holes are
    if hole < info.st_size:
        raise MeshFormatError(f"the file is sparse: it has never-written holes from byte {hole} on (they read as "
                              f"zeros) in its {file_size_text(info.st_size)}", path=path,
                              fix="the file is incomplete (an interrupted copy or download); copy or export it again")


def unpack_limit(packed_size, max_unpacked=None):
    """Bytes an archive of ``packed_size`` bytes may unpack to (``max_unpacked`` if given)."""
    if max_unpacked is None:
        return max(UNPACK_FLOOR, UNPACK_RATIO * packed_size)
    if isinstance(max_unpacked, bool) or not isinstance(max_unpacked, int) or max_unpacked <= 0:
        raise OptionError(f"{option('max_unpacked')} must be a positive number of bytes, got {max_unpacked!r}")
    return max_unpacked


def graph_limits(max_instances=None, max_depth=None):
    """``(instances, depth)`` an instance graph may place and nest: the values given, else the defaults.

    Raises
    ------
    OptionError
        A value that is not a positive whole number.
    """
    limits = []
    for name, value, default in (("max_instances", max_instances, MAX_INSTANCES), ("max_depth", max_depth, MAX_DEPTH)):
        if value is None:
            value = default
        elif isinstance(value, bool) or not isinstance(value, int) or value <= 0:
            raise OptionError(f"{option(name)} must be a positive whole number, got {value!r}")
        limits.append(value)
    return tuple(limits)


def check_archive(path, info, max_unpacked=None):
    """Refuse a zip container that declares more unpacked bytes than :func:`unpack_limit` allows."""
    with open(path, "rb") as handle:
        if handle.read(4) != b"PK\x03\x04":
            return
    import zipfile
    try:
        with zipfile.ZipFile(path) as archive:
            unpacked = sum(member.file_size for member in archive.infolist())
    except (zipfile.BadZipFile, OSError, ValueError, EOFError, NotImplementedError):
        return                  # not a zip after all (a binary STL header may start so): the reader judges
    limit = unpack_limit(info.st_size, max_unpacked)
    if unpacked > limit:
        ratio = unpacked / max(1, info.st_size)
        raise MeshFormatError(
            f"the archive unpacks to {file_size_text(unpacked)} ({ratio:.0f} times its size), more than the "
            f"limit of {file_size_text(limit)}", path=path,
            fix=f"if the file is trusted, raise the limit with {option('max_unpacked', 'BYTES')}")
