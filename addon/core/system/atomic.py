"""Every file the project writes is written whole or not at all: into a temporary file beside
its place (``temporary``: ``.<stem>.<pid>.tmp<suffix>``, the suffix kept for writers that read
the format from it), then renamed over it (``os.replace``, atomic on one file system). A reader
(a farm polling the output, Blender reloading an image) never sees half a file, and a failed or
cancelled write leaves the previous file as it was.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Callable
from pathlib import Path

__all__ = ["replace_all", "temporary", "write_atomically", "write_bytes", "write_text"]


def temporary(path: str | os.PathLike) -> Path:
    """The temporary file beside ``path`` that a write goes into first."""
    path = Path(path)
    return path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")


def write_atomically(path: str | os.PathLike, encode: Callable[[Path], None]) -> None:
    """Write ``path`` whole: ``encode(tmp)`` writes the file at the temporary path it is given,
    which then replaces ``path``. On any failure (``encode``'s too) ``path`` is as it was, no
    temporary file stays, and the error is raised."""
    replace_all([(path, encode)])


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """``data`` written to ``path`` whole (``write_atomically``)."""
    write_atomically(path, lambda tmp: tmp.write_bytes(data))


def write_text(path: str | os.PathLike, text: str) -> None:
    """UTF-8 ``text`` written to ``path`` whole (``write_atomically``)."""
    write_atomically(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def replace_all(writes: list[tuple[str | os.PathLike, Callable[[Path], None]]]) -> None:
    """Write several files, all or nothing: ``writes`` is a list of (path, encode) as
    ``write_atomically`` takes them (their folders made). Every new file is encoded first;
    then the old files are moved aside and the new ones renamed in. On any failure every old
    file is back in place, no new file is, no temporary file stays, and the error is raised
    (``IsADirectoryError`` where a folder stands in a file's place)."""
    paths = [Path(w[0]) for w in writes]
    for path in paths:
        if path.is_dir():
            raise IsADirectoryError(errno.EISDIR, "a folder stands where the file goes", str(path))
    fresh = [temporary(p) for p in paths]
    aside = [p.with_name(f".{p.stem}.{os.getpid()}.old{p.suffix}") for p in paths]
    placed: list[int] = []
    try:
        for (path, encode), tmp in zip(writes, fresh, strict=True):
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            encode(tmp)
            if not tmp.is_file():
                raise OSError(f"{path}: nothing was written")
        for k, (path, tmp, old) in enumerate(zip(paths, fresh, aside, strict=True)):
            placed.append(k)
            if path.exists():
                os.replace(path, old)
            os.replace(tmp, path)
    except BaseException:
        for k in reversed(placed):
            try:
                if not fresh[k].exists():  # the new file went in: take it out
                    paths[k].unlink(missing_ok=True)
                if aside[k].exists():
                    os.replace(aside[k], paths[k])
            except OSError:
                continue  # put back what can be
        raise
    finally:
        for tmp in fresh:
            tmp.unlink(missing_ok=True)
    for old in aside:  # the new files are in: a left-over old file is only clutter
        try:
            old.unlink(missing_ok=True)
        except OSError:
            pass
