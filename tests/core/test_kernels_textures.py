"""Texture kernels against their NumPy references.

- ``halve``: the readable two-pass area-weighted box filter below (``reference_halve``, the
  NumPy the kernel replaced), bit for bit, on even, odd and 1-texel sizes;
- ``prepare``: ``texture.srgb_to_linear`` (IEC 61966-2-1) on every 8-bit code and on
  values between codes, to 1 ulp of float32;
- ``sample``: bilinear and trilinear look-ups written out texel by texel below
  (``reference_lookup``: Cycles' wrap rules, Williams 1983), every extension mode, UVs far
  outside the image, non-finite UVs and LODs: relative 1e-6.
"""

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import texture
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
                                   (1, 1, 3), (10, 14, 2), (12, 7, 4)])
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
    np.testing.assert_allclose(tex.linear(0)[0, :, 0], expected, rtol=2e-7, atol=1e-9)


def test_large_image_is_decoded_in_bands_without_seams():
    """make_texture splits a large image into row bands, one per thread: every row is decoded
    (a band edge neither skipped nor done twice), and the even-sized levels match the
    two-pass reference."""
    codes = RNG.integers(0, 256, (1031, 1100, 4)).astype(np.float32) / np.float32(255)
    assert codes.size >= 4 * texture.PREPARE_BAND
    tex = texture.make_texture(codes, srgb=True)
    np.testing.assert_allclose(tex.linear(0)[..., :3], texture.srgb_to_linear(codes[..., :3]),
                               rtol=2e-7, atol=1e-9)
    np.testing.assert_array_equal(tex.linear(0)[..., 3], codes[..., 3])
    np.testing.assert_array_equal(tex.mips[1],
                                  reference_halve_axis(reference_halve_axis(tex.linear(0), 0), 1))


def wrapped(i, n, extension):
    """Cycles' wrap of texel index i into [0, n), or None outside the image (CLIP)."""
    if extension == "REPEAT":
        return i % n
    if extension == "MIRROR":
        m = (-i - 1 if i < 0 else i) % (2 * n)
        return 2 * n - m - 1 if m >= n else m
    if extension == "CLIP" and not 0 <= i < n:
        return None
    return min(max(i, 0), n - 1)


def reference_lookup(mips, extension, u, v, lod):
    """One trilinear (lod) or bilinear (lod None) look-up, texel by texel, in float64."""
    u = u if np.isfinite(u) else 0.0
    v = v if np.isfinite(v) else 0.0
    top = len(mips) - 1
    level = 0.0 if lod is None else (top if np.isnan(lod) else min(max(lod, 0.0), top))
    k0 = int(np.floor(level))
    out = np.zeros(mips[0].shape[2])
    for k, weight in ((k0, 1.0 - (level - k0)), (k0 + 1, level - k0)):
        if k > top or weight <= 0.0:
            continue
        h, w, _ = mips[k].shape
        x, y = u * w - 0.5, v * h - 0.5
        x0, y0 = int(np.floor(x)), int(np.floor(y))
        for dy, wy in ((0, 1.0 - (y - y0)), (1, y - y0)):
            for dx, wx in ((0, 1.0 - (x - x0)), (1, x - x0)):
                col, row = wrapped(x0 + dx, w, extension), wrapped(y0 + dy, h, extension)
                if col is not None and row is not None:
                    out += weight * wx * wy * mips[k][h - 1 - row, col]
    return out


@pytest.mark.parametrize("extension", ["REPEAT", "EXTEND", "CLIP", "MIRROR"])
def test_sample_matches_texel_by_texel_lookups(extension):
    tex = texture.Texture(texture.build_mips(RNG.random((13, 22, 3)).astype(np.float32)),
                          extension)
    uv = RNG.uniform(-2.5, 3.5, (400, 2))
    uv[:3] = [[np.nan, 0.3], [np.inf, 0.5], [0.25, -np.inf]]
    lod = RNG.uniform(-1.0, 6.0, 400)
    lod[:2] = [np.nan, np.inf]
    for per_point in (None, lod):
        got = texture.sample(tex, uv, per_point)
        ref = np.array([reference_lookup(tex.mips, extension, a, b,
                                         None if per_point is None else per_point[i])
                        for i, (a, b) in enumerate(uv)])
        np.testing.assert_allclose(got, ref, rtol=1e-6, atol=1e-6)


