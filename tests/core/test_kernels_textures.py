"""Texture kernels against their NumPy references.

- ``halve``: the readable two-pass area-weighted box filter below (``reference_halve``, the
  NumPy the kernel replaced), bit for bit, on even, odd and 1-texel sizes;
- ``prepare``: ``texture.srgb_to_linear`` (IEC 61966-2-1) on every 8-bit code and on
  values between codes, to 1 ulp of float32.
"""

import numpy as np
import pytest

from bo2_lighting.addon.core import texture
from bo2_lighting.addon.core.kernels import textures as kernels

RNG = np.random.default_rng(5)


def reference_halve_axis(a: np.ndarray, axis: int) -> np.ndarray:
    """Box-filter one axis down to max(1, n // 2) samples, keeping the mean exactly: pairs for
    even n; for n = 2m + 1, output i averages texels 2i, 2i+1, 2i+2 with the area weights
    (m - i) / n, m / n, (i + 1) / n."""
    n = a.shape[axis]
    if n == 1:
        return a
    a = np.moveaxis(a, axis, 0)
    if n % 2 == 0:
        out = 0.5 * (a[0::2] + a[1::2])
    else:
        m = (n - 1) // 2
        i = np.arange(m, dtype=np.float32).reshape((m,) + (1,) * (a.ndim - 1))
        out = ((m - i) / n) * a[0:-1:2] + np.float32(m / n) * a[1::2] + ((i + 1) / n) * a[2::2]
    return np.moveaxis(out.astype(np.float32, copy=False), 0, axis)


@pytest.mark.parametrize("shape", [(8, 8, 4), (7, 9, 3), (1, 5, 1), (6, 1, 3), (13, 12, 4),
                                   (1, 1, 3)])
def test_halve_matches_the_reference_bit_for_bit(shape):
    src = RNG.random(shape, dtype=np.float32) * 4.0
    out = np.empty((max(1, shape[0] // 2), max(1, shape[1] // 2), shape[2]), np.float32)
    kernels.halve(src, out)
    expected = reference_halve_axis(reference_halve_axis(src, 0), 1)
    np.testing.assert_array_equal(out, expected)
    # the area weights keep the mean of a whole level (odd sizes included)
    if shape[0] > 1 and shape[1] > 1:
        np.testing.assert_allclose(out.mean((0, 1)), src.mean((0, 1)), rtol=0.2)


def test_mip_chain_keeps_the_mean_of_an_odd_image():
    image = RNG.random((37, 53, 3), dtype=np.float32)
    mips = texture.build_mips(image)
    assert [m.shape[:2] for m in mips][-1] == (1, 1) and len(mips) == 6
    np.testing.assert_allclose(mips[-1][0, 0], image.mean((0, 1)), rtol=1e-4)


def test_srgb_decode_by_table_and_between_codes():
    codes = np.arange(256, dtype=np.float32) / np.float32(255)
    between = RNG.random(300, dtype=np.float32)
    values = np.concatenate([codes, between, [0.0, 0.04045, 1.0]]).astype(np.float32)
    image = np.repeat(values[None, :, None], 4, axis=2)  # alpha in channel 3
    image[0, :3, 0] = [np.nan, np.inf, -np.inf]
    out = np.empty_like(image)
    kernels.prepare(image, 3, texture.srgb_to_linear(codes), out)
    expected = texture.srgb_to_linear(values)
    np.testing.assert_array_equal(out[0, :3, 0], 0.0)  # non-finite values become 0
    np.testing.assert_allclose(out[0, 3:, :3], np.repeat(expected[3:, None], 3, 1), rtol=2e-7,
                               atol=1e-9)
    np.testing.assert_array_equal(out[0, :, 3], values)  # alpha is never decoded
    # make_texture decodes the colour of an sRGB image once
    tex = texture.make_texture(np.repeat(values[None, :, None], 3, axis=2), srgb=True)
    np.testing.assert_allclose(tex.mips[0][0, :, 0], expected, rtol=2e-7, atol=1e-9)
