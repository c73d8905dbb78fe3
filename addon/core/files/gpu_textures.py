"""Cube maps as GPUs and game engines store them: face orientation, DDS and KTX2 files.

Face orientation. GPUs pick a cube face and its texel coordinates (s, t) from a direction r by
the table of the OpenGL specification (4.6, section 8.13, table 8.19), which Direct3D and Vulkan
share; row 0 of a face's data is t = 0::

    face  major   sc     tc        s = (sc / |ma| + 1) / 2
    +X    +rx     -rz    -ry       t = (tc / |ma| + 1) / 2
    -X    -rx     +rz    -ry
    +Y    +ry     +rx    +rz
    -Y    -ry     +rx    -rz
    +Z    +rz     +rx    -ry
    -Z    -rz     -rx    -ry

in the engine's axes, Y up. Blender's axes (Z up) turn into them as the glTF exporter turns
them: (x, y, z) -> (x, z, -y) (``Y_UP``), so the faces carry the engine's +X, +Y (Blender's up)
and +Z (Blender's -Y). ``to_gpu_faces`` and ``from_gpu_faces`` move texels between this layout
and ``cubemap.FACES`` exactly (each texel centre of one is a texel centre of the other).

Files, both RGBA16F (IEEE half floats, alpha 1) with every mip, faces in the order +X, -X, +Y,
-Y, +Z, -Z:

- DDS (Microsoft, "Programming Guide for DDS"): the ``DDS_HEADER`` with ``DDSCAPS2_CUBEMAP``
  and all six face flags, ``DDSCAPS_MIPMAP`` and the mip count, and the ``DX10`` header
  (DXGI_FORMAT_R16G16B16A16_FLOAT, D3D10_RESOURCE_DIMENSION_TEXTURE2D,
  D3D11_RESOURCE_MISC_TEXTURECUBE); data face by face, each face's mips largest first.
- KTX2 (Khronos, "KTX File Format Specification" 2.0): VK_FORMAT_R16G16B16A16_SFLOAT, faceCount
  6, the level index, a Basic Data Format Descriptor (RGBSDA, BT.709 primaries, linear, four
  signed float 16-bit samples), key/value data (``KTXwriter`` and ``bo2.meta``, JSON; each
  entry padded to 8 bytes), and the levels smallest first, each holding its six faces, 8-byte
  aligned.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np

from ..formulas import cubemap
from ..system.atomic import write_atomically

__all__ = ["Y_UP", "from_gpu_faces", "gpu_face_directions", "to_gpu_faces", "write_dds",
           "write_ktx2"]

# Blender (Z up) -> engine (Y up) axes, as the glTF exporter turns them: (x, y, z) -> (x, z, -y)
Y_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
Y_UP.setflags(write=False)


def gpu_face_directions(size: int) -> np.ndarray:
    """(6, S, S, 3) float64 unit directions, engine axes (Y up), of the texel centres of the GPU
    faces (the OpenGL table in the module docstring, inverted)."""
    t = (2.0 * np.arange(size) + 1.0) / size - 1.0
    sc, tc = np.meshgrid(t, t)  # sc along the columns, tc along the rows
    one = np.ones_like(sc)
    faces = [(one, -tc, -sc), (-one, -tc, sc), (sc, one, tc), (sc, -one, -tc),
             (sc, -tc, one), (-sc, -tc, -one)]
    d = np.stack([np.stack(f, -1) for f in faces])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _gpu_index(size: int) -> np.ndarray:
    """(6 S^2,) flat indices into a ``cubemap.FACES`` cube of the GPU faces' texels."""
    d = gpu_face_directions(size).reshape(-1, 3) @ Y_UP  # engine -> Blender axes
    face, x, y = cubemap.direction_to_face(d, size)
    col = np.clip(np.floor(x), 0, size - 1).astype(np.int64)
    row = np.clip(np.floor(y), 0, size - 1).astype(np.int64)
    return (face * size + row) * size + col


def to_gpu_faces(cube: np.ndarray) -> np.ndarray:
    """(6, S, S, C) cube of ``cubemap.FACES`` (Blender axes) -> the same texels as GPU faces."""
    cube = np.asarray(cube)
    s, c = cube.shape[1], cube.shape[-1]
    return cube.reshape(-1, c)[_gpu_index(s)].reshape(6, s, s, c)


def from_gpu_faces(gpu: np.ndarray) -> np.ndarray:
    """The inverse of ``to_gpu_faces``."""
    gpu = np.asarray(gpu)
    s, c = gpu.shape[1], gpu.shape[-1]
    out = np.empty((6 * s * s, c), gpu.dtype)
    out[_gpu_index(s)] = gpu.reshape(-1, c)
    return out.reshape(6, s, s, c)


def _rgba16f(level: np.ndarray) -> np.ndarray:
    """(6, S, S, 3 or 4) -> (6, S, S, 4) float16, alpha 1, finite."""
    level = np.asarray(level, np.float32)
    out = np.ones(level.shape[:3] + (4,), np.float16)
    with np.errstate(over="ignore"):
        out[..., :3] = np.clip(np.nan_to_num(level[..., :3]), -65504.0, 65504.0)
    return out


