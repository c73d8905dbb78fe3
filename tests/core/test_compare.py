"""Comparison metrics, SSIM, colour map, bitmap font, composition and PNG writer.

Independent values:
- PSNR, RMSE and mean relative error of images whose MSE is known in closed form (a constant
  offset d: MSE = d^2, PSNR = -20 log10 d; a +-d checkerboard: the same);
- SSIM: the identity SSIM(x, x) = 1 and symmetry; two constant images, whose variances and
  covariance vanish, SSIM = (2ab + C1) / (a^2 + b^2 + C1) in closed form (Wang et al. 2004,
  eq. 13); a brute-force implementation of eq. 13 here (explicit 2-D Gaussian weights, a loop
  over window positions, weighted moments from their definitions); the window against the
  2-D Gaussian exp(-(x^2 + y^2) / (2 1.5^2)) on 11 x 11 taps, normalized;
- colour map: Oklab lightness computed with Ottosson's forward matrices (linear sRGB -> LMS ->
  cube root -> L), CIE 1976 L* from the Rec. 709 luminance (CIE 15:2004), and Oklab's white
  point (L = 1, a = b = 0 is linear sRGB (1, 1, 1));
- PNG: decoded here with zlib (filter type 0 rows), checked byte for byte.
"""

import math
import struct
import zlib

import numpy as np
import pytest

from bo2_lighting.addon.core import compare

RNG = np.random.default_rng(7)


# --- metrics -----------------------------------------------------------------------------------

def test_rmse_psnr_of_a_constant_offset():
    a = RNG.random((20, 30, 3)).astype(np.float32) * 0.8
    b = a + np.float32(0.1)
    assert compare.mse(a, b) == pytest.approx(0.01, rel=1e-5)
    assert compare.rmse(a, b) == pytest.approx(0.1, rel=1e-5)
    assert compare.psnr(a, b) == pytest.approx(20.0, abs=1e-4)  # -20 log10(0.1)
    assert compare.psnr(a, b, peak=2.0) == pytest.approx(20.0 + 20 * math.log10(2), abs=1e-4)


def test_psnr_of_a_checkerboard_error_and_identity():
    a = np.full((16, 16), 0.5)
    d = 0.02 * np.where((np.arange(16)[:, None] + np.arange(16)) % 2, 1.0, -1.0)
    assert compare.psnr(a + d, a) == pytest.approx(-20 * math.log10(0.02), abs=1e-9)
    assert compare.psnr(a, a) == math.inf
    assert compare.rmse(a, a) == 0.0


def test_mean_relative_error():
    ref = np.array([1.0, 0.0, 2.0])
    test = np.array([1.1, 0.01, 2.0])
    expected = (0.1 / 1.01 + 0.01 / 0.01 + 0.0) / 3
    assert compare.mean_relative_error(test, ref) == pytest.approx(expected, rel=1e-12)
    assert compare.mean_relative_error(ref, ref) == 0.0


def test_luminance_rec709():
    assert compare.luminance([1.0, 1.0, 1.0]) == pytest.approx(1.0, abs=1e-6)
    np.testing.assert_allclose(compare.luminance(np.eye(3)), [0.2126, 0.7152, 0.0722], rtol=1e-6)


def test_image_metrics_keys_and_identity():
    lin = RNG.random((24, 24, 3)).astype(np.float32)
    disp = np.sqrt(lin)
    m = compare.image_metrics(lin, lin, disp, disp)
    assert m == {"rmse": 0.0, "mean_relative_error": 0.0, "psnr_db": None, "ssim": 1.0}
    m = compare.image_metrics(lin * 1.1, lin, disp * 0.9, disp)
    assert m["rmse"] > 0 and m["psnr_db"] > 0 and 0 < m["ssim"] < 1


@pytest.mark.parametrize("x, expected", [(0.031, 0.04), (0.2, 0.2), (0.21, 0.25), (7.0, 8.0),
                                         (1.0, 1.0), (2.4e-4, 2.5e-4), (0.518, 0.6),
                                         (8.5, 10.0), (0.11, 0.15)])
def test_nice_ceil(x, expected):
    assert compare.nice_ceil(x) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("seconds, text", [(0.8412, "0.84 s"), (12.34, "12.3 s"),
                                           (125.2, "2 min 05 s")])
def test_format_seconds(seconds, text):
    assert compare.format_seconds(seconds) == text


# --- SSIM --------------------------------------------------------------------------------------

def test_gaussian_window_is_the_papers():
    w = compare.gaussian_window()
    assert w.shape == (11,) and w.sum() == pytest.approx(1.0, abs=1e-15)
    yy, xx = np.mgrid[-5:6, -5:6]
    g = np.exp(-(xx ** 2 + yy ** 2) / (2 * 1.5 ** 2))
    np.testing.assert_allclose(np.outer(w, w), g / g.sum(), rtol=1e-12)
    assert w[5] / w[4] == pytest.approx(math.exp(1 / 4.5), rel=1e-12)


