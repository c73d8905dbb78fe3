"""Image textures on the GPU (``glsl/texture.glsl``): a ``core.formulas.texture.Texture``'s
mip chain as rows of a texture (one texel per pixel; 8-bit images keep their codes) and its
``ImageData`` record (declared once here)."""

from __future__ import annotations

import threading

import numpy as np

from ..core.formulas import texture as core_texture
from . import textures
from .uniforms import Struct

MAX_LEVELS = 16  # a 32768-pixel image has 16 levels
ROW_WIDTH = 4096  # texels per row of an image's texture
MAX_TEXELS = ROW_WIDTH * 16384  # of one texture: 16384 rows (the 8-bit images, the others)
IMAGE = Struct("ImageData", (
    ("levels", "ivec4", MAX_LEVELS),  # per level: (first texel, height, width, -)
    ("info", "ivec4", 0),  # (levels, channels, extension, filter): kernels.textures' codes
    ("info2", "ivec4", 0),  # (sRGB channels, 8-bit codes, texels per row, -)
))


def srgb_table():
    """The 256 linear values of the 8-bit sRGB codes (texture._SRGB_LUT), a 256 x 1 texture."""
    lut = core_texture.srgb_to_linear(np.arange(256, dtype=np.float32) / np.float32(255.0))
    return textures.image(np.asarray(lut, np.float32).reshape(1, 256, 1))


def upload(tex) -> tuple[dict, object]:
    """(the ImageData record, the GPU texture of its texels) of texture ``tex``, its mip chain
    filled first."""
    records, by_codes = pack([tex])
    return records[0], by_codes[records[0]["info2"][1]]


def pack(texs: list) -> tuple[list[dict], tuple]:
    """Textures ``texs`` in two GPU textures, one of the 8-bit images (RGBA8, their codes)
    and one of the others (RGBA32F): (their ImageData records, in order, and the two textures
    (float, 8-bit), a one-texel one where there is none of a kind). The upload of the last
    ``KEPT_UPLOADS`` sets of texel arrays is kept: a frame made again after a material tweak
    reuses it."""
    from ..core.kernels import textures as texture_kernel

    records, flats, used = [], [], [0, 0]
    for tex in texs:
        if tex.pending:
            tex.fill_mips()
        flat, rows = tex.packed
        c = tex.channels
        if len(rows) > MAX_LEVELS:
            raise ValueError(f"an image of more than {MAX_LEVELS} mip levels")
        codes = int(flat.dtype == np.uint8)
        levels = np.zeros((len(rows), 4), np.int64)
        levels[:, 0] = rows[:, 0] // c + used[codes]
        levels[:, 1:3] = rows[:, 1:3]
        records.append({"levels": levels,
                        "info": [len(rows), c,
                                 texture_kernel.EXTENSIONS.get(tex.extension,
                                                               texture_kernel.EXTEND),
                                 texture_kernel.FILTERS.get(tex.interpolation,
                                                            texture_kernel.LINEAR)],
                        "info2": [tex.encoded, codes, ROW_WIDTH, 0]})
        flats.append((flat, c, codes))
        used[codes] += len(flat) // c
    key = tuple((id(flat), c) for flat, c, _ in flats)
    with _lock:
        kept = _uploads.pop(key, None)
    if kept is None:
        kept = (flats, _upload(texs, flats, used))
    with _lock:
        _uploads[key] = kept  # the most recently used last
        while len(_uploads) > KEPT_UPLOADS:
            del _uploads[next(iter(_uploads))]
    textures_ = kept[1]
    if len(texs) == 1:  # one image: its own row width
        records[0]["info2"][2] = textures_[records[0]["info2"][1]].width
    return records, textures_


KEPT_UPLOADS = 4
# (texel arrays' ids and channels) -> (those arrays, kept alive so the ids stay theirs; the two
# GPU textures)
_uploads: dict[tuple, tuple] = {}
_lock = threading.Lock()


def release() -> None:
    """Let go of the kept uploads (``pack``)."""
    with _lock:
        _uploads.clear()


def _upload(texs: list, flats: list, used: list[int]) -> tuple:
    import gpu

    parts = ([], [])
    for flat, c, codes in flats:
        data = np.zeros((len(flat) // c, 4), np.float32)
        data[:, :c] = flat.reshape(-1, c).astype(np.float32) / (255.0 if codes else 1.0)
        parts[codes].append(data)
    textures_ = []
    for codes, chunks in enumerate(parts):
        count = max(1, used[codes])
        width = min(count, ROW_WIDTH) if len(texs) == 1 else ROW_WIDTH
        height = -(-count // width)
        if height * width > MAX_TEXELS:
            names = ", ".join(repr(t.name) for t in texs)
            raise MemoryError(f"the images {names} are too large for one GPU texture")
        data = np.zeros((height * width, 4), np.float32)
        if chunks:
            data[:used[codes]] = np.concatenate(chunks)
        buffer = gpu.types.Buffer("FLOAT", data.size, data.reshape(-1))
        textures_.append(gpu.types.GPUTexture((width, height),
                                              format="RGBA8" if codes else "RGBA32F",
                                              data=buffer))
    return tuple(textures_)