def test_packed_chain_is_the_chain_itself():
    """A chain of build_mips / make_texture lies in one array: packed returns it without a
    copy, and it equals the chain packed from separate arrays."""
    tex = texture.make_texture(RNG.random((37, 20, 4), dtype=np.float32), srgb=True)
    flat, rows = tex.packed
    assert all(np.shares_memory(flat, m) for m in tex.mips)
    apart = texture.Texture([m.copy() for m in tex.mips], "REPEAT", "Linear")
    np.testing.assert_array_equal(apart.packed[0], flat)
    np.testing.assert_array_equal(apart.packed[1], rows)
    assert [tuple(r) for r in rows[:2]] == [(0, 37, 20), (37 * 20 * 4, 18, 10)]


def test_srgb_level_zero_is_decoded_after_interpolation():
    """Cycles keeps 8-bit sRGB images encoded and decodes each bilinear look-up; the mip levels
    are made from the decoded image, and a trilinear look-up blends the decoded levels."""
    codes = np.round(RNG.random((9, 14, 4)) * 255.0).astype(np.float32) / 255.0
    tex = texture.make_texture(codes, srgb=True)
    assert tex.encoded == 3
    np.testing.assert_array_equal(tex.mips[0], codes)
    linear = texture.make_texture(codes, srgb=False)  # the same texels, read as data
    uv = RNG.uniform(0.0, 1.0, (300, 2))
    got = texture.sample(tex, uv)
    expected = texture.srgb_to_linear(texture.sample(linear, uv)[:, :3])
    np.testing.assert_allclose(got[:, :3], expected, rtol=2e-6, atol=1e-7)
    np.testing.assert_array_equal(got[:, 3], texture.sample(linear, uv)[:, 3])
    decoded = texture.srgb_to_linear(codes[..., :3])
    np.testing.assert_allclose(tex.mips[1][..., :3],
                               reference_halve_axis(reference_halve_axis(decoded, 0), 1),
                               rtol=1e-5, atol=1e-7)
    lod = np.full(300, 0.5)
    mid = texture.sample(tex, uv, lod)
    level1 = texture.Texture(tex.mips[1:], tex.extension)
    blend = 0.5 * got[:, :3] + 0.5 * texture.sample(level1, uv)[:, :3]
    np.testing.assert_allclose(mid[:, :3], blend, rtol=1e-5, atol=1e-6)


def bspline(d):
    """The uniform cubic B-spline kernel at distance d (texels)."""
    d = abs(d)
    return (4.0 - 6.0 * d * d + 3.0 * d ** 3) / 6.0 if d < 1.0 else (
        (2.0 - d) ** 3 / 6.0 if d < 2.0 else 0.0)


@pytest.mark.parametrize("extension", ["REPEAT", "EXTEND", "CLIP", "MIRROR"])
def test_cubic_is_the_b_spline_of_the_texels(extension):
    """Cubic (as Cycles): the cubic B-spline kernel over the texel centres, each texel wrapped
    by the extension (CLIP: 0 outside)."""
    img = RNG.random((7, 9, 2)).astype(np.float32)
    tex = texture.Texture(texture.build_mips(img), extension, "Cubic")
    uv = RNG.uniform(-0.3, 1.3, (60, 2))
    got = texture.sample(tex, uv)
    h, w = img.shape[:2]
    for (u, v), value in zip(uv, got, strict=True):
        x, y = u * w - 0.5, v * h - 0.5  # texel-centre coordinates, row j counted from the bottom
        expected = np.zeros(2)
        for j in range(int(np.floor(y)) - 1, int(np.floor(y)) + 3):
            for i in range(int(np.floor(x)) - 1, int(np.floor(x)) + 3):
                col, row = wrapped(i, w, extension), wrapped(j, h, extension)
                if col is None or row is None:
                    continue
                expected += bspline(x - i) * bspline(y - j) * img[h - 1 - row, col]
        np.testing.assert_allclose(value, expected, rtol=1e-5, atol=1e-6)


