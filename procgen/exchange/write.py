"""The only place procgen writes files: atomically, and a run's files all or none.

A file goes to a temporary name in its folder and is renamed over the target, so readers see
the old file or the whole new one. A run's files are first written into a hidden staging
folder, then moved in (a new folder appears in one rename), so a full disk or a killed process
leaves the old folder or the whole new run, never 7 of its 10 files without its run.json. A
failed write is one line naming the file the user asked for and the reason in plain words.
"""
from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from ..errors import ProcgenError, printable

#: prefix of staging folders; one left behind by a killed process is never a complete run
STAGING_PREFIX = ".tmp-"


class WriteError(ProcgenError):
    """An output file could not be written (disk full, no permission, read-only disk...)."""


def _reason(exc: OSError) -> str:
    """``no space left on device``: what the system says, in its own words, lower case."""
    text = exc.strerror or (os.strerror(exc.errno) if exc.errno else "") or "the system refused"
    return text[:1].lower() + text[1:]


def _failure(path: Path, exc: OSError) -> WriteError:
    if isinstance(exc, (FileExistsError, NotADirectoryError)):    # a file where a folder must be
        blocker = next((p for p in (path, *path.parents) if p.exists() and not p.is_dir()), None)
        if blocker is not None:
            return WriteError(f"{printable(str(path))}: cannot write ({printable(str(blocker))} is a file, "
                              "not a folder)")
    return WriteError(f"{printable(str(path))}: cannot write ({_reason(exc)})")


def _store(fd: int, blob: bytes) -> None:
    """Write every byte of ``blob`` to ``fd`` and flush it to the disk."""
    view = memoryview(blob)
    while view:
        view = view[os.write(fd, view):]
    os.fsync(fd)


def _put(path: Path, blob: bytes) -> None:
    """Temp file beside ``path``, then rename over it; the temp file never outlives a failure."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        try:
            _store(fd, blob)
        finally:
            os.close(fd)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def _blob(data: bytes | str) -> bytes:
    return data.encode("utf-8") if isinstance(data, str) else bytes(data)


def write(path: str | Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` so that readers see the old file or the whole new one.

    Raises WriteError (one line: the file and the reason) when the system refuses.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _put(path, _blob(data))
    except OSError as exc:
        raise _failure(path, exc) from None
    return path


def make_folder(folder: str | Path) -> Path:
    """``folder`` and its parents created if missing; WriteError (one line: the folder and the
    reason: a read-only disk, a file in the way...) when the system refuses."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _failure(folder, exc) from None
    return folder


def write_many(folder: str | Path, files: dict[str, bytes | str]) -> list[Path]:
    """Write several files (each atomically); returns their paths."""
    return [write(Path(folder) / name, data) for name, data in files.items()]


def write_folder(folder: str | Path, files: dict[str, bytes | str], *, replace: bool = False) -> list[Path]:
    """Write ``files`` (relative path -> data) into ``folder``: all of them or none.

    They are written into a staging folder first; nothing in ``folder`` changes until every file
    is on the disk. A new folder then appears with one rename. With ``replace`` the folder
    becomes exactly ``files`` (its old content goes); without, the files are moved into the
    existing folder in order, so the last one (a run's record) arrives last and other files stay.
    Raises WriteError naming the file that could not be written; the staging folder is removed.
    """
    folder = Path(folder)
    names = [(rel, folder / rel) for rel in files]
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
        fresh = replace or not folder.is_dir()
        # a new folder is staged beside it; files for an existing one inside it (same disk)
        stage = Path(tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{folder.name}-",
                                      dir=folder.parent if fresh else folder))
        os.chmod(stage, 0o755)                 # it may become the run folder itself
    except OSError as exc:
        raise _failure(folder, exc) from None
    try:
        for (rel, target), data in zip(names, files.values()):
            try:
                (stage / rel).parent.mkdir(parents=True, exist_ok=True)
                _put(stage / rel, _blob(data))
            except OSError as exc:
                raise _failure(target, exc) from None
        if fresh:
            old = folder.parent / f"{stage.name}-old"
            try:
                if folder.is_dir():
                    os.replace(folder, old)          # the old folder steps aside...
                os.replace(stage, folder)            # ...and the new one takes its name
            except OSError as exc:
                if old.is_dir() and not folder.exists():
                    os.replace(old, folder)
                raise _failure(folder, exc) from None
            shutil.rmtree(old, ignore_errors=True)
        else:
            for rel, target in names:
                try:
                    target.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(stage / rel, target)
                except OSError as exc:
                    raise _failure(target, exc) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return [target for _, target in names]
