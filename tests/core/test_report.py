"""The look-dev review's core: FLIP through NVIDIA's implementation checked against values worked
out by hand from the paper, the RGBE and PNG encodings read back by readers not written for them,
and the page's data (ranking, failing scenes, escaping)."""

import io
import json
import math
import re

import numpy as np
import pytest
from rgbe import read_rgbe

from bo2_lighting.addon.core.review import flip, imaging, report

needs_flip = pytest.mark.skipif(flip.unavailable() is not None, reason="no flip-evaluator")

# ---------------------------------------------------------------------------------------------
# LDR-FLIP of two uniform images, by hand (Andersson et al. 2020, section 4.1 and Eq. 2-4).
# In a uniform image the CSF filters (normalized) change nothing and the feature detectors see
# no edge or point, so FLIP = the colour error: HyAB distance of the Hunt-adjusted L*a*b*
# colours, to the power q_c = 0.7, remapped with p_c = 0.4, p_t = 0.95 and the largest
# difference c_max, that between pure green and pure blue.

_SRGB_TO_XYZ = np.array([[0.4124, 0.3576, 0.1805],
                         [0.2126, 0.7152, 0.0722],
                         [0.0193, 0.1192, 0.9505]])  # IEC 61966-2-1, D65


def _lab(linear_rgb):
    white = _SRGB_TO_XYZ @ np.ones(3)
    t = (_SRGB_TO_XYZ @ np.asarray(linear_rgb, float)) / white
    d = 6 / 29
    f = np.where(t > d ** 3, np.cbrt(t), t / (3 * d * d) + 4 / 29)
    lum = 116 * f[1] - 16
    return np.array([lum, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _hunt(lab):
    return np.array([lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]])


def _hyab(x, y):
    return abs(x[0] - y[0]) + math.hypot(x[1] - y[1], x[2] - y[2])


def _srgb_decode(v):
    v = np.asarray(v, float)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def hand_flip_uniform(a, b):
    """LDR-FLIP of two uniform sRGB-encoded colours a, b (3,)."""
    qc, pc, pt = 0.7, 0.4, 0.95
    cmax = _hyab(_hunt(_lab([0, 1, 0])), _hunt(_lab([0, 0, 1]))) ** qc
    e = _hyab(_hunt(_lab(_srgb_decode(a))), _hunt(_lab(_srgb_decode(b)))) ** qc
    if e < pc * cmax:
        return pt / (pc * cmax) * e
    return pt + (e - pc * cmax) / (cmax - pc * cmax) * (1 - pt)


def uniform(colour, shape=(48, 64)):
    return np.broadcast_to(np.asarray(colour, np.float32), (*shape, 3)).copy()


@needs_flip
def test_identical_images_have_no_error():
    rng = np.random.default_rng(3)
    image = rng.random((40, 56, 3), dtype=np.float32)
    for hdr in (False, True):
        error, mean = flip.evaluate(image * (4 if hdr else 1), image * (4 if hdr else 1), hdr)
        assert mean == 0.0 and error.shape == (40, 56) and not error.any()


@needs_flip
@pytest.mark.parametrize("a, b", [
    ((0.5, 0.5, 0.5), (0.55, 0.5, 0.5)),  # a small shift of red: below p_c c_max
    ((0.2, 0.4, 0.6), (0.2, 0.4, 0.9)),
    ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),   # c_max itself: error 1
    ((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)),
])
def test_uniform_colours_match_the_paper_by_hand(a, b):
    expected = hand_flip_uniform(np.array(a), np.array(b))
    error, mean = flip.evaluate(uniform(a), uniform(b))
    assert mean == pytest.approx(expected, abs=1e-4)  # 2.3e-5 at most, float32
    assert np.ptp(error) < 1e-4  # the same everywhere, borders included