def test_alpha_association():
    """associate=1 filters colour times alpha (Cycles' premultiplied images), 2 divides the
    result by the filtered alpha again; CLIP's outside taps are transparent black in both."""
    img = RNG.random((6, 5, 4)).astype(np.float32)
    premultiplied = img.copy()
    premultiplied[..., :3] *= img[..., 3:]
    for extension in ("REPEAT", "CLIP"):
        straight = texture.Texture(texture.build_mips(img), extension)
        reference = texture.Texture(texture.build_mips(premultiplied), extension)
        uv = RNG.uniform(-0.2, 1.2, (200, 2))
        expected = texture.sample(reference, uv)
        np.testing.assert_allclose(texture.sample(straight, uv, associate=1), expected,
                                   rtol=1e-5, atol=1e-6)
        got = texture.sample(straight, uv, associate=2)
        alpha = expected[:, 3:]
        ok = alpha[:, 0] > 1e-3
        np.testing.assert_allclose(got[ok, :3], expected[ok, :3] / alpha[ok], rtol=1e-4,
                                   atol=1e-5)
        np.testing.assert_array_equal(got[:, 3], expected[:, 3])


def test_footprint_lod_is_lod_from_uv_derivatives():
    """The kernel's level of detail from a look-up's UV steps equals the NumPy reference
    (OpenGL 4.6, 8.14.1), non-finite steps giving the coarsest level."""
    from bo2_lighting.addon.core.kernels import textures as kernels

    tex = texture.make_texture(RNG.random((64, 128, 3)).astype(np.float32), srgb=False)
    dx = RNG.normal(0.0, 0.02, (500, 3)).astype(np.float32)
    dy = RNG.normal(0.0, 0.02, (500, 3)).astype(np.float32)
    dx[:3, 0] = [np.nan, np.inf, 0.0]
    dy[2] = 0.0
    lod = np.empty(500)
    kernels.footprint_lod(dx, dy, 128.0, 64.0, lod)
    expected = texture.lod_from_uv_derivatives(tex, dx[:, :2], dy[:, :2])
    assert np.all(lod[:2] >= tex.levels - 1) and np.all(expected[:2] >= tex.levels - 1)
    np.testing.assert_allclose(lod[3:], expected[3:], rtol=1e-5, atol=1e-5)


# sRGB codes' linear values, and the linear values halfway between codes (IEC 61966-2-1)
TABLES = (texture.srgb_to_linear(np.arange(256) / 255.0),
          texture.srgb_to_linear((np.arange(255) + 0.5) / 255.0))


def reference_halve_codes(codes: np.ndarray, decode: int) -> np.ndarray:
    """One 8-bit mip level written out in float64, before rounding: the first ``decode``
    channels decoded from sRGB (IEC 61966-2-1), the two-pass area-weighted box filter, encoded
    again, times 255; the other channels filtered as codes."""
    values = codes.astype(np.float64)
    values[..., :decode] = texture.srgb_to_linear(values[..., :decode] / 255.0).astype(np.float64)
    out = reference_halve_axis(reference_halve_axis(values, 0), 1).astype(np.float64)
    linear = np.clip(out[..., :decode], 0.0, 1.0)
    out[..., :decode] = 255.0 * np.where(linear <= 0.0031308, 12.92 * linear,
                                         1.055 * linear ** (1.0 / 2.4) - 0.055)
    return out


@pytest.mark.parametrize("shape", [(8, 8, 4), (7, 9, 3), (1, 5, 1), (6, 1, 4), (13, 12, 4),
                                   (1, 1, 3), (12, 7, 4)])