def _check_chain(mips: list[np.ndarray]) -> None:
    size = mips[0].shape[1]
    for m, level in enumerate(mips):
        if level.shape[:3] != (6, size >> m, size >> m):
            raise ValueError(f"mip {m} has shape {level.shape}, expected (6, {size >> m}, "
                             f"{size >> m}, C)")


def write_dds(path: str | os.PathLike, mips: list[np.ndarray]) -> None:
    """A DDS cube map (RGBA16F, DX10 header) of the GPU-layout mip chain ``mips``
    ((6, S >> m, S >> m, C) each), replaced atomically."""
    _check_chain(mips)
    size = mips[0].shape[1]
    flags = 0x1 | 0x2 | 0x4 | 0x1000 | 0x8 | 0x20000  # caps height width pixfmt pitch mipcount
    pixel_format = struct.pack("<II4s5I", 32, 0x4, b"DX10", 0, 0, 0, 0, 0)
    caps = 0x1000 | 0x8 | 0x400000  # texture, complex, mipmap
    caps2 = 0x200 | 0xFC00  # cubemap and its six faces
    header = struct.pack("<7I44s32s4I4x", 124, flags, size, size, size * 8, 0, len(mips),
                         bytes(44), pixel_format, caps, caps2, 0, 0)
    dx10 = struct.pack("<5I", 10, 3, 0x4, 1, 0)  # R16G16B16A16_FLOAT, TEXTURE2D, cube, 1
    levels = [_rgba16f(level) for level in mips]
    data = [levels[m][f].tobytes() for f in range(6) for m in range(len(levels))]
    write_atomically(path, lambda tmp: _write_chunks(tmp, [b"DDS ", header, dx10, *data]))


_KTX2_ID = b"\xabKTX 20\xbb\r\n\x1a\n"
_VK_R16G16B16A16_SFLOAT = 97


def _dfd_rgba16f() -> bytes:
    """The Basic Data Format Descriptor of RGBA16F, with its total size in front."""
    block = struct.pack("<IIBBBB4B8B", 0, 2 | (24 + 16 * 4) << 16,
                        1, 1, 1, 0,  # RGBSDA, BT.709, linear, straight alpha
                        0, 0, 0, 0,  # a 1 x 1 x 1 x 1 texel block
                        8, 0, 0, 0, 0, 0, 0, 0)  # 8 bytes in plane 0
    for k, channel in enumerate((0, 1, 2, 15)):  # R, G, B, A
        kind = channel | 0x40 | 0x80  # signed float
        block += struct.pack("<I4BII", (16 * k) | (15 << 16) | (kind << 24), 0, 0, 0, 0,
                             0xBF800000, 0x3F800000)  # -1.0f .. 1.0f
    return struct.pack("<I", 4 + len(block)) + block


def _kv(key: str, text: str) -> bytes:
    """A key/value entry of a NUL-terminated UTF-8 ``text``, its length a multiple of 8
    (``text`` padded with spaces), so that no padding follows it whatever a reader's
    alignment (pyktx2 0.3.1 aligns to 8 where the specification says 4)."""
    entry = key.encode() + b"\0" + text.encode()
    entry += b" " * (-(4 + len(entry) + 1) % 8) + b"\0"
    return struct.pack("<I", len(entry)) + entry


def write_ktx2(path: str | os.PathLike, mips: list[np.ndarray], meta: dict | None = None,
               writer: str = "BO2 Lighting") -> None:
    """A KTX2 cube map (RGBA16F) of the GPU-layout mip chain ``mips``, with ``meta`` as JSON
    under the key ``bo2.meta``; replaced atomically."""
    _check_chain(mips)
    size, count = mips[0].shape[1], len(mips)
    dfd = _dfd_rgba16f()
    kvd = _kv("KTXwriter", writer)
    if meta is not None:
        kvd += _kv("bo2.meta", json.dumps(meta, sort_keys=True))
    head = 12 + 4 * 9 + 4 * 4 + 8 * 2
    index_end = head + 24 * count
    dfd_offset = index_end
    kvd_offset = dfd_offset + len(dfd)
    offset = kvd_offset + len(kvd)
    levels = [_rgba16f(level).tobytes() for level in mips]
    placed = {}
    chunks = []
    for m in reversed(range(count)):  # the smallest level first
        pad = -offset % 8
        chunks.append(bytes(pad))
        offset += pad
        placed[m] = (offset, len(levels[m]))
        chunks.append(levels[m])
        offset += len(levels[m])
    header = _KTX2_ID + struct.pack("<9I", _VK_R16G16B16A16_SFLOAT, 2, size, size, 0, 0, 6,
                                    count, 0)
    header += struct.pack("<4I2Q", dfd_offset, len(dfd), kvd_offset, len(kvd), 0, 0)
    index = b"".join(struct.pack("<3Q", placed[m][0], placed[m][1], placed[m][1])
                     for m in range(count))
    write_atomically(path, lambda tmp: _write_chunks(tmp, [header, index, dfd, kvd, *chunks]))


def _write_chunks(path: Path, chunks: list[bytes]) -> None:
    with open(path, "wb") as f:
        for chunk in chunks:
            f.write(chunk)
