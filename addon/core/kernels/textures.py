"""Texture preparation kernels: an image's copy with sRGB decoded by table, and one
box-filtered mip level.

References (the NumPy these kernels are held to): ``texture.srgb_to_linear`` (IEC 61966-2-1)
and ``texture._halve_axis`` (area-weighted box filter, Williams 1983).
"""

from __future__ import annotations

import numba as nb
import numpy as np

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}


@nb.njit(nb.float32(nb.float32), **_OPTIONS)
def _srgb_formula(v):
    if v <= np.float32(0.04045):
        return v / np.float32(12.92)
    return ((v + np.float32(0.055)) / np.float32(1.055)) ** np.float32(2.4)


@nb.njit(nb.void(nb.float32[:, :, :], nb.int64, nb.float32[::1], nb.float32[:, :, ::1]),
         **_OPTIONS)
def prepare(image, decode, lut, out):
    """Copy ``image`` (H, W, C) to ``out`` with NaN and infinities as 0, decoding the first
    ``decode`` channels from sRGB: an 8-bit code k / 255 (within 1e-6) through ``lut`` (256,),
    its linear value, any other value by the formula of ``texture.srgb_to_linear``."""
    h, w, nc = image.shape
    for y in range(h):
        for x in range(w):
            for c in range(nc):
                v = image[y, x, c]
                if not np.isfinite(v):
                    v = np.float32(0.0)
                elif c < decode:
                    if np.float32(0.0) <= v <= np.float32(1.0):
                        i = np.int64(v * np.float32(255.0) + np.float32(0.5))
                        if abs(np.float32(i) * np.float32(1.0 / 255.0) - v) <= 1e-6:
                            v = lut[i]
                        else:
                            v = _srgb_formula(v)
                    else:
                        v = _srgb_formula(v)
                out[y, x, c] = v


@nb.njit(nb.void(nb.float32[:, :, ::1], nb.float32[:, :, ::1]), **_OPTIONS)
def halve(src, out):
    """One mip level: ``src`` (h, w, C) box-filtered to ``out`` (max(1, h // 2),
    max(1, w // 2), C), rows first then columns, with the weights and float32 rounding of
    ``texture._halve_axis`` (pairs for even sizes; (m - i)/n, m/n, (i + 1)/n for odd n)."""
    h, w, nc = src.shape
    h2, w2 = out.shape[0], out.shape[1]
    rows = np.empty((h2, w, nc), np.float32)
    if h == 1:
        rows[:] = src
    elif h % 2 == 0:
        for i in range(h2):
            for x in range(w):
                for c in range(nc):
                    rows[i, x, c] = np.float32(0.5) * (src[2 * i, x, c] + src[2 * i + 1, x, c])
    else:
        m = (h - 1) // 2
        wm = np.float32(m / h)
        for i in range(h2):
            w0 = (np.float32(m) - np.float32(i)) / np.float32(h)
            w2_ = (np.float32(i) + np.float32(1.0)) / np.float32(h)
            for x in range(w):
                for c in range(nc):
                    rows[i, x, c] = (w0 * src[2 * i, x, c] + wm * src[2 * i + 1, x, c]) \
                        + w2_ * src[2 * i + 2, x, c]
    if w == 1:
        out[:] = rows
    elif w % 2 == 0:
        for i in range(h2):
            for x in range(w2):
                for c in range(nc):
                    out[i, x, c] = np.float32(0.5) * (rows[i, 2 * x, c] + rows[i, 2 * x + 1, c])
    else:
        m = (w - 1) // 2
        wm = np.float32(m / w)
        for x in range(w2):
            w0 = (np.float32(m) - np.float32(x)) / np.float32(w)
            w2_ = (np.float32(x) + np.float32(1.0)) / np.float32(w)
            for i in range(h2):
                for c in range(nc):
                    out[i, x, c] = (w0 * rows[i, 2 * x, c] + wm * rows[i, 2 * x + 1, c]) \
                        + w2_ * rows[i, 2 * x + 2, c]
