"""Baked probes on disk: one multi-part OpenEXR file per probe, written atomically.

Parts (all float32 RGB, ZIP compressed):

- ``sh``: the radiance SH, width 9, one row per capture point (1 for a reflection probe,
  X*Y*Z for an irradiance volume, samples in C order of (x, y, z));
- ``bo2.mip<m>`` and ``bo1.mip<m>``: the prefiltered cube map chains (cosine power and angular
  Gaussian), the six faces of mip m stacked top to bottom in ``cubemap`` face order, each
  S >> m pixels square;
- ``depth`` (irradiance volumes): the samples' depth moments (``sample_visibility``), each
  sample's six M x M faces stacked top to bottom, samples in the SH's order, R the mean and G
  the mean square of the distance (metres, m^2), B 0. Files baked before it have none: their
  volumes are looked up without the visibility test.

A bake file (``bake_file``): the first part carries the metadata (``bo2.meta``): probe name and
kind, position or matrix, face size, filters, bake time, add-on version and what the shading
needs (radius, falloff, resolution, influence), and the pixels' checksum. Writes are all or
nothing (``write_all``): a failed or cancelled bake leaves every previous file as it was.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..lighting.sample_visibility import SIZE as MOMENT_SIZE
from ..system.atomic import replace_all
from .bake_file import BakeFileError, content_digest, read_parts, write_parts

__all__ = ["DEPTH", "FORMAT", "read", "size_bound", "write", "write_all"]

FORMAT = 1
"""Layout version stored in the metadata; files of another version are refused."""
DEPTH = "depth"
"""The name of a volume's depth moments part, and of their entry in ``read``'s dict."""


def write(path: str | os.PathLike, meta: dict, sh: np.ndarray,
          mips: dict[str, list[np.ndarray]] | None = None) -> None:
    """Write one probe atomically (``write_all`` of one).

    meta: JSON-serializable metadata (``FORMAT`` is added)
    sh:   (K, 9, 3) radiance SH of the K capture points
    mips: {"bo2": [...], "bo1": [...]} lists of (6, S_m, S_m, 3) cube maps, and for a
          volume {"depth": [(K, 6, M, M, 2) depth moments]}; or None
    """
    write_all([(path, meta, sh, mips)])


def write_all(files: list[tuple]) -> None:
    """Write several probes, all or nothing: ``files`` is a list of (path, meta, sh, mips) as
    ``write`` takes them (``replace_all``)."""
    replace_all([(f[0], lambda tmp, f=f: _encode(tmp, *f[1:])) for f in files])


def _encode(path: Path, meta: dict, sh: np.ndarray, mips) -> None:
    """One probe's OpenEXR file at ``path`` (``write``'s arguments)."""
    sh = np.asarray(sh, np.float32).reshape(-1, 9, 3)
    images = [("sh", sh)]
    for chain, levels in (mips or {}).items():
        if chain == DEPTH:
            m = np.asarray(levels[0], np.float32)
            size = m.shape[-2]
            rgb = np.concatenate([m, np.zeros((*m.shape[:-1], 1), np.float32)], axis=-1)
            images.append((DEPTH, rgb.reshape(-1, size, 3)))
            continue
        for m, cube in enumerate(levels):
            cube = np.asarray(cube, np.float32)
            images.append((f"{chain}.mip{m}", cube.reshape(-1, cube.shape[2], 3)))
    write_parts(path, {**meta, "format": FORMAT}, images)


def size_bound(points: int, face_size: int | None) -> int:
    """An upper bound of a probe file's bytes: ``points`` SH rows and, with ``face_size``, both
    prefiltered chains of that cube, uncompressed; without, the points' depth moments."""
    texels = points * 6 * MOMENT_SIZE ** 2 if face_size is None else 2 * sum(
        6 * (face_size >> m) ** 2 for m in range(face_size.bit_length()))
    return 12 * (points * 9 + texels) + 65536


def read(path: str | os.PathLike) -> tuple[dict, np.ndarray, dict[str, list[np.ndarray]]]:
    """Read a probe written by ``write``.

    returns: (meta, sh (K, 9, 3) float32, {chain: [(6, S_m, S_m, 3) float32, ...]} and, for a
             volume baked with them, {"depth": [(K, 6, M, M, 2) float32]})
    raises:  BakeFileError with a one-line reason
    """
    path = Path(path)
    if not path.is_file():
        raise BakeFileError(f"{path.name}: no baked file (bake the probes)")
    meta, parts = read_parts(path, "probe")
    images = dict(parts)
    if meta.get("format") != FORMAT:
        raise BakeFileError(f"{path.name}: probe file format {meta.get('format')!r}, "
                             f"expected {FORMAT} (re-bake)")
    order = ["sh"] + [n for n, _ in parts if n != "sh"]
    if meta.get("checksum") != content_digest([(n, images[n]) for n in order if n in images]):
        raise BakeFileError(f"{path.name}: damaged file (its pixels do not match their "
                             "checksum; re-bake)")
    if "sh" not in images or images["sh"].shape[1:] != (9, 3):
        raise BakeFileError(f"{path.name}: no SH coefficients")
    bad = [n for n in order if n in images and not np.isfinite(images[n]).all()]
    if bad:  # light is finite: such a file was written wrong, whatever its checksum says
        raise BakeFileError(f"{path.name}: part {bad[0]} holds NaN or infinite values "
                             "(re-bake)")
    mips: dict[str, list[np.ndarray]] = {}
    if DEPTH in images:
        img = images[DEPTH]
        size = img.shape[1]
        if img.shape != (len(images["sh"]) * 6 * size, size, 3):
            raise BakeFileError(f"{path.name}: part {DEPTH} is not six square faces per sample")
        mips[DEPTH] = [img.reshape(-1, 6, size, size, 3)[..., :2].copy()]
    for name in sorted(images, key=lambda n: (n.split(".mip")[0], int(n.split(".mip")[-1])
                                              if ".mip" in n else -1)):
        if ".mip" not in name:
            continue
        chain = name.split(".mip")[0]
        img = images[name]
        size = img.shape[1]
        if img.shape != (6 * size, size, 3):
            raise BakeFileError(f"{path.name}: part {name} is not six square faces")
        mips.setdefault(chain, []).append(img.reshape(6, size, size, 3))
    return meta, images["sh"], mips