@pytest.mark.parametrize("decode", [0, 3])
def test_eight_bit_levels_are_filtered_in_linear_and_encoded_again(shape, decode):
    decode = min(decode, shape[2])
    src = RNG.integers(0, 256, shape).astype(np.uint8)
    out = np.empty((max(1, shape[0] // 2), max(1, shape[1] // 2), shape[2]), np.uint8)
    kernels.halve_bytes(src, out, decode, *TABLES)
    exact = reference_halve_codes(src, decode)
    diff = np.abs(out.astype(int) - np.rint(exact).astype(int))  # nearest code, ties to even
    assert diff.max() <= 1
    edge = np.abs(exact - np.floor(exact) - 0.5) < 2e-3  # float32 rounding decides a tie
    assert not (diff > 0)[~edge].any()
    # a uniform image keeps its codes level after level
    flat = np.full(shape, 200, np.uint8)
    kernels.halve_bytes(flat, out, decode, *TABLES)
    assert (out == 200).all()


def test_eight_bit_texture_samples_as_its_float_twin():
    """An 8-bit image kept as codes reads as the float image of the same values at level 0
    (every filter, alpha association); its other levels are the linear filter of the codes,
    stored as codes, and a trilinear look-up blends them as the texel-by-texel reference."""
    codes = RNG.integers(0, 256, (21, 34, 4)).astype(np.uint8)
    for srgb in (True, False):
        for interpolation in ("Linear", "Closest", "Cubic"):
            eight = texture.make_texture(codes, srgb=srgb, interpolation=interpolation)
            twin = texture.make_texture(codes / np.float32(255.0), srgb=srgb,
                                        interpolation=interpolation)
            assert eight.codes and eight.image.dtype == np.uint8 and not twin.codes
            uv = RNG.uniform(-0.5, 1.5, (300, 2))
            for associate in (0, 1, 2):
                np.testing.assert_allclose(texture.sample(eight, uv, None, associate),
                                           texture.sample(twin, uv, None, associate),
                                           rtol=2e-6, atol=1e-7)
        tex = texture.make_texture(codes, srgb=srgb)
        linear = [tex.linear(k) for k in range(tex.levels)]
        reference = linear[:1] + [texture.make_texture(level, srgb=False).image
                                  for level in linear[1:]]
        lod = RNG.uniform(0.0, 5.0, 300)
        uv = RNG.uniform(-0.5, 1.5, (300, 2))
        got = texture.sample(tex, uv, lod)
        ref = np.array([reference_lookup(reference, "REPEAT", a, b, lod[i])
                        for i, (a, b) in enumerate(uv)])
        if srgb:  # level 0 is decoded after its bilinear step: its share comes from the
            # bilinear look-up of level 0 (tested above), the rest from level 1's reference
            near = lod < 1.0
            f = lod[near, None]
            level1 = np.array([reference_lookup(reference[1:], "REPEAT", a, b, None)
                               for a, b in uv[near]])
            ref[near] = (1.0 - f) * texture.sample(tex, uv[near]) + f * level1
        np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-6)
        # the 8-bit levels are the float twin's levels to within half a code at level 1, and
        # a code and a quarter deeper (each level rounds a level that was rounded)
        twin = texture.make_texture(codes / np.float32(255.0), srgb=srgb)
        for k in range(1, tex.levels):
            encoded = twin.mips[k].copy()
            if srgb:
                encoded[..., :3] = texture.linear_to_srgb(encoded[..., :3])
            np.testing.assert_allclose(tex.mips[k] / 255.0, encoded,
                                       atol=(0.5 if k == 1 else 1.25) / 255 + 1e-6)


def test_mip_levels_are_filled_when_a_look_up_first_needs_them():
    """make_texture fills level 0 only; look-ups at level 0 (no lod, lod <= 0, Closest) leave
    the other levels pending, the first that reaches level 1 fills them before it reads, and
    reads what a texture filled beforehand reads."""
    codes = RNG.integers(0, 256, (64, 48, 4)).astype(np.uint8)
    tex = texture.make_texture(codes, srgb=True)
    uv = RNG.uniform(0.0, 1.0, (50, 2))
    texture.sample(tex, uv)
    texture.sample(tex, uv, np.full(50, -1.0))
    closest = texture.make_texture(codes, srgb=True, interpolation="Closest")
    texture.sample(closest, uv, np.full(50, 3.0))
    assert tex.pending and closest.pending
    lod = np.zeros(50)
    lod[7] = np.nan  # the coarsest level
    lod[8] = 2.5
    first = texture.sample(tex, uv, lod)
    assert not tex.pending
    filled = texture.make_texture(codes, srgb=True)
    filled.fill_mips()
    np.testing.assert_array_equal(first, texture.sample(filled, uv, lod))
    assert first[7].tolist() != first[0].tolist()  # the coarsest level was read, filled
