"""A small Radiance RGBE (.hdr) reader for tests, independent of Blender.

Format: G. Ward, "Real Pixels", Graphics Gems II (1991), and the Radiance file format notes
(``picture_format``): a text header ending with an empty line, a resolution line
``-Y H +X W`` (rows top to bottom, columns left to right), then H scanlines of W pixels of
four bytes (R, G, B mantissas and a shared exponent E). Scanlines are either flat or "new-style"
run-length encoded: the bytes 2, 2, W >> 8, W & 255, then each of the four components of the
scanline in turn as packets, a count byte n > 128 followed by one byte repeated n - 128 times,
or n <= 128 followed by n literal bytes. Old-style RLE is not supported (it raises).

Decoding as Blender does through OpenImageIO (Walter's ``rgbe.c``): channel = m * 2^(E - 136),
and 0 where E = 0. Radiance's own ``colr_color`` adds half a unit, (m + 0.5) * 2^(E - 136);
Blender does not, and neither does this reader (tests/cli checks ``bo2 sh`` against it).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

_RESOLUTION = re.compile(rb"-Y (\d+) \+X (\d+)")


def _rle_source_indices(data: bytes, start: int, height: int, width: int) -> np.ndarray:
    """Index into ``data`` of every decoded byte, in (row, component, column) order.

    Packets are parsed serially (each count decides where the next packet starts); the gather
    of the bytes themselves is vectorised.
    """
    src, count, literal = [], [], []
    p = start
    head = bytes((2, 2, width >> 8, width & 255))
    for _ in range(height):
        if data[p:p + 4] != head:
            raise ValueError("not a new-style run-length encoded scanline")
        p += 4
        for _component in range(4):
            x = 0
            while x < width:
                n = data[p]
                if n > 128:
                    n -= 128
                    src.append(p + 1)
                    literal.append(0)
                    p += 2
                else:
                    if n == 0:
                        raise ValueError("zero-length packet")
                    src.append(p + 1)
                    literal.append(1)
                    p += 1 + n
                count.append(n)
                x += n
            if x != width:
                raise ValueError("a packet overruns the scanline")
    count = np.asarray(count, np.int64)
    first = np.cumsum(count) - count  # output offset of each packet's first byte
    within = np.arange(int(count.sum()), dtype=np.int64) - np.repeat(first, count)
    return np.repeat(np.asarray(src, np.int64), count) + within * np.repeat(
        np.asarray(literal, np.int64), count)


def read_rgbe(path) -> np.ndarray:
    """Read a Radiance .hdr file.

    path:    file path
    returns: (H, W, 3) float32 linear RGB, row 0 at the TOP (the file's first scanline)
    """
    data = Path(path).read_bytes()
    if not data.startswith((b"#?RADIANCE", b"#?RGBE")):
        raise ValueError(f"{path}: not a Radiance file")
    end = data.find(b"\n\n")
    if end < 0 or b"FORMAT=32-bit_rle_rgbe" not in data[:end]:
        raise ValueError(f"{path}: missing header or not 32-bit_rle_rgbe")
    line_end = data.index(b"\n", end + 2)
    m = _RESOLUTION.fullmatch(data[end + 2:line_end].strip())
    if not m:
        raise ValueError(f"{path}: unsupported resolution line (only -Y H +X W)")
    height, width = int(m[1]), int(m[2])
    start = line_end + 1
    raw = np.frombuffer(data, np.uint8)
    if 8 <= width < 32768 and data[start:start + 2] == b"\x02\x02":
        rgbe = raw[_rle_source_indices(data, start, height, width)]
        rgbe = rgbe.reshape(height, 4, width).transpose(0, 2, 1)
    else:
        rgbe = raw[start:start + height * width * 4].reshape(height, width, 4)
    exponent = rgbe[..., 3].astype(np.int32)
    scale = np.where(exponent > 0, np.ldexp(np.float32(1.0), exponent - 136), 0.0)
    return (rgbe[..., :3] * scale[..., None].astype(np.float32)).astype(np.float32)
