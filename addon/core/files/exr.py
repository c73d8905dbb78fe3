"""OpenEXR files, read and written in one place (the ``OpenEXR`` package).

``read`` gives every part of a file (its name, header and channels as float32 arrays), the
library's own output silenced, and one ``ExrError`` with a one-line reason for any file it
cannot decode. ``write`` writes float32 parts (ZIP compressed) whole (``atomic``).
"""

from __future__ import annotations

import contextlib
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..system.atomic import write_atomically

__all__ = ["ExrError", "Part", "read", "rgb", "write"]


class ExrError(Exception):
    """An OpenEXR file that cannot be decoded; one-line message naming the file."""


@dataclass
class Part:
    """One part of an OpenEXR file.

    name:     the part's name ("" for a single-part file without one)
    channels: {channel name: (H, W) float32, or (H, W, C) for packed channels such as "RGB"}
    header:   extra header attributes (strings, numbers)
    """

    name: str
    channels: dict[str, np.ndarray]
    header: dict = field(default_factory=dict)


@contextlib.contextmanager
def _library_silenced():
    """File descriptors 1 and 2 sent to the null device: OpenEXR prints its own warnings about
    a damaged file there, which ``read`` turns into one message of its own."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def read(path: str | os.PathLike, separate: bool = False) -> list[Part]:
    """Every part of the OpenEXR file at ``path``, in file order; ``separate``: one channel per
    entry ("R", "G", "B", or "<layer>.<pass>.R" in a multilayer file) rather than RGB(A)
    packed into one. Raises ``ExrError`` "<file>: <why>"."""
    import OpenEXR

    path = Path(path)
    try:
        with _library_silenced():
            with OpenEXR.File(str(path), separate_channels=separate) as file:
                parts = [Part(p.name() or "", {k: np.asarray(c.pixels, np.float32)
                                               for k, c in p.channels.items()}, dict(p.header))
                         for p in file.parts]
    except Exception as exc:  # noqa: BLE001 - any decoding failure is one message
        why = str(exc).replace(f"'{path}' ", "").replace(str(path), "the file")
        raise ExrError(f"{path.name}: {why}") from None
    return parts


def rgb(path: str | os.PathLike) -> np.ndarray:
    """(H, W, 3) float32 colour of the first part of an OpenEXR file, row 0 at the top: its
    RGB or RGBA channels (packed or not), or its Y channel as grey. Raises ``ExrError``."""
    channels = read(path)[0].channels
    for name in ("RGB", "RGBA"):
        if name in channels:
            return np.ascontiguousarray(channels[name][..., :3])
    if all(c in channels for c in "RGB"):
        return np.stack([channels[c] for c in "RGB"], -1)
    if "Y" in channels:
        return np.repeat(channels["Y"][..., None], 3, -1)
    raise ExrError(f"{Path(path).name}: no R, G, B (or Y) channels "
                   f"(has {', '.join(sorted(channels)) or 'none'})")


def write(path: str | os.PathLike, parts: list[Part]) -> None:
    """Write ``parts`` (float32, ZIP compressed) to ``path`` whole (``atomic``); the parts
    share one display window, the largest part's."""
    write_atomically(path, lambda tmp: encode(tmp, parts))


def encode(path: Path, parts: list[Part]) -> None:
    """``write`` without the atomic replacement (for ``atomic.replace_all``)."""
    import OpenEXR

    sizes = [next(iter(p.channels.values())).shape[:2] for p in parts]
    height, width = max(s[0] for s in sizes), max(s[1] for s in sizes)
    window = (np.array([0, 0], np.int32), np.array([width - 1, height - 1], np.int32))
    encoded = []
    for p in parts:
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "displayWindow": window, **p.header}
        channels = {k: np.ascontiguousarray(v, np.float32) for k, v in p.channels.items()}
        encoded.append(OpenEXR.Part(header, channels, p.name) if len(parts) > 1 or p.name
                       else (header, channels))
    if len(encoded) == 1 and isinstance(encoded[0], tuple):
        OpenEXR.File(*encoded[0]).write(str(path))
    else:
        OpenEXR.File(encoded).write(str(path))
