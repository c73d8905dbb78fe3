"""Baked probes on disk: one multi-part OpenEXR file per probe, written atomically.

Parts (all float32 RGB, ZIP compressed):

- ``sh``: the radiance SH, width 9, one row per capture point (1 for a reflection probe,
  X*Y*Z for an irradiance volume, samples in C order of (x, y, z));
- ``bo2.mip<m>`` and ``bo1.mip<m>``: the prefiltered cube map chains (cosine power and angular
  Gaussian), the six faces of mip m stacked top to bottom in ``cubemap`` face order, each
  S >> m pixels square.

The first part carries the metadata as a JSON string attribute ``bo2.meta``: probe name and
kind, position or matrix, face size, filters, bake time, add-on version and what the shading
needs (radius, falloff, resolution, influence), and a SHA-256 of the pixels, so that a
truncated or damaged file is refused rather than read as zeros. A write goes to a temporary
file in the same folder which is then renamed over the old one (``os.replace``), so a failed or
cancelled bake leaves the previous file as it was.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

__all__ = ["FORMAT", "ProbeFileError", "read", "write"]

FORMAT = 1
"""Layout version stored in the metadata; files of another version are refused."""


class ProbeFileError(Exception):
    """A probe file that cannot be used (missing, corrupt, another format); one-line message."""


def _part(name: str, rgb: np.ndarray, header: dict, window) -> object:
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "displayWindow": window, **header}
    return OpenEXR.Part(header, {"RGB": np.ascontiguousarray(rgb, np.float32)}, name)


def write(path: str | os.PathLike, meta: dict, sh: np.ndarray,
          mips: dict[str, list[np.ndarray]] | None = None) -> None:
    """Write one probe atomically.

    meta: JSON-serializable metadata (``FORMAT`` is added)
    sh:   (K, 9, 3) radiance SH of the K capture points
    mips: {"bo2": [...], "bo1": [...]} lists of (6, S_m, S_m, 3) cube maps, or None
    """
    import OpenEXR

    path = Path(path)
    sh = np.asarray(sh, np.float32).reshape(-1, 9, 3)
    images = [("sh", sh)]
    for chain, levels in (mips or {}).items():
        for m, cube in enumerate(levels):
            cube = np.asarray(cube, np.float32)
            images.append((f"{chain}.mip{m}", cube.reshape(-1, cube.shape[2], 3)))
    width = max(img.shape[1] for _, img in images)
    height = max(img.shape[0] for _, img in images)
    window = (np.array([0, 0], np.int32), np.array([width - 1, height - 1], np.int32))
    text = json.dumps({**meta, "format": FORMAT, "checksum": _digest(images)})
    parts = [_part(name, img, {"bo2.meta": text} if i == 0 else {}, window)
             for i, (name, img) in enumerate(images)]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        OpenEXR.File(parts).write(str(tmp))
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _digest(images) -> str:
    h = hashlib.sha256()
    for name, img in images:
        h.update(name.encode())
        h.update(np.ascontiguousarray(img, np.float32).tobytes())
    return h.hexdigest()


def read(path: str | os.PathLike) -> tuple[dict, np.ndarray, dict[str, list[np.ndarray]]]:
    """Read a probe written by ``write``.

    returns: (meta, sh (K, 9, 3) float32, {chain: [(6, S_m, S_m, 3) float32, ...]})
    raises:  ProbeFileError with a one-line reason
    """
    import OpenEXR

    path = Path(path)
    if not path.is_file():
        raise ProbeFileError(f"{path.name}: no baked file (bake the probes)")
    try:
        parts = OpenEXR.File(str(path)).parts
        meta = json.loads(parts[0].header["bo2.meta"])
        images = {p.name(): np.asarray(p.channels["RGB"].pixels, np.float32) for p in parts}
    except Exception as exc:  # noqa: BLE001 - any decoding failure is "corrupt"
        raise ProbeFileError(f"{path.name}: not a readable probe file ({exc})") from None
    if meta.get("format") != FORMAT:
        raise ProbeFileError(f"{path.name}: probe file format {meta.get('format')!r}, "
                             f"expected {FORMAT} (re-bake)")
    order = ["sh"] + [n for n in (p.name() for p in parts) if n != "sh"]
    if meta.get("checksum") != _digest([(n, images[n]) for n in order if n in images]):
        raise ProbeFileError(f"{path.name}: damaged file (its pixels do not match their "
                             "checksum; re-bake)")
    if "sh" not in images or images["sh"].shape[1:] != (9, 3):
        raise ProbeFileError(f"{path.name}: no SH coefficients")
    bad = [n for n in order if n in images and not np.isfinite(images[n]).all()]
    if bad:  # light is finite: such a file was written wrong, whatever its checksum says
        raise ProbeFileError(f"{path.name}: part {bad[0]} holds NaN or infinite values "
                             "(re-bake)")
    mips: dict[str, list[np.ndarray]] = {}
    for name in sorted(images, key=lambda n: (n.split(".mip")[0], int(n.split(".mip")[-1])
                                              if ".mip" in n else -1)):
        if ".mip" not in name:
            continue
        chain = name.split(".mip")[0]
        img = images[name]
        size = img.shape[1]
        if img.shape != (6 * size, size, 3):
            raise ProbeFileError(f"{path.name}: part {name} is not six square faces")
        mips.setdefault(chain, []).append(img.reshape(6, size, size, 3))
    return meta, images["sh"], mips
