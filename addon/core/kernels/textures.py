"""Texture kernels: an image's copy with sRGB decoded by table, one box-filtered mip level
of a float or an 8-bit image, and filtered look-ups of either.

References (what tests/core/test_kernels_textures.py holds these kernels to):
``texture.srgb_to_linear`` and ``texture.linear_to_srgb`` (IEC 61966-2-1), the test's two-pass
area-weighted box filter (Williams 1983), and bilinear / trilinear look-ups written out texel by
texel with Cycles' wrap rules (``sample``, which gave bit for bit the results of the NumPy it
replaced).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from . import mark_cached

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


@nb.njit(inline="always", **_OPTIONS)
def _halve_first_axis(src, out):
    """``src`` (n, m, C) box-filtered along its first axis to ``out`` (max(1, n // 2), m, C):
    pairs for an even n; weights (k - i)/n, k/n, (i + 1)/n, k = (n - 1) // 2, for an odd n."""
    n, m, nc = src.shape
    if n == 1:  # (element loops: slice assignment is slow to compile)
        for x in range(m):
            for c in range(nc):
                out[0, x, c] = src[0, x, c]
    elif n % 2 == 0:
        for i in range(out.shape[0]):
            for x in range(m):
                for c in range(nc):
                    out[i, x, c] = np.float32(0.5) * (src[2 * i, x, c] + src[2 * i + 1, x, c])
    else:
        k = (n - 1) // 2
        wk = np.float32(k / n)
        for i in range(out.shape[0]):
            w0 = (np.float32(k) - np.float32(i)) / np.float32(n)
            w2 = (np.float32(i) + np.float32(1.0)) / np.float32(n)
            for x in range(m):
                for c in range(nc):
                    out[i, x, c] = (w0 * src[2 * i, x, c] + wk * src[2 * i + 1, x, c]) \
                        + w2 * src[2 * i + 2, x, c]


@nb.njit(nb.void(nb.float32[:, :, ::1], nb.float32[:, :, ::1]), **_OPTIONS)
def halve(src, out):
    """One mip level: ``src`` (h, w, C) box-filtered to ``out`` (max(1, h // 2),
    max(1, w // 2), C), rows first then columns, with the weights and float32 rounding of the
    test's reference (pairs for even sizes; (m - i)/n, m/n, (i + 1)/n for odd n)."""
    h, w, nc = src.shape
    h2, w2 = out.shape[0], out.shape[1]
    half = np.float32(0.5)
    if h % 2 == 0 and w % 2 == 0:  # both passes at once, the same operations
        for i in range(h2):
            for x in range(w2):
                for c in range(nc):
                    left = half * (src[2 * i, 2 * x, c] + src[2 * i + 1, 2 * x, c])
                    right = half * (src[2 * i, 2 * x + 1, c] + src[2 * i + 1, 2 * x + 1, c])
                    out[i, x, c] = half * (left + right)
        return
    rows = np.empty((h2, w, nc), np.float32)
    _halve_first_axis(src, rows)
    for i in range(h2):
        _halve_first_axis(rows[i].reshape((w, 1, nc)), out[i].reshape((w2, 1, nc)))


CODE_BINS = 16384
# the sRGB code of the linear value at the lower edge of each bin (IEC 61966-2-1): the nearest
# code of a value in the bin is this one or one of the next few
_edges = np.arange(CODE_BINS + 1) / CODE_BINS
_BIN_CODES = np.rint(255.0 * np.where(_edges <= 0.0031308, 12.92 * _edges,
                                      1.055 * _edges ** (1.0 / 2.4) - 0.055)).astype(np.int64)
_BIN_CODES = np.maximum(_BIN_CODES - 1, 0)  # a code at or below every value of its bin


@nb.njit(**_OPTIONS)
def _taps(i, n):
    """First input texel and the area weights of output texel i of an axis of n texels
    (``halve``'s: the texel itself for n = 1, pairs for even n, three taps for odd n)."""
    if n == 1:
        return 0, np.float32(1.0), np.float32(0.0), np.float32(0.0)
    if n % 2 == 0:
        return 2 * i, np.float32(0.5), np.float32(0.5), np.float32(0.0)
    m = (n - 1) // 2
    return (2 * i, (np.float32(m) - np.float32(i)) / np.float32(n), np.float32(m / n),
            (np.float32(i) + np.float32(1.0)) / np.float32(n))


@nb.njit(**_OPTIONS)
def _nearest_code(v, thresholds):
    """The 8-bit sRGB code nearest to the linear value v: the number of ``thresholds`` (255,)
    (the linear values halfway between codes, in encoded terms) below v, found from the code
    below v's bin of ``CODE_BINS`` and counted up from there."""
    if not v > np.float32(0.0):
        return 0
    code = _BIN_CODES[min(np.int64(v * np.float32(CODE_BINS)), CODE_BINS)]
    while code < 255 and thresholds[code] < v:
        code += 1
    return code


@nb.njit(**_OPTIONS)
def _round_code(acc):
    """A filtered code (float32) rounded to the nearest integer, ties to even, in [0, 255]."""
    code = np.floor(acc + np.float32(0.5))
    if code - acc == np.float32(0.5) and code % 2 == 1:  # ties to even: no drift
        code -= np.float32(1.0)
    return np.uint8(min(max(code, np.float32(0.0)), np.float32(255.0)))


@nb.njit(nb.void(nb.uint8[:, :, ::1], nb.uint8[:, :, ::1], nb.int64, nb.float32[::1],
                 nb.float32[::1]), **_OPTIONS)
def halve_bytes(src, out, decode, lut, thresholds):
    """``halve`` of an 8-bit level: ``src`` (h, w, C) uint8 to ``out`` (max(1, h // 2),
    max(1, w // 2), C) with the same area weights, in float32. The first ``decode`` channels
    hold sRGB codes: they are filtered as the linear values of ``lut`` (256,) and take the
    nearest code again (``thresholds`` (255,): the linear values halfway between codes); the
    others are filtered as they are and rounded to the nearest code, ties to even (so that
    levels made of levels do not drift)."""
    h, w, nc = src.shape
    h2, w2 = out.shape[0], out.shape[1]
    quarter = np.float32(0.25)
    if h % 2 == 0 and w % 2 == 0:  # 2 x 2 blocks: the usual case, written out
        for i in range(h2):
            top, bottom = src[2 * i], src[2 * i + 1]
            row = out[i]
            for x in range(w2):
                for c in range(nc):  # codes: the sum of four, halved twice, ties to even
                    total = ((np.int32(top[2 * x, c]) + np.int32(top[2 * x + 1, c]))
                             + (np.int32(bottom[2 * x, c]) + np.int32(bottom[2 * x + 1, c])))
                    q = total >> 2
                    r = total & 3
                    row[x, c] = q + ((r > 2) | ((r == 2) & (q & 1 == 1)))
                for c in range(decode):
                    v = quarter * ((lut[top[2 * x, c]] + lut[top[2 * x + 1, c]])
                                   + (lut[bottom[2 * x, c]] + lut[bottom[2 * x + 1, c]]))
                    row[x, c] = _nearest_code(v, thresholds)
        return
    for i in range(h2):
        r0, wr0, wr1, wr2 = _taps(i, h)
        rows = 1 if h == 1 else (2 if h % 2 == 0 else 3)
        for x in range(w2):
            c0, wc0, wc1, wc2 = _taps(x, w)
            cols = 1 if w == 1 else (2 if w % 2 == 0 else 3)
            for c in range(nc):
                acc = np.float32(0.0)
                for j in range(rows):
                    wr = wr0 if j == 0 else (wr1 if j == 1 else wr2)
                    line = np.float32(0.0)
                    for m in range(cols):
                        wc = wc0 if m == 0 else (wc1 if m == 1 else wc2)
                        t = src[r0 + j, c0 + m, c]
                        line += wc * (lut[t] if c < decode else np.float32(t))
                    acc += wr * line
                out[i, x, c] = (_nearest_code(acc, thresholds) if c < decode
                                else _round_code(acc))


REPEAT, EXTEND, CLIP, MIRROR = 0, 1, 2, 3
EXTENSIONS = {"REPEAT": REPEAT, "EXTEND": EXTEND, "CLIP": CLIP, "MIRROR": MIRROR}


@nb.njit(**_OPTIONS)
def _wrap(i, n, extension):
    """Texel index i wrapped into [0, n) by an extension mode (Cycles' wrap functions), and
    whether it is inside the image (CLIP)."""
    if extension == REPEAT:
        return i % n, True
    if extension == MIRROR:
        m = abs(i + (1 if i < 0 else 0)) % (2 * n)
        return (2 * n - m - 1 if m >= n else m), True
    clamped = min(max(i, 0), n - 1)
    return clamped, (extension != CLIP or (0 <= i < n))


_SAMPLE = [nb.void(
    texels, nb.int64[:, ::1], nb.int64, nb.int64, nb.int64,  # texels, levels
    nb.float64[::1], nb.float64[::1], nb.float64[::1], nb.boolean,  # u, v, lod, use lod
    nb.int64, nb.int64, nb.float32[::1], nb.float32[:, ::1],  # decode, associate, table, out
) for texels in (nb.float32[::1], nb.uint8[::1])]


@nb.njit(nb.float32(nb.float32), **_OPTIONS)
def _decode(v):
    if not v > np.float32(0.0):
        return np.float32(0.0) if v == v else v
    return _srgb_formula(v)


LINEAR, CLOSEST, CUBIC = 0, 1, 2
FILTERS = {"Linear": LINEAR, "Closest": CLOSEST, "Cubic": CUBIC, "Smart": CUBIC}


@nb.njit(**_OPTIONS)
def _spline(t):
    """Uniform cubic B-spline weights of the four taps around t in [0, 1) (Cycles'
    ``SET_CUBIC_SPLINE_WEIGHTS``)."""
    w0 = (((np.float32(-1.0 / 6.0) * t + np.float32(0.5)) * t - np.float32(0.5)) * t
          + np.float32(1.0 / 6.0))
    w1 = ((np.float32(0.5) * t - np.float32(1.0)) * t) * t + np.float32(2.0 / 3.0)
    w2 = ((np.float32(-0.5) * t + np.float32(0.5)) * t + np.float32(0.5)) * t \
        + np.float32(1.0 / 6.0)
    w3 = np.float32(1.0 / 6.0) * t * t * t
    return w0, w1, w2, w3


@nb.njit(**_OPTIONS)
def _finish(vals, straight, decode, weight, out):
    """One level's filtered texel ``vals`` into ``out``: divided by its alpha first when
    ``straight`` (Cycles unassociates before it decodes), the first ``decode`` channels
    decoded from sRGB, times ``weight``."""
    if straight:
        a = vals[3]
        for c in range(3):
            vals[c] = vals[c] / a if a > np.float32(0.0) else np.float32(0.0)
    for c in range(vals.shape[0]):
        v = _decode(vals[c]) if c < decode else vals[c]
        out[c] += weight * v


@nb.njit(**_OPTIONS)
def _value(texels, at, scale):
    """One stored value as float32: an 8-bit code times ``scale`` (1 / 255), a float value
    as it is (``scale`` 1)."""
    return np.float32(texels[at]) * scale


@nb.njit(_SAMPLE, **_OPTIONS)
def sample(texels, levels, extension, channels, mode, u, v, lod, use_lod, decode, associate,
           table, out):
    """``texture.sample``: filtered look-ups of a texture whose mip level k (rows: offset into
    ``texels``, height, width) is stored row 0 at the top, C = ``channels``; ``mode`` LINEAR:
    bilinear at level 0 without ``use_lod``, else trilinear at ``lod`` (N,) (clamped to the
    levels, NaN: the coarsest); CLOSEST: the nearest texel of level 0; CUBIC: level 0 by the
    cubic B-spline of its 4 x 4 taps (as Cycles' Cubic), blended linearly with level 1 beyond
    lod 0. The first ``decode`` channels of level 0 are sRGB-encoded and decoded after the
    interpolation, as Cycles does for 8-bit sRGB images. Float texels are read as they are
    (``table`` empty) and their other levels are linear; 8-bit texels (uint8) are codes / 255,
    and the first ``decode`` channels of their other levels are sRGB codes, each decoded by
    ``table`` (256,) before it is filtered. With ``associate`` (RGBA only), the colour of
    every tap is multiplied by its alpha before it is weighted, as Cycles filters images with
    alpha: 1 returns that premultiplied colour, 2 divides it by the filtered alpha again. UV
    as Blender's, v up; out (N, C) float32."""
    closest = mode == CLOSEST
    assoc = associate > 0 and channels == 4
    straight = assoc and associate == 2
    codes = table.shape[0] > 0
    scale = np.float32(1.0 / 255.0) if codes else np.float32(1.0)
    vals = np.empty(channels, np.float32)
    top = levels.shape[0] - 1
    for i in range(u.shape[0]):
        uu, vv = u[i], v[i]
        if not np.isfinite(uu):
            uu = 0.0
        if not np.isfinite(vv):
            vv = 0.0
        for c in range(channels):
            out[i, c] = np.float32(0.0)
        if closest:
            off, h, w = levels[0, 0], levels[0, 1], levels[0, 2]
            col, col_ok = _wrap(np.int64(np.floor(uu * w)), w, extension)
            row, row_ok = _wrap(np.int64(np.floor(vv * h)), h, extension)
            at = off + ((h - 1 - row) * w + col) * channels
            for c in range(channels):
                t = np.float32(0.0)
                if col_ok and row_ok:
                    t = _value(texels, at + c, scale)
                    if assoc and c < 3:
                        t *= _value(texels, at + 3, scale)
                vals[c] = t
            _finish(vals, straight, decode, np.float32(1.0), out[i])
            continue
        if use_lod:
            level = lod[i]
            level = np.float64(top) if level != level else min(max(level, 0.0), np.float64(top))
            base = np.int64(np.floor(level))
            frac = np.float32(level - base)
        else:
            base, frac = np.int64(0), np.float32(0.0)
        for k in range(base, base + 2):
            if k > top:
                break
            weight = (np.float32(1.0) - frac) if k == base else frac
            if not weight > 0.0:
                continue
            off, h, w = levels[k, 0], levels[k, 1], levels[k, 2]
            x = uu * w - 0.5
            y = vv * h - 0.5
            x0, y0 = np.floor(x), np.floor(y)
            tx, ty = np.float32(x - x0), np.float32(y - y0)
            if mode == CUBIC and k == 0:
                wx, wy = _spline(tx), _spline(ty)
                for c in range(channels):
                    acc = np.float32(0.0)
                    for j in range(4):
                        row, row_ok = _wrap(np.int64(y0) - 1 + j, h, extension)
                        if not row_ok:
                            continue
                        base_row = off + (h - 1 - row) * w * channels
                        line = np.float32(0.0)
                        for m in range(4):
                            col, col_ok = _wrap(np.int64(x0) - 1 + m, w, extension)
                            if col_ok:
                                at = base_row + col * channels
                                t = _value(texels, at + c, scale)
                                if assoc and c < 3:
                                    t *= _value(texels, at + 3, scale)
                                line += wx[m] * t
                        acc += wy[j] * line
                    vals[c] = acc
            else:
                c0, ok0 = _wrap(np.int64(x0), w, extension)
                c1, ok1 = _wrap(np.int64(x0) + 1, w, extension)
                r0, okr0 = _wrap(np.int64(y0), h, extension)
                r1, okr1 = _wrap(np.int64(y0) + 1, h, extension)
                one = np.float32(1.0)
                for c in range(channels):
                    decoded = codes and k > 0 and c < decode
                    acc = np.float32(0.0)
                    for (row, row_ok, wy) in ((r0, okr0, one - ty), (r1, okr1, ty)):
                        base_row = off + (h - 1 - row) * w * channels
                        for (col, col_ok, wx) in ((c0, ok0, one - tx), (c1, ok1, tx)):
                            wgt = wx * wy
                            if not (row_ok and col_ok):
                                wgt = np.float32(0.0)
                            at = base_row + col * channels
                            t = table[np.int64(texels[at + c])] if decoded \
                                else _value(texels, at + c, scale)
                            if assoc and c < 3:
                                t *= _value(texels, at + 3, scale)
                            acc += wgt * t
                    vals[c] = acc
            _finish(vals, straight, decode if k == 0 else 0, weight, out[i])


_RO = nb.types.Array(nb.float32, 2, "A", readonly=True)


@nb.njit(nb.void(_RO, _RO, nb.float64, nb.float64, nb.float64[::1]), **_OPTIONS)
def footprint_lod(step_x, step_y, width, height, lod):
    """``texture.lod_from_uv_derivatives`` of look-ups whose UV (the first two columns)
    changes by ``step_x`` and ``step_y`` (N, >= 2) over one pixel right and down: lod (N,) =
    log2 of the longer step in texels; a non-finite step gives the coarsest level (+inf)."""
    for i in range(step_x.shape[0]):
        ax = np.float64(step_x[i, 0]) * width
        ay = np.float64(step_x[i, 1]) * height
        bx = np.float64(step_y[i, 0]) * width
        by = np.float64(step_y[i, 1]) * height
        rho2 = max(ax * ax + ay * ay, bx * bx + by * by)
        if not np.isfinite(rho2):
            lod[i] = np.inf
        else:
            lod[i] = 0.5 * np.log2(max(rho2, 1e-60))


mark_cached(__name__)  # every kernel above is compiled or loaded
