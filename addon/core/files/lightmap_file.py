"""Baked lightmaps on disk: one OpenEXR file per object, written all or nothing.

Parts (float32 RGB, ZIP compressed): ``lightmap`` (H, W) irradiance, or ``sh0`` .. ``sh3``
(H, W) the L1 SH of a directional lightmap (``lightmap.Lightmap``); ``uv`` the lightmap UVs
of the object's T triangles, (T, 2) pixels of RGB holding the six numbers of a triangle's
three corners. The first part carries the metadata as the JSON attribute ``bo2.meta``: the
object's name and identity, the UV map (its name, or "" for a layout made by the bake), the
density, the bake settings, the keys that tell a stale lightmap (``lightmap_bake.geometry_key``,
``lightmap_bake.light_key``) and a SHA-256 of the pixels. Writes go through
``atomic.replace_all``: a failed or cancelled bake leaves every previous file as it was.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..lighting.lightmap import Lightmap
from ..system.atomic import replace_all
from .bake_file import BakeFileError, content_digest, read_parts, write_parts

__all__ = ["FORMAT", "read", "write_all"]

FORMAT = 1


def _images(lightmap: Lightmap) -> list[tuple[str, np.ndarray]]:
    image = np.asarray(lightmap.image, np.float32)
    if image.shape[2] == 12:
        maps = [(f"sh{k}", image[..., 3 * k:3 * k + 3]) for k in range(4)]
    else:
        maps = [("lightmap", image)]
    uv = np.asarray(lightmap.uvs, np.float32).reshape(-1, 2, 3)
    return maps + [("uv", uv)]


def write_all(files: list[tuple[str | os.PathLike, dict, Lightmap]]) -> None:
    """Write lightmaps, all or nothing: (path, metadata, ``Lightmap``) each."""
    replace_all([(path, lambda tmp, m={**meta, "format": FORMAT}, lm=lm:
                  write_parts(tmp, m, _images(lm))) for path, meta, lm in files])


def read(path: str | os.PathLike) -> tuple[dict, Lightmap]:
    """Read a lightmap written by ``write_all``: (metadata, ``Lightmap``); raises
    ``bake_file.BakeFileError`` with a one-line reason."""
    path = Path(path)
    if not path.is_file():
        raise BakeFileError(f"{path.name}: no baked lightmap (bake the lightmaps)")
    meta, images = read_parts(path, "lightmap")
    if meta.get("format") != FORMAT:
        raise BakeFileError(f"{path.name}: lightmap format {meta.get('format')!r}, expected "
                             f"{FORMAT} (re-bake)")
    if meta.get("checksum") != content_digest(images):
        raise BakeFileError(f"{path.name}: damaged file (its pixels do not match their "
                             "checksum; re-bake)")
    named = dict(images)
    if not all(np.isfinite(img).all() for _, img in images):
        raise BakeFileError(f"{path.name}: NaN or infinite values (re-bake)")
    if "lightmap" in named:
        image = named["lightmap"]
    elif all(f"sh{k}" in named for k in range(4)):
        image = np.concatenate([named[f"sh{k}"] for k in range(4)], axis=2)
    else:
        raise BakeFileError(f"{path.name}: no lightmap part")
    if "uv" not in named:
        raise BakeFileError(f"{path.name}: no lightmap UVs")
    uvs = named["uv"].reshape(-1, 3, 2)
    return meta, Lightmap(np.ascontiguousarray(image), np.ascontiguousarray(uvs))