def test_ssim_identity_and_symmetry():
    x = RNG.random((40, 50))
    y = np.clip(x + 0.1 * RNG.standard_normal(x.shape), 0, 1)
    assert compare.ssim(x, x) == pytest.approx(1.0, abs=1e-12)
    assert compare.ssim(x, y) == pytest.approx(compare.ssim(y, x), abs=1e-12)
    assert 0 < compare.ssim(x, y) < 1
    assert compare.ssim(x, 1 - x) < 0  # anti-correlated structure


@pytest.mark.parametrize("a, b", [(0.2, 0.6), (0.0, 1.0), (0.5, 0.5), (0.9, 0.1)])
def test_ssim_of_constant_images_closed_form(a, b):
    c1 = (0.01 * 1.0) ** 2
    expected = (2 * a * b + c1) / (a * a + b * b + c1)  # sigma terms: (0 + C2) / (0 + C2)
    x, y = np.full((20, 20), a), np.full((20, 20), b)
    assert compare.ssim(x, y) == pytest.approx(expected, rel=1e-9)


def brute_force_ssim_map(x, y, sigma=1.5, size=11, data_range=1.0):
    """Wang et al. 2004 eq. 13 from the definitions, one window position at a time."""
    r = size // 2
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    w = np.exp(-(xx ** 2 + yy ** 2) / (2 * sigma ** 2))
    w /= w.sum()
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    h, wd = x.shape
    out = np.empty((h - size + 1, wd - size + 1))
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            px, py = x[i:i + size, j:j + size], y[i:i + size, j:j + size]
            mx, my = (w * px).sum(), (w * py).sum()
            vx, vy = (w * (px - mx) ** 2).sum(), (w * (py - my) ** 2).sum()
            cxy = (w * (px - mx) * (py - my)).sum()
            out[i, j] = ((2 * mx * my + c1) * (2 * cxy + c2)) / (
                (mx ** 2 + my ** 2 + c1) * (vx + vy + c2))
    return out


def test_ssim_matches_brute_force():
    x = RNG.random((19, 23))
    y = np.clip(0.7 * x + 0.2 + 0.05 * RNG.standard_normal(x.shape), 0, 1)
    expected = brute_force_ssim_map(x, y)
    got = compare.ssim_map(x, y)
    assert got.shape == (9, 13)
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)
    assert compare.ssim(x, y) == pytest.approx(expected.mean(), rel=1e-9)


def test_ssim_of_an_image_smaller_than_the_window():
    x = RNG.random((6, 9))
    y = np.clip(x + 0.05, 0, 1)
    assert compare.ssim_map(x, y).shape == (2, 5)  # window shrunk to 5 x 5
    np.testing.assert_allclose(compare.ssim_map(x, y), brute_force_ssim_map(x, y, size=5),
                               rtol=1e-9)
    assert compare.ssim(x, x) == pytest.approx(1.0)
    with pytest.raises(ValueError):
        compare.ssim(x, x[:5])


# --- colour map --------------------------------------------------------------------------------

def oklab_lightness(linear_rgb):
    m1 = np.array([[0.4122214708, 0.5363325363, 0.0514459929],
                   [0.2119034982, 0.6806995451, 0.1073969566],
                   [0.0883024619, 0.2817188376, 0.6299787005]])
    lms = np.cbrt(linear_rgb @ m1.T)
    return lms @ np.array([0.2104542553, 0.7936177850, -0.0040720468])


def srgb_decode(x):
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def test_oklab_white_point():
    np.testing.assert_allclose(compare.oklab_to_linear_srgb([1.0, 0.0, 0.0]), [1, 1, 1],
                               atol=1e-4)


def test_colormap_lightness_is_monotonic():
    lut = compare.COLORMAP.astype(np.float64)
    assert lut.shape == (256, 3) and lut.min() >= 0 and lut.max() <= 1
    linear = srgb_decode(lut)
    lightness = oklab_lightness(linear)
    assert np.all(np.diff(lightness) > 0)
    np.testing.assert_allclose(lightness, np.linspace(0.18, 0.97, 256), atol=2e-3)
    y = linear @ np.array([0.2126, 0.7152, 0.0722])
    lstar = np.where(y > (6 / 29) ** 3, 116 * np.cbrt(y) - 16, y * (29 / 3) ** 3)
    assert np.all(np.diff(lstar) > 0)
    assert lstar[0] < 15 and lstar[-1] > 90
    chroma = np.ptp(lut, -1)
    assert chroma[128] > 0.3  # a colourful middle, not a grey ramp