@needs_flip
def test_a_shifted_edge_errs_only_where_it_moved():
    """A vertical edge moved 4 pixels right: errors near the edge only, and row 0 at the top
    (the map is not flipped)."""
    ref = np.zeros((64, 96, 3), np.float32)
    ref[:, 40:] = 0.8
    test = np.zeros_like(ref)
    test[:, 44:] = 0.8
    test[:8] = ref[:8]  # the top rows unchanged
    error, mean = flip.evaluate(ref, test)
    columns = error[32].nonzero()[0]
    assert 0 < mean < 0.2
    assert columns.min() >= 40 - 12 and columns.max() <= 44 + 12  # within the filters' reach
    assert error[32, 42] > 0.5  # where the colour changed
    assert error[0, 60:].max() == 0.0 and error[:, :20].max() == 0.0


@needs_flip
def test_larger_differences_give_larger_errors():
    ref = uniform((0.3, 0.3, 0.3))
    means = [flip.evaluate(ref, uniform((0.3 + d, 0.3, 0.3)))[1] for d in (0.02, 0.08, 0.3)]
    assert means == sorted(means) and means[0] > 0
    lin = ref ** 2.2
    hdr = [flip.evaluate(lin, lin * k, hdr=True)[1] for k in (1.1, 1.5, 4.0)]
    assert hdr == sorted(hdr) and hdr[0] > 0


@needs_flip
@needs_flip
def test_hdr_flip_of_a_black_reference_is_undefined():
    """The implementation ends the process for a reference this dark: it is not called."""
    for black in (0.0, 1e-7):
        ref = uniform((black, black, black))
        assert flip.evaluate(ref, ref + 0.5, hdr=True) == (None, None)
    assert flip.evaluate(uniform((0, 0, 0)), uniform((0.5, 0.5, 0.5)))[1] > 0.5  # LDR is


@needs_flip
def test_colour_map_and_bad_shapes():
    rgb, mean = flip.evaluate(uniform((0.2, 0.2, 0.2)), uniform((0.8, 0.2, 0.2)), colour=True)
    assert rgb.shape == (48, 64, 3) and 0 <= rgb.min() and rgb.max() <= 1 and mean > 0.3
    with pytest.raises(ValueError, match="one shape"):
        flip.evaluate(uniform((0, 0, 0)), uniform((0, 0, 0), (8, 8)))
    nan = uniform((0.5, 0.5, 0.5))
    nan[0, 0] = np.nan  # NaN counts as 0, no exception, no NaN mean
    assert math.isfinite(flip.evaluate(nan, uniform((0.5, 0.5, 0.5)))[1])


# ---------------------------------------------------------------------------------------------
# Encodings


def test_rgbe_read_back_by_a_radiance_reader(tmp_path):
    rng = np.random.default_rng(5)
    linear = (rng.random((12, 20, 3)) * np.logspace(-4, 4, 20)[None, :, None]).astype(np.float32)
    linear[0, 0] = 0.0
    linear[0, 1] = (-1.0, np.nan, 2.0)
    pixels = report.rgbe(linear)
    path = tmp_path / "x.hdr"
    path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 12 +X 20\n" + pixels.tobytes())
    back = read_rgbe(path)  # m 2^(E - 136), as Blender reads it
    assert back.shape == (12, 20, 3)
    assert np.all(back[0, 0] == 0)
    assert back[0, 1, 0] == 0 and back[0, 1, 1] == 0 and back[0, 1, 2] == pytest.approx(2.0)
    top = linear[1:].max(-1, keepdims=True)
    assert np.all(np.abs(back[1:] - linear[1:]) <= top / 128)  # one unit of the mantissa


def test_png_read_back_by_pillow():
    pil = pytest.importorskip("PIL.Image")
    rng = np.random.default_rng(7)
    for channels in (3, 4):
        px = rng.integers(0, 256, (9, 13, channels), dtype=np.uint8)
        image = pil.open(io.BytesIO(imaging.png_bytes(px)))
        assert image.mode == ("RGB" if channels == 3 else "RGBA")
        assert np.array_equal(np.asarray(image), px)


