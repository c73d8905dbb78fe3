"""NumPy arrays to GPU textures and back (float32 data given at creation: Python textures
have one mip level and no partial update)."""

from __future__ import annotations

import numpy as np

ROW_WIDTH = 1024  # texels per row of a texture holding a list (``rows``)
_FORMATS = {1: "R32F", 2: "RG32F", 4: "RGBA32F"}


def _buffer(array: np.ndarray):
    import gpu

    flat = np.ascontiguousarray(array, np.float32).reshape(-1)
    return gpu.types.Buffer("FLOAT", len(flat), flat)


def image(array: np.ndarray):
    """(H, W, C) float32, C of 1, 2 or 4, row 0 first -> a 2D texture (C channels)."""
    import gpu

    h, w, c = array.shape
    return gpu.types.GPUTexture((w, h), format=_FORMATS[c], data=_buffer(array))


def layers(array: np.ndarray):
    """(L, H, W) float32 -> a one-channel 2D-array texture of L layers."""
    import gpu

    n, h, w = array.shape
    return gpu.types.GPUTexture((w, h), layers=n, format="R32F", data=_buffer(array))


def rows(array: np.ndarray, width: int = ROW_WIDTH):
    """A list (N, C<=4) float32 -> an RGBA32F texture, item k at texel (k % width, k // width)
    (at least one texel)."""
    a = np.asarray(array, np.float32).reshape(len(array), -1)
    n = max(1, len(a))
    w = min(n, width)
    h = -(-n // w)
    out = np.zeros((h * w, 4), np.float32)
    out[:len(a), :a.shape[1]] = a
    return image(out.reshape(h, w, 4))


def read(texture, channels: int = 4) -> np.ndarray:
    """(H, W, channels) float32 of a float texture (row 0 first)."""
    data = np.asarray(texture.read(), np.float32)
    return data.reshape(texture.height, texture.width, -1)[..., :channels]


def read_rows(texture, count: int, channels: int = 4) -> np.ndarray:
    """The first ``count`` items (count, channels) of a ``rows`` texture."""
    return read(texture, 4).reshape(-1, 4)[:count, :channels]


def full_screen():
    """A batch of one triangle covering the viewport (``corner``: NDC x, y), for passes that
    shade every pixel (``background_vert.glsl``)."""
    import gpu

    fmt = gpu.types.GPUVertFormat()
    fmt.attr_add(id="corner", comp_type="F32", len=2, fetch_mode="FLOAT")
    corners = gpu.types.GPUVertBuf(fmt, 3)
    corners.attr_fill("corner", np.float32([[-1, -1], [3, -1], [-1, 3]]))
    return gpu.types.GPUBatch(type="TRIS", buf=corners)
