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
truncated or damaged file is refused rather than read as zeros.

Writes are all or nothing (``write_all``): every new file is written to a temporary file beside
its place first, then the old files are moved aside and the new ones renamed in (``os.replace``);
if any step fails, what was moved is moved back. A failed or cancelled bake leaves every previous
file as it was.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import sys
from pathlib import Path

import numpy as np

__all__ = ["FORMAT", "ProbeFileError", "read", "read_parts", "replace_all", "size_bound", "write",
           "write_all", "write_parts"]

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
    """Write one probe atomically (``write_all`` of one).

    meta: JSON-serializable metadata (``FORMAT`` is added)
    sh:   (K, 9, 3) radiance SH of the K capture points
    mips: {"bo2": [...], "bo1": [...]} lists of (6, S_m, S_m, 3) cube maps, or None
    """
    write_all([(path, meta, sh, mips)])


def write_all(files: list[tuple]) -> None:
    """Write several probes, all or nothing: ``files`` is a list of (path, meta, sh, mips) as
    ``write`` takes them (``replace_all``)."""
    replace_all([(f[0], lambda tmp, f=f: _encode(tmp, *f[1:])) for f in files])


def replace_all(writes: list[tuple]) -> None:
    """Write several files, all or nothing: ``writes`` is a list of (path, encode), encode
    writing the file's bytes to the temporary path it is given. On any failure every old file
    is back in place, no new file is, no temporary file stays, and the error is raised."""
    paths = [Path(w[0]) for w in writes]
    for path in paths:
        if path.is_dir():
            raise ProbeFileError(f"{path}: a folder stands where the file goes")
    pid = os.getpid()
    temporary = [p.with_name(f".{p.name}.{pid}.tmp") for p in paths]
    aside = [p.with_name(f".{p.name}.{pid}.old") for p in paths]
    placed: list[int] = []
    try:
        for (path, encode), tmp in zip(writes, temporary, strict=True):
            Path(path).parent.mkdir(parents=True, exist_ok=True)
            encode(tmp)
        for k, (path, tmp, old) in enumerate(zip(paths, temporary, aside, strict=True)):
            placed.append(k)
            if path.exists():
                os.replace(path, old)
            os.replace(tmp, path)
    except BaseException:
        for k in reversed(placed):
            try:
                if not temporary[k].exists():  # the new file went in: take it out
                    paths[k].unlink(missing_ok=True)
                if aside[k].exists():
                    os.replace(aside[k], paths[k])
            except OSError:
                continue  # put back what can be
        raise
    finally:
        for tmp in temporary:
            tmp.unlink(missing_ok=True)
    for old in aside:  # the bake is in: a left-over old file is only clutter
        try:
            old.unlink(missing_ok=True)
        except OSError:
            pass


def _encode(path: Path, meta: dict, sh: np.ndarray, mips) -> None:
    """One probe's OpenEXR file at ``path`` (``write``'s arguments)."""
    sh = np.asarray(sh, np.float32).reshape(-1, 9, 3)
    images = [("sh", sh)]
    for chain, levels in (mips or {}).items():
        for m, cube in enumerate(levels):
            cube = np.asarray(cube, np.float32)
            images.append((f"{chain}.mip{m}", cube.reshape(-1, cube.shape[2], 3)))
    write_parts(path, {**meta, "format": FORMAT}, images)


def write_parts(path: Path, meta: dict, images: list[tuple[str, np.ndarray]]) -> None:
    """A multi-part OpenEXR file of float32 RGB ``images`` ((name, (H, W, 3)) each, ZIP
    compressed), the first part carrying ``meta`` and a checksum of the pixels (``content_digest``)
    as the JSON attribute ``bo2.meta``."""
    import OpenEXR

    width = max(img.shape[1] for _, img in images)
    height = max(img.shape[0] for _, img in images)
    window = (np.array([0, 0], np.int32), np.array([width - 1, height - 1], np.int32))
    text = json.dumps({**meta, "checksum": content_digest(images)})
    parts = [_part(name, img, {"bo2.meta": text} if i == 0 else {}, window)
             for i, (name, img) in enumerate(images)]
    OpenEXR.File(parts).write(str(path))


def size_bound(points: int, face_size: int | None) -> int:
    """An upper bound of a probe file's bytes: ``points`` SH rows and, with ``face_size``, both
    prefiltered chains of that cube, uncompressed."""
    texels = 0 if face_size is None else 2 * sum(6 * (face_size >> m) ** 2
                                                 for m in range(face_size.bit_length()))
    return 12 * (points * 9 + texels) + 65536


def content_digest(images) -> str:
    h = hashlib.sha256()
    for name, img in images:
        h.update(name.encode())
        h.update(np.ascontiguousarray(img, np.float32).tobytes())
    return h.hexdigest()


@contextlib.contextmanager
def _library_silenced():
    """File descriptors 1 and 2 sent to the null device: OpenEXR prints its own warnings about
    a damaged file there, which a reader turns into one message of its own."""
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


def read_parts(path: Path, what: str) -> tuple[dict, list[tuple[str, np.ndarray]]]:
    """The ``bo2.meta`` of a bake file's first part and every part's (name, RGB pixels
    float32), in file order; ProbeFileError "<file>: not a readable <what> file (<why>)",
    the file named once, the library's own output silenced."""
    import OpenEXR

    try:
        with _library_silenced():
            parts = OpenEXR.File(str(path)).parts
            meta = json.loads(parts[0].header["bo2.meta"])
            images = [(p.name(), np.asarray(p.channels["RGB"].pixels, np.float32))
                      for p in parts]
    except Exception as exc:  # noqa: BLE001 - any decoding failure is "corrupt"
        why = str(exc).replace(f"'{path}' ", "").replace(str(path), "the file")
        raise ProbeFileError(f"{path.name}: not a readable {what} file ({why})") from None
    return meta, images


def read(path: str | os.PathLike) -> tuple[dict, np.ndarray, dict[str, list[np.ndarray]]]:
    """Read a probe written by ``write``.

    returns: (meta, sh (K, 9, 3) float32, {chain: [(6, S_m, S_m, 3) float32, ...]})
    raises:  ProbeFileError with a one-line reason
    """
    path = Path(path)
    if not path.is_file():
        raise ProbeFileError(f"{path.name}: no baked file (bake the probes)")
    meta, parts = read_parts(path, "probe")
    images = dict(parts)
    if meta.get("format") != FORMAT:
        raise ProbeFileError(f"{path.name}: probe file format {meta.get('format')!r}, "
                             f"expected {FORMAT} (re-bake)")
    order = ["sh"] + [n for n, _ in parts if n != "sh"]
    if meta.get("checksum") != content_digest([(n, images[n]) for n in order if n in images]):
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
