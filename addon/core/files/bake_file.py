"""Bake files: the multi-part OpenEXR files that probes (``probe_file``), lightmaps
(``lightmap_file``) and exports (``engine_export``) are stored in.

Every part is float32 RGB, ZIP compressed. The first part carries the metadata as a JSON string
attribute ``bo2.meta``, with a SHA-256 of the pixels (``content_digest``), so that a truncated
or damaged file is refused rather than read as zeros. Files are written whole, several at once
all or nothing (``atomic.replace_all``): a failed or cancelled bake leaves every previous file
as it was.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from . import exr

__all__ = ["BakeFileError", "content_digest", "read_parts", "write_parts"]


class BakeFileError(Exception):
    """A bake file that cannot be used (missing, corrupt, another format); one-line message."""


def write_parts(path: Path, meta: dict, images: list[tuple[str, np.ndarray]]) -> None:
    """A multi-part OpenEXR file of float32 RGB ``images`` ((name, (H, W, 3)) each) at
    ``path`` (as ``atomic.replace_all``'s encode: not atomic by itself), the first part
    carrying ``meta`` and a checksum of the pixels (``content_digest``) as the JSON attribute
    ``bo2.meta``."""
    text = json.dumps({**meta, "checksum": content_digest(images)})
    exr.encode(path, [exr.Part(name, {"RGB": img}, {"bo2.meta": text} if i == 0 else {})
                      for i, (name, img) in enumerate(images)])


def content_digest(images) -> str:
    """SHA-256 of (name, float32 pixels) pairs, in order."""
    h = hashlib.sha256()
    for name, img in images:
        h.update(name.encode())
        h.update(np.ascontiguousarray(img, np.float32).tobytes())
    return h.hexdigest()


def read_parts(path: Path, what: str) -> tuple[dict, list[tuple[str, np.ndarray]]]:
    """The ``bo2.meta`` of a bake file's first part and every part's (name, RGB pixels
    float32), in file order; BakeFileError "<file>: not a readable <what> file (<why>)"."""
    try:
        parts = exr.read(path)
        meta = json.loads(parts[0].header["bo2.meta"])
        images = [(p.name, p.channels["RGB"]) for p in parts]
    except (exr.ExrError, KeyError, IndexError, ValueError) as exc:
        why = str(exc).removeprefix(f"{Path(path).name}: ")
        raise BakeFileError(f"{Path(path).name}: not a readable {what} file ({why})") from None
    return meta, images