def test_rgbe_stack_and_links(tmp_path):
    e = report.rgbe(np.array([[[0.5, 0.25, 2.0]]], np.float32))
    stack = report.rgbe_stack(np.array([[[0.5, 0.25, 2.0]]], np.float32))
    assert stack.shape == (2, 1, 3) and np.array_equal(stack[0, 0], e[0, 0, :3])
    assert np.all(stack[1, 0] == e[0, 0, 3])
    page = tmp_path / "review"
    assert report.href(tmp_path / "a b#1" / "shot:01.exr", page) == "../a%20b%231/shot%3A01.exr"
    assert report.href(page / "scenes" / "x" / "bo2.exr", page) == "scenes/x/bo2.exr"


def test_shrink_and_slug():
    image = np.arange(4 * 6 * 3, dtype=np.float32).reshape(4, 6, 3)
    small = report.shrink(image, 3)
    assert small.shape == (2, 3, 3)
    assert small[0, 0, 0] == pytest.approx(image[:2, :2, 0].mean())
    assert report.shrink(image, 6) is image
    assert report.shrink(np.zeros((2, 900, 3), np.float32), 3).shape == (1, 450, 3)  # not 0
    taken = set()
    assert [report.slug(n, taken) for n in ("a b", "a_b", "A B", "../x", "")] == [
        "a_b", "a_b_2", "A_B_3", "x", "scene"]


# ---------------------------------------------------------------------------------------------
# The page's data


def entry(tmp_path, name, scale):
    """A scene whose BO2 render is Cycles' times ``scale``."""
    ramp = np.linspace(0.05, 0.9, 32, dtype=np.float32)
    cycles = np.stack([*np.meshgrid(ramp, ramp[:24]), np.full((24, 32), 0.3, np.float32)], -1)
    bo2 = cycles * scale
    passes = {k: {"Combined": (im, np.clip(im, 0, 1) ** (1 / 2.2))}
              for k, im in (("cycles", cycles), ("bo2", bo2))}
    info = {"seconds": {"bo2": 1.0, "cycles": 4.0}, "resolution": [32, 24]}
    return report.analyse_scene(name, passes, info, tmp_path / "scenes" / name, tmp_path,
                                {"bo2": f"scenes/{name}/bo2.exr"})


def page_data(path):
    text = path.read_text()
    found = re.search(r'<script id="report-data" type="application/json">(.*?)</script>', text,
                      re.S)
    return json.loads(found.group(1))


@needs_flip
def test_page_ranks_worst_first_and_puts_failing_scenes_first(tmp_path):
    entries = [entry(tmp_path, n, s) for n, s in (("a", 1.0), ("b", 1.6), ("c", 1.2))]
    meta = {"title": "T", "created": "now", "blender_version": "5.0", "fail_above": None,
            "flip": None, "pending": []}
    data = page_data(report.write_page(tmp_path, entries, meta))
    assert [s["name"] for s in data["scenes"]] == ["b", "c", "a"]
    flips = [s["variants"]["bo2"]["metrics"]["Combined"]["flip_ldr"] for s in data["scenes"]]
    assert flips[2] == 0.0 and flips[0] > flips[1] > 0
    assert json.loads((tmp_path / "report.json").read_text())["scenes"][0]["name"] == "b"
    limit = (flips[0] + flips[1]) / 2  # only b above
    data = page_data(report.write_page(tmp_path, entries, {**meta, "fail_above": limit}))
    assert [s["failing"] for s in data["scenes"]] == [True, False, False]
    assert [e["name"] for e in report.failing(entries, limit)] == ["b"]
    for pic in data["scenes"][0]["variants"]["bo2"]["pictures"].values():
        assert (tmp_path / pic).is_file()  # relative to the page


@needs_flip
def test_page_escapes_names(tmp_path):
    e = entry(tmp_path, "x", 1.1)
    e["name"] = "<!--<script></script><script>alert(1)</script>"
    meta = {"title": "<b>&", "created": "now", "blender_version": "5.0", "fail_above": None,
            "flip": None, "pending": []}
    path = report.write_page(tmp_path, [e], meta)
    text = path.read_text()
    assert "<title>&lt;b&gt;&amp;</title>" in text
    assert "alert(1)</script>" not in text and "<!--" not in text
    assert page_data(path)["scenes"][0]["name"] == e["name"]
