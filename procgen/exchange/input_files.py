"""Opening the files users hand procgen: regular files only, each kind bounded in size.

Why: a path in a recipe (or a name inside a mesh, an MTL or a glTF) may point at a named pipe,
a device or a folder, and reading one blocks forever or never ends; a file may also be far
larger than anything a recipe can use. Every reader opens its input through here, so each
refuses such a file in one line naming it, before any library sees a byte. The open is
non-blocking and the type is checked again on the open descriptor, so a FIFO swapped in
between the check and the open cannot hang the run either.
"""
from __future__ import annotations

import io
import os
import stat
from pathlib import Path

from ..errors import InputError, printable

MiB = 2**20
GiB = 2**30

#: the largest file of each kind procgen opens (bytes); bigger ones are refused unread
MAX_BYTES: dict[str, int] = {
    "SVG": 32 * MiB,        # a drawing; svgelements holds it whole as Python objects
    "mesh": 1 * GiB,        # OBJ/PLY/STL/OFF/GLB/glTF: about 20M faces of text OBJ
    "mesh part": 512 * MiB,  # an OBJ's MTL, a glTF's external buffer (textures are only checked)
    "image": 512 * MiB,     # PNG/JPEG/BMP/WebP; the pixel count is bounded separately
    "NPY": 16 * GiB,        # the memory check of the rule that reads it is the tighter bound
    "GeoTIFF": 16 * GiB,    # read by windows of the header's size; same memory check
    "sidecar": 1 * MiB,     # procgen's JSON sidecar beside a raster
}

_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a device"),
          (stat.S_ISBLK, "a device"), (stat.S_ISSOCK, "a socket"))


def _refuse_mode(name: str, mode: int) -> None:
    if stat.S_ISREG(mode):
        return
    what = next((text for test, text in _KINDS if test(mode)), "not a regular file")
    raise InputError(f"{name}: is {what}, not a regular file")


def _stat(path: Path, name: str) -> os.stat_result:
    try:
        return os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{name}: file not found") from None
    except OSError as exc:
        raise InputError(f"{name}: cannot be read ({os.strerror(exc.errno) if exc.errno else 'bad path'})") from None
    except ValueError:                  # a NUL byte in the name
        raise InputError(f"{name}: not a valid file name") from None


def _bound(name: str, size: int, kind: str) -> None:
    limit = MAX_BYTES[kind]
    if size > limit:
        raise InputError(f"{name}: {size:,} bytes, more than the {limit / MiB:,.0f} MiB "
                         f"procgen reads from one {kind} file")


def refuse_special(path: str | Path, name: str | None = None) -> None:
    """InputError if ``path`` exists but is not a regular file (a folder, FIFO, device...):
    for finding a file among candidate folders, where a missing one is not yet an error."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return
    _refuse_mode(printable(name if name is not None else str(path)), mode)


def check_input(path: str | Path, kind: str, name: str | None = None) -> int:
    """The size of ``path`` after refusing (InputError, one line naming ``name`` or the path)
    anything that is missing, not a regular file, or larger than ``MAX_BYTES[kind]``."""
    name = printable(name if name is not None else str(path))
    st = _stat(Path(path), name)
    _refuse_mode(name, st.st_mode)
    _bound(name, st.st_size, kind)
    return st.st_size


def open_input(path: str | Path, kind: str, name: str | None = None) -> io.BufferedReader:
    """``path`` opened for binary reading, refused as in ``check_input`` (checked again on the
    open descriptor); the caller closes it."""
    name = printable(name if name is not None else str(path))
    check_input(path, kind, name)
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise InputError(f"{name}: cannot be read ({os.strerror(exc.errno) if exc.errno else 'bad path'})") from None
    try:
        st = os.fstat(fd)
        _refuse_mode(name, st.st_mode)
        _bound(name, st.st_size, kind)
    except BaseException:
        os.close(fd)
        raise
    return os.fdopen(fd, "rb")


def read_input(path: str | Path, kind: str, name: str | None = None) -> bytes:
    """The bytes of ``path``, refused as in ``open_input``; never more than the limit is read
    even if the file grows meanwhile."""
    name = printable(name if name is not None else str(path))
    with open_input(path, kind, name) as fh:
        try:
            data = fh.read(MAX_BYTES[kind] + 1)
        except OSError as exc:
            raise InputError(f"{name}: cannot be read ({os.strerror(exc.errno) if exc.errno else 'read failed'})") from None
    _bound(name, len(data), kind)
    return data
