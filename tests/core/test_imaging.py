"""Pictures of a comparison: colour map, bitmap font, composition and PNG writer.

Independent values:
- colour map: Oklab lightness computed with Ottosson's forward matrices (linear sRGB -> LMS ->
  cube root -> L), CIE 1976 L* from the Rec. 709 luminance (CIE 15:2004), and Oklab's white
  point (L = 1, a = b = 0 is linear sRGB (1, 1, 1));
- PNG: decoded here with zlib (filter type 0 rows), checked byte for byte.
"""

import struct
import zlib

import numpy as np
import pytest

from bo2_lighting.addon.core.review import imaging

RNG = np.random.default_rng(7)


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
    np.testing.assert_allclose(imaging.oklab_to_linear_srgb([1.0, 0.0, 0.0]), [1, 1, 1],
                               atol=1e-4)


def test_colormap_lightness_is_monotonic():
    lut = imaging.COLORMAP.astype(np.float64)
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
    np.testing.assert_allclose(imaging.colormap(0.0), imaging.COLORMAP[0])
    np.testing.assert_allclose(imaging.colormap(1.0), imaging.COLORMAP[-1])
    np.testing.assert_allclose(imaging.colormap(7.0), imaging.COLORMAP[-1])
    np.testing.assert_allclose(imaging.colormap(np.nan), imaging.COLORMAP[0])
    mid = imaging.colormap(0.5 / 255)
    np.testing.assert_allclose(mid, 0.5 * (imaging.COLORMAP[0] + imaging.COLORMAP[1]), atol=1e-6)
    assert imaging.colormap(np.zeros((4, 5))).shape == (4, 5, 3)


# --- font --------------------------------------------------------------------------------------

def test_font_has_every_printable_glyph():
    assert sorted(imaging.GLYPHS) == [chr(c) for c in range(32, 127)]
    bitmaps = set()
    for char, text in imaging.GLYPHS.items():
        rows = text.split()
        assert len(rows) == 7 and all(len(r) == 5 and set(r) <= {"#", "."} for r in rows), char
        mask = imaging.text_mask(char)
        assert mask.shape == (7, 5)
        assert mask.any() == (char != " "), char
        bitmaps.add(mask.tobytes())
    assert len(bitmaps) == 95  # every glyph differs from every other


def test_text_mask_layout_and_scale():
    m = imaging.text_mask("Hi!", 2)
    assert m.shape == (14, (3 * 6 - 1) * 2)
    assert imaging.text_size("Hi!", 2) == (34, 14)
    np.testing.assert_array_equal(m[::2, ::2][:, :5], imaging.text_mask("H"))
    assert not m[:, 10:12].any()  # the spacing column between glyphs
    np.testing.assert_array_equal(imaging.text_mask("\u00e9"), imaging.text_mask("?"))
    assert imaging.text_mask("").shape == (7, 0)


def test_draw_text_clips_and_boxes():
    img = np.zeros((10, 12, 3), np.float32)
    imaging.draw_text(img, "WWWWW", -3, 5, 1, (1, 0, 0))  # off the left and the bottom
    assert img[..., 0].any() and not img[..., 1].any()
    img = np.ones((20, 40, 3), np.float32)
    imaging.draw_text(img, "A", 5, 5, 1, (1, 1, 1), box=(0, 0, 0, 0.5), pad=2)
    assert img[3, 3, 0] == pytest.approx(0.5) and img[0, 0, 0] == 1.0


# --- composition and output --------------------------------------------------------------------

def test_side_by_side_and_split_shapes():
    h, w = 36, 64
    a = np.full((h, w, 3), 0.2, np.float32)
    b = np.full((h, w, 3), 0.7, np.float32)
    labels = (("BO2 Lighting  1.00 s", "BO2"), ("Cycles  9.00 s", "Cycles"))
    sbs = imaging.side_by_side(a, b, labels)
    s = imaging.label_scale(h)
    assert sbs.shape == (h + imaging.CELL_H * s + 4 * s, 2 * w + 2 * s, 3)
    np.testing.assert_allclose(sbs[-1, :w], 0.2)
    np.testing.assert_allclose(sbs[-1, -w:], 0.7)
    split = imaging.split_view(a, b, labels)
    assert split.shape == (h, w, 3)
    assert split[-1, 2, 0] == pytest.approx(0.2) and split[-1, -3, 0] == pytest.approx(0.7)
    assert split[-1, w // 2, 0] > 0.9  # the divider
    assert (split[:12] != split[-1]).any()  # labels drawn at the top
    row = imaging.panels([a, b, a * 2], [*labels, ("third",)])
    assert row.shape == (h + imaging.CELL_H * s + 4 * s, 3 * w + 4 * s, 3)
    np.testing.assert_allclose(row[-1, w + 2 * s:2 * w + 2 * s], 0.7)
    np.testing.assert_allclose(row[-1, -w:], 0.4)
    np.testing.assert_allclose(row[-1, w:w + 2 * s], 0.11)  # the gaps


def test_heat_map_layout():
    diff = np.linspace(0, 0.2, 64 * 36).reshape(36, 64)
    img = imaging.heat_map(diff, 0.1, "caption", "footer")
    assert img.shape[0] > 36 and img.shape[1] >= 64 and img.shape[2] == 3
    x0 = (img.shape[1] - 64) // 2
    np.testing.assert_allclose(img[:36, x0:x0 + 64], imaging.colormap(diff / 0.1), atol=1e-6)
    assert img.min() >= 0 and img.max() <= 1


def test_label_scale():
    assert imaging.label_scale(36) == 1 and imaging.label_scale(1080) == 6


def test_write_png_round_trip(tmp_path):
    rgb = (RNG.random((5, 7, 3)) * 255).astype(np.uint8)
    path = tmp_path / "x.png"
    imaging.write_png(path, rgb)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert struct.unpack(">IIBBBBB", data[16:29]) == (7, 5, 8, 2, 0, 0, 0)
    start = data.index(b"IDAT")
    length = struct.unpack(">I", data[start - 4:start])[0]
    raw = np.frombuffer(zlib.decompress(data[start + 4:start + 4 + length]), np.uint8)
    raw = raw.reshape(5, 1 + 7 * 3)
    assert (raw[:, 0] == 2).all()  # filter type 2, "Up": Raw(x) = Up(x) + Prior(x) mod 256
    rows = np.cumsum(raw[:, 1:].astype(np.int64), 0) % 256
    np.testing.assert_array_equal(rows.reshape(5, 7, 3), rgb)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.png"]  # no partial file left


def test_to_uint8_rounds_and_clips():
    np.testing.assert_array_equal(imaging.to_uint8(np.array([-1, 0.5, 1.2, np.nan])),
                                  [0, 128, 255, 0])
