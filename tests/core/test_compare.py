"""Comparison metrics, SSIM and the report.

Independent values:
- PSNR, RMSE and mean relative error of images whose MSE is known in closed form (a constant
  offset d: MSE = d^2, PSNR = -20 log10 d; a +-d checkerboard: the same);
- SSIM: the identity SSIM(x, x) = 1 and symmetry; two constant images, whose variances and
  covariance vanish, SSIM = (2ab + C1) / (a^2 + b^2 + C1) in closed form (Wang et al. 2004,
  eq. 13); a brute-force implementation of eq. 13 here (explicit 2-D Gaussian weights, a loop
  over window positions, weighted moments from their definitions); the window against the
  2-D Gaussian exp(-(x^2 + y^2) / (2 1.5^2)) on 11 x 11 taps, normalized;
"""

import math

import numpy as np
import pytest

from bo2_lighting.addon.core.review import compare

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


# --- the report --------------------------------------------------------------------------------


def test_light_pairs_multiply_cycles_by_its_colour_pass():
    ones = np.ones((2, 3, 3), np.float32)
    bo2 = {"Combined": np.full((2, 3, 4), 0.5, np.float32), "DiffDir": ones * 0.3,
           "GlossDir": ones, "Emit": ones * 0.2}
    cycles = {"Combined": np.full((2, 3, 4), 0.25, np.float32), "DiffDir": ones * 0.5,
              "DiffCol": ones * 0.4, "GlossDir": ones, "Emit": ones * 0.1}
    pairs = compare.light_pairs(bo2, cycles)
    assert list(pairs) == ["Combined", "DiffDir", "Emit"]  # no GlossCol: Glossy not compared
    assert pairs["Combined"][0].shape == (2, 3, 3)
    np.testing.assert_allclose(pairs["DiffDir"][1], 0.2)  # 0.5 x 0.4
    np.testing.assert_allclose(pairs["Emit"][1], 0.1)


def test_data_metrics_where_both_see_geometry():
    geometry = np.array([[True, False], [True, True]])
    a = np.zeros((2, 2, 1), np.float32)
    b = np.array([[[3.0], [100.0]], [[0.0], [4.0]]], np.float32)
    m = compare.data_metrics("Depth", a, b, geometry)
    assert m == {"rmse": pytest.approx(math.sqrt(25 / 3)), "mean_abs_error": pytest.approx(7 / 3),
                 "pixels": 3}
    m = compare.data_metrics("IndexMA", a, b, geometry)
    assert m == {"fraction_equal": pytest.approx(1 / 3), "pixels": 3}


def test_report_and_headline():
    bo2 = {"Combined": np.zeros((4, 4, 4), np.float32)}
    cycles = {"Combined": np.zeros((4, 4, 4), np.float32)}
    cycles["Combined"][0, 0, :3] = 1.0  # Y = 1 at one pixel of 16
    pairs = compare.light_pairs(bo2, cycles)
    display = {name: [np.clip(x, 0, 1) for x in pair] for name, pair in pairs.items()}
    diff, scale_max, high = compare.difference(pairs)
    assert diff.shape == (4, 4) and diff[0, 0] == pytest.approx(1.0)
    # the 99th percentile of fifteen 0s and one 1, linearly interpolated at 0.99 x 15 = 14.85
    assert high == pytest.approx(0.85) and scale_max == 1.0
    info = {"bo2": {"render_seconds": 2.0}, "cycles": {"render_seconds": 30.0}}
    result = compare.report(pairs, display, bo2, cycles, info, {"scene": "S"}, {"a": "b"},
                            label=str.upper)
    assert list(result)[:2] == ["scene", "engines"] and result["speedup"] == 15.0
    assert result["image"]["rmse"] == pytest.approx(math.sqrt(3 / 48))
    assert result["passes"] == {} and result["files"] == {"a": "b"}
    assert compare.headline(result) == ("BO2 2.00 s, Cycles 30.0 s (15.0x); RMSE 0.25, "
                                        f"PSNR {result['image']['psnr_db']:.1f} dB, "
                                        f"SSIM {result['image']['ssim']:.3f}")