def test_colormap_interpolation_and_clipping():
    np.testing.assert_allclose(compare.colormap(0.0), compare.COLORMAP[0])
    np.testing.assert_allclose(compare.colormap(1.0), compare.COLORMAP[-1])
    np.testing.assert_allclose(compare.colormap(7.0), compare.COLORMAP[-1])
    np.testing.assert_allclose(compare.colormap(np.nan), compare.COLORMAP[0])
    mid = compare.colormap(0.5 / 255)
    np.testing.assert_allclose(mid, 0.5 * (compare.COLORMAP[0] + compare.COLORMAP[1]), atol=1e-6)
    assert compare.colormap(np.zeros((4, 5))).shape == (4, 5, 3)


# --- font --------------------------------------------------------------------------------------

def test_font_has_every_printable_glyph():
    assert sorted(compare.GLYPHS) == [chr(c) for c in range(32, 127)]
    bitmaps = set()
    for char, text in compare.GLYPHS.items():
        rows = text.split()
        assert len(rows) == 7 and all(len(r) == 5 and set(r) <= {"#", "."} for r in rows), char
        mask = compare.text_mask(char)
        assert mask.shape == (7, 5)
        assert mask.any() == (char != " "), char
        bitmaps.add(mask.tobytes())
    assert len(bitmaps) == 95  # every glyph differs from every other


def test_text_mask_layout_and_scale():
    m = compare.text_mask("Hi!", 2)
    assert m.shape == (14, (3 * 6 - 1) * 2)
    assert compare.text_size("Hi!", 2) == (34, 14)
    np.testing.assert_array_equal(m[::2, ::2][:, :5], compare.text_mask("H"))
    assert not m[:, 10:12].any()  # the spacing column between glyphs
    np.testing.assert_array_equal(compare.text_mask("\u00e9"), compare.text_mask("?"))
    assert compare.text_mask("").shape == (7, 0)


def test_draw_text_clips_and_boxes():
    img = np.zeros((10, 12, 3), np.float32)
    compare.draw_text(img, "WWWWW", -3, 5, 1, (1, 0, 0))  # off the left and the bottom
    assert img[..., 0].any() and not img[..., 1].any()
    img = np.ones((20, 40, 3), np.float32)
    compare.draw_text(img, "A", 5, 5, 1, (1, 1, 1), box=(0, 0, 0, 0.5), pad=2)
    assert img[3, 3, 0] == pytest.approx(0.5) and img[0, 0, 0] == 1.0


# --- composition and output --------------------------------------------------------------------

def test_side_by_side_and_split_shapes():
    h, w = 36, 64
    a = np.full((h, w, 3), 0.2, np.float32)
    b = np.full((h, w, 3), 0.7, np.float32)
    labels = (("BO2 Lighting  1.00 s", "BO2"), ("Cycles  9.00 s", "Cycles"))
    sbs = compare.side_by_side(a, b, labels)
    s = compare.label_scale(h)
    assert sbs.shape == (h + compare.CELL_H * s + 4 * s, 2 * w + 2 * s, 3)
    np.testing.assert_allclose(sbs[-1, :w], 0.2)
    np.testing.assert_allclose(sbs[-1, -w:], 0.7)
    split = compare.split_view(a, b, labels)
    assert split.shape == (h, w, 3)
    assert split[-1, 2, 0] == pytest.approx(0.2) and split[-1, -3, 0] == pytest.approx(0.7)
    assert split[-1, w // 2, 0] > 0.9  # the divider
    assert (split[:12] != split[-1]).any()  # labels drawn at the top


def test_heat_map_layout():
    diff = np.linspace(0, 0.2, 64 * 36).reshape(36, 64)
    img = compare.heat_map(diff, 0.1, "caption", "footer")
    assert img.shape[0] > 36 and img.shape[1] >= 64 and img.shape[2] == 3
    x0 = (img.shape[1] - 64) // 2
    np.testing.assert_allclose(img[:36, x0:x0 + 64], compare.colormap(diff / 0.1), atol=1e-6)
    assert img.min() >= 0 and img.max() <= 1


def test_label_scale():
    assert compare.label_scale(36) == 1 and compare.label_scale(1080) == 6


def test_write_png_round_trip(tmp_path):
    rgb = (RNG.random((5, 7, 3)) * 255).astype(np.uint8)
    path = tmp_path / "x.png"
    compare.write_png(path, rgb)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">IIBBBBB", data[16:29]) == (7, 5, 8, 2, 0, 0, 0)
    start = data.index(b"IDAT")
    length = struct.unpack(">I", data[start - 4:start])[0]
    raw = np.frombuffer(zlib.decompress(data[start + 4:start + 4 + length]), np.uint8)
    raw = raw.reshape(5, 1 + 7 * 3)
    assert (raw[:, 0] == 0).all()
    np.testing.assert_array_equal(raw[:, 1:].reshape(5, 7, 3), rgb)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.png"]  # no partial file left


def test_to_uint8_rounds_and_clips():
    np.testing.assert_array_equal(compare.to_uint8(np.array([-1, 0.5, 1.2, np.nan])),
                                  [0, 128, 255, 0])
