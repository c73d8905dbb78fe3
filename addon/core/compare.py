"""Comparison of two renders of one frame (BO2 Lighting against Cycles): error metrics, SSIM, a
perceptual colour map, a bitmap font and the composed pictures, in NumPy only.

What the module follows, and where from:

- Luminance: the Rec. ITU-R BT.709 weights (0.2126, 0.7152, 0.0722), the primaries of
  Blender's default scene-linear space (Linear Rec.709). On scene-linear RGB they give the
  relative luminance Y; on display-encoded R'G'B' they give the luma Y' (BT.709 eq. 3.2).
- RMSE, PSNR: PSNR = 10 log10(peak^2 / MSE) dB with the peak of the value range (1 for
  display-referred values in [0, 1]); identical images have MSE 0 and PSNR +inf.
- Mean relative error: mean over pixels and channels of |a - b| / (|b| + eps), b the reference
  (Cycles) and eps = 0.01 so that black pixels do not dominate (the "relative MSE" of
  Rousselle, Knaus and Zwicker, "Adaptive sampling and reconstruction using greedy error
  minimization", SIGGRAPH Asia 2011, guards its squared errors the same way).
- SSIM: Z. Wang, A. C. Bovik, H. R. Sheikh and E. P. Simoncelli, "Image quality assessment:
  from error visibility to structural similarity", IEEE TIP 13(4), 2004, eq. 13 with
  C1 = (K1 L)^2, C2 = (K2 L)^2, K1 = 0.01, K2 = 0.03, L the dynamic range, local statistics
  under an 11 x 11 circular-symmetric Gaussian window of standard deviation 1.5 normalized to
  unit sum (their section III.C), population (biased) variances, and the mean SSIM over the
  window positions that lie wholly inside the image (their reference implementation's
  ``filter2(..., 'valid')``). An image smaller than 11 pixels along an axis uses the largest
  odd window that fits (the same Gaussian, truncated).
- Colour map: lightness rising linearly in Oklab (B. Ottosson, "A perceptual color space for
  image processing", 2020, whose matrices are used below) from L = 0.18 to 0.97, hue turning
  from violet through red and orange to yellow, chroma brought back into the sRGB gamut by
  bisection at constant L and hue; the result is sRGB-encoded (IEC 61966-2-1). Equal steps in
  value are near-equal steps in perceived lightness, and the map stays readable in grey.
- Font: 5 x 7 pixel glyphs of our own for printable ASCII (32-126), drawn on a 6 x 8 cell.
- PNG: ISO/IEC 15948, 8-bit RGB, one IDAT chunk, filter type 0 on every row.

Images are (H, W, C) float32 with row 0 at the TOP (the project's convention); display images
hold display-encoded values in [0, 1].
"""

from __future__ import annotations

import math
import os
import struct
import zlib
from pathlib import Path

import numpy as np

REC709_WEIGHTS = np.array([0.2126, 0.7152, 0.0722], np.float32)
RELATIVE_EPS = 0.01
SSIM_SIGMA = 1.5
SSIM_K1, SSIM_K2 = 0.01, 0.03


# ---------------------------------------------------------------------------------------------
# Metrics


def luminance(rgb) -> np.ndarray:
    """Rec. 709 weighted sum of the first three channels.

    rgb:     (..., C >= 3) scene-linear RGB (gives luminance Y) or display-encoded (luma Y')
    returns: (...,) float32
    """
    rgb = np.asarray(rgb, np.float32)
    return rgb[..., 0] * REC709_WEIGHTS[0] + rgb[..., 1] * REC709_WEIGHTS[1] + (
        rgb[..., 2] * REC709_WEIGHTS[2])


def mse(a, b) -> float:
    """Mean squared difference over every element (float64 accumulation).

    a, b:    same shape, any units
    returns: MSE in the units squared
    """
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    return float(np.mean(d * d))


def rmse(a, b) -> float:
    """Root mean squared difference over every element, in the images' units."""
    return math.sqrt(mse(a, b))


def psnr(a, b, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio 10 log10(peak^2 / MSE) in dB; +inf for identical images.

    a, b:    same shape; values in [0, peak] (display-referred for the comparison)
    peak:    largest possible value
    """
    m = mse(a, b)
    return math.inf if m == 0.0 else 10.0 * math.log10(peak * peak / m)


def mean_relative_error(test, reference, eps: float = RELATIVE_EPS) -> float:
    """Mean of |test - reference| / (|reference| + eps) over every element (dimensionless).

    test, reference: same shape, scene-linear values (reference: Cycles)
    eps:             guard against dividing by black pixels
    """
    t = np.asarray(test, np.float64)
    r = np.asarray(reference, np.float64)
    return float(np.mean(np.abs(t - r) / (np.abs(r) + eps)))


def gaussian_window(sigma: float = SSIM_SIGMA, size: int = 11) -> np.ndarray:
    """The 1-D factor of SSIM's separable Gaussian window, normalized to unit sum.

    sigma:   standard deviation in pixels
    size:    odd number of taps (11 for Wang et al.'s window)
    returns: (size,) float64; the 2-D window is its outer product with itself
    """
    x = np.arange(size, dtype=np.float64) - (size - 1) / 2
    w = np.exp(-0.5 * (x / sigma) ** 2)
    return w / w.sum()


def _filter_valid(image: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Correlate a 2-D image with the separable window w x w, keeping only the positions where
    the window lies inside the image: (H, W) -> (H - n + 1, W - n + 1), n = len(w)."""
    n = len(w)
    h, wd = image.shape
    rows = sum(w[i] * image[i:h - n + 1 + i] for i in range(n))
    return sum(w[j] * rows[:, j:wd - n + 1 + j] for j in range(n))


def ssim_map(x, y, data_range: float = 1.0, sigma: float = SSIM_SIGMA, size: int = 11,
             k1: float = SSIM_K1, k2: float = SSIM_K2) -> np.ndarray:
    """Local SSIM of two greyscale images (Wang et al. 2004, eq. 13).

    x, y:       (H, W) images on the same scale (display-referred luma for the comparison)
    data_range: L, the dynamic range of the values (1 for values in [0, 1])
    sigma:      standard deviation of the Gaussian window in pixels
    size:       window size, odd; reduced to the largest odd size that fits the image
    returns:    (H - n + 1, W - n + 1) float64 SSIM per window position, n the window size
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    if x.shape != y.shape or x.ndim != 2:
        raise ValueError(f"SSIM needs two 2-D images of one shape, got {x.shape} and {y.shape}")
    n = min(size, *x.shape)
    n -= 1 - n % 2  # odd
    w = gaussian_window(sigma, n)
    c1, c2 = (k1 * data_range) ** 2, (k2 * data_range) ** 2
    mx, my = _filter_valid(x, w), _filter_valid(y, w)
    sxx = _filter_valid(x * x, w) - mx * mx
    syy = _filter_valid(y * y, w) - my * my
    sxy = _filter_valid(x * y, w) - mx * my
    return ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))


def ssim(x, y, data_range: float = 1.0, sigma: float = SSIM_SIGMA) -> float:
    """Mean SSIM (MSSIM, Wang et al. 2004 eq. 17) of two greyscale images; 1 when identical."""
    return float(np.mean(ssim_map(x, y, data_range, sigma)))


def image_metrics(linear_test, linear_ref, display_test, display_ref) -> dict:
    """The comparison's four numbers for one image or pass.

    linear_*:  (H, W, 3) scene-linear RGB (test: BO2 Lighting, ref: Cycles)
    display_*: (H, W, 3) the same through the view transform, display-encoded in [0, 1]
    returns:   {"rmse": scene-linear RGB, "mean_relative_error": scene-linear RGB,
                "psnr_db": display RGB (None when identical), "ssim": display luma}
    """
    p = psnr(display_test, display_ref)
    return {
        "rmse": rmse(linear_test, linear_ref),
        "mean_relative_error": mean_relative_error(linear_test, linear_ref),
        "psnr_db": None if math.isinf(p) else p,
        "ssim": ssim(luminance(display_test), luminance(display_ref)),
    }


def nice_ceil(x: float) -> float:
    """The smallest of 1, 1.5, 2, 2.5, 3, 4, 5, 6, 8 times a power of ten that is >= x (x > 0):
    the end of a colour scale."""
    x = max(float(x), 1e-12)
    e = math.floor(math.log10(x))
    for m in (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0):
        v = float(f"{m * 10.0 ** e:.12g}")
        if v >= x * (1 - 1e-9):
            return v
    return 10.0 ** (e + 1)


# ---------------------------------------------------------------------------------------------
# Colour map

# Ottosson 2020: Oklab -> non-linear LMS, and LMS -> linear sRGB.
_OKLAB_TO_LMS = np.array([[1.0, 0.3963377774, 0.2158037573],
                          [1.0, -0.1055613458, -0.0638541728],
                          [1.0, -0.0894841775, -1.2914855480]])
_LMS_TO_SRGB = np.array([[4.0767416621, -3.3077115913, 0.2309699292],
                         [-1.2684380046, 2.6097574011, -0.3413193965],
                         [-0.0041960863, -0.7034186147, 1.7076147010]])


def oklab_to_linear_srgb(lab) -> np.ndarray:
    """Oklab (L, a, b) to linear sRGB (Ottosson 2020); (..., 3) -> (..., 3) float64, not
    clipped (out-of-gamut colours have components outside [0, 1])."""
    lms = np.asarray(lab, np.float64) @ _OKLAB_TO_LMS.T
    return (lms ** 3) @ _LMS_TO_SRGB.T


def _srgb_encode(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.maximum(x, 0.0031308) ** (1 / 2.4)
                    - 0.055)


def _build_colormap(n: int = 256) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)
    lightness = 0.18 + 0.79 * t
    hue = np.radians(300.0 + 160.0 * t)  # violet -> magenta -> red -> orange -> yellow
    chroma = 0.17 * np.sin(np.pi * np.clip(t * 1.05, 0, 1)) ** 0.7 + 0.02 * (1 - t)
    lo, hi = np.zeros(n), np.ones(n)  # bisection on the chroma factor that stays in gamut
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        c = chroma * mid
        rgb = oklab_to_linear_srgb(np.stack([lightness, c * np.cos(hue), c * np.sin(hue)], -1))
        inside = np.all((rgb >= -1e-9) & (rgb <= 1 + 1e-9), -1)
        lo, hi = np.where(inside, mid, lo), np.where(inside, hi, mid)
    c = chroma * lo
    rgb = oklab_to_linear_srgb(np.stack([lightness, c * np.cos(hue), c * np.sin(hue)], -1))
    return _srgb_encode(rgb).astype(np.float32)


COLORMAP = _build_colormap()  # (256, 3) sRGB-encoded, dark violet to pale yellow


def colormap(values) -> np.ndarray:
    """Map values in [0, 1] (clipped; NaN -> 0) to the perceptual colour map.

    values:  any shape
    returns: shape + (3,) float32 sRGB-encoded display colours (linearly interpolated LUT)
    """
    v = np.nan_to_num(np.asarray(values, np.float64), nan=0.0)
    x = np.clip(v, 0.0, 1.0) * (len(COLORMAP) - 1)
    i = np.minimum(x.astype(np.int64), len(COLORMAP) - 2)
    f = (x - i)[..., None].astype(np.float32)
    return COLORMAP[i] * (1 - f) + COLORMAP[i + 1] * f


# ---------------------------------------------------------------------------------------------
# Bitmap font: one entry per printable ASCII character, 7 rows of 5 pixels ('#' on), top first.

GLYPHS = {
    " ": "..... ..... ..... ..... ..... ..... .....",
    "!": "..#.. ..#.. ..#.. ..#.. ..#.. ..... ..#..",
    '"': ".#.#. .#.#. ..... ..... ..... ..... .....",
    "#": ".#.#. .#.#. ##### .#.#. ##### .#.#. .#.#.",
    "$": "..#.. .#### #.#.. .###. ..#.# ####. ..#..",
    "%": "##... ##..# ...#. ..#.. .#... #..## ...##",
    "&": ".##.. #..#. #.#.. .#... #.#.# #..#. .##.#",
    "'": "..#.. ..#.. ..... ..... ..... ..... .....",
    "(": "...#. ..#.. .#... .#... .#... ..#.. ...#.",
    ")": ".#... ..#.. ...#. ...#. ...#. ..#.. .#...",
    "*": "..... ..#.. #.#.# .###. #.#.# ..#.. .....",
    "+": "..... ..#.. ..#.. ##### ..#.. ..#.. .....",
    ",": "..... ..... ..... ..... .##.. ..#.. .#...",
    "-": "..... ..... ..... ##### ..... ..... .....",
    ".": "..... ..... ..... ..... ..... .##.. .##..",
    "/": "..... ....# ...#. ..#.. .#... #.... .....",
    "0": ".###. #...# #..## #.#.# ##..# #...# .###.",
    "1": "..#.. .##.. ..#.. ..#.. ..#.. ..#.. .###.",
    "2": ".###. #...# ....# ...#. ..#.. .#... #####",
    "3": "####. ....# ....# .###. ....# ....# ####.",
    "4": "...#. ..##. .#.#. #..#. ##### ...#. ...#.",
    "5": "##### #.... ####. ....# ....# #...# .###.",
    "6": "..##. .#... #.... ####. #...# #...# .###.",
    "7": "##### ....# ...#. ..#.. .#... .#... .#...",
    "8": ".###. #...# #...# .###. #...# #...# .###.",
    "9": ".###. #...# #...# .#### ....# ...#. .##..",
    ":": "..... .##.. .##.. ..... .##.. .##.. .....",
    ";": "..... .##.. .##.. ..... .##.. ..#.. .#...",
    "<": "...#. ..#.. .#... #.... .#... ..#.. ...#.",
    "=": "..... ..... ##### ..... ##### ..... .....",
    ">": ".#... ..#.. ...#. ....# ...#. ..#.. .#...",
    "?": ".###. #...# ....# ...#. ..#.. ..... ..#..",
    "@": ".###. #...# #.### #.#.# #.### #.... .####",
    "A": ".###. #...# #...# ##### #...# #...# #...#",
    "B": "####. #...# #...# ####. #...# #...# ####.",
    "C": ".###. #...# #.... #.... #.... #...# .###.",
    "D": "####. #...# #...# #...# #...# #...# ####.",
    "E": "##### #.... #.... ####. #.... #.... #####",
    "F": "##### #.... #.... ####. #.... #.... #....",
    "G": ".###. #...# #.... #.### #...# #...# .####",
    "H": "#...# #...# #...# ##### #...# #...# #...#",
    "I": ".###. ..#.. ..#.. ..#.. ..#.. ..#.. .###.",
    "J": "..### ...#. ...#. ...#. ...#. #..#. .##..",
    "K": "#...# #..#. #.#.. ##... #.#.. #..#. #...#",
    "L": "#.... #.... #.... #.... #.... #.... #####",
    "M": "#...# ##.## #.#.# #.#.# #...# #...# #...#",
    "N": "#...# #...# ##..# #.#.# #..## #...# #...#",
    "O": ".###. #...# #...# #...# #...# #...# .###.",
    "P": "####. #...# #...# ####. #.... #.... #....",
    "Q": ".###. #...# #...# #...# #.#.# #..#. .##.#",
    "R": "####. #...# #...# ####. #.#.. #..#. #...#",
    "S": ".#### #.... #.... .###. ....# ....# ####.",
    "T": "##### ..#.. ..#.. ..#.. ..#.. ..#.. ..#..",
    "U": "#...# #...# #...# #...# #...# #...# .###.",
    "V": "#...# #...# #...# #...# #...# .#.#. ..#..",
    "W": "#...# #...# #...# #.#.# #.#.# #.#.# .#.#.",
    "X": "#...# #...# .#.#. ..#.. .#.#. #...# #...#",
    "Y": "#...# #...# .#.#. ..#.. ..#.. ..#.. ..#..",
    "Z": "##### ....# ...#. ..#.. .#... #.... #####",
    "[": ".###. .#... .#... .#... .#... .#... .###.",
    "\\": "..... #.... .#... ..#.. ...#. ....# .....",
    "]": ".###. ...#. ...#. ...#. ...#. ...#. .###.",
    "^": "..#.. .#.#. #...# ..... ..... ..... .....",
    "_": "..... ..... ..... ..... ..... ..... #####",
    "`": ".#... ..#.. ..... ..... ..... ..... .....",
    "a": "..... ..... .###. ....# .#### #...# .####",
    "b": "#.... #.... #.##. ##..# #...# #...# ####.",
    "c": "..... ..... .###. #.... #.... #...# .###.",
    "d": "....# ....# .##.# #..## #...# #...# .####",
    "e": "..... ..... .###. #...# ##### #.... .###.",
    "f": "..##. .#..# .#... ###.. .#... .#... .#...",
    "g": "..... .#### #...# #...# .#### ....# .###.",
    "h": "#.... #.... #.##. ##..# #...# #...# #...#",
    "i": "..#.. ..... .##.. ..#.. ..#.. ..#.. .###.",
    "j": "...#. ..... ..##. ...#. ...#. #..#. .##..",
    "k": "#.... #.... #..#. #.#.. ##... #.#.. #..#.",
    "l": ".##.. ..#.. ..#.. ..#.. ..#.. ..#.. .###.",
    "m": "..... ..... ##.#. #.#.# #.#.# #...# #...#",
    "n": "..... ..... #.##. ##..# #...# #...# #...#",
    "o": "..... ..... .###. #...# #...# #...# .###.",
    "p": "..... ####. #...# #...# ####. #.... #....",
    "q": "..... .##.# #..## #...# .#### ....# ....#",
    "r": "..... ..... #.##. ##..# #.... #.... #....",
    "s": "..... ..... .###. #.... .###. ....# ####.",
    "t": ".#... .#... ###.. .#... .#... .#..# ..##.",
    "u": "..... ..... #...# #...# #...# #..## .##.#",
    "v": "..... ..... #...# #...# #...# .#.#. ..#..",
    "w": "..... ..... #...# #...# #.#.# #.#.# .#.#.",
    "x": "..... ..... #...# .#.#. ..#.. .#.#. #...#",
    "y": "..... #...# #...# #...# .#### ....# .###.",
    "z": "..... ..... ##### ...#. ..#.. .#... #####",
    "{": "...#. ..#.. ..#.. .#... ..#.. ..#.. ...#.",
    "|": "..#.. ..#.. ..#.. ..#.. ..#.. ..#.. ..#..",
    "}": ".#... ..#.. ..#.. ...#. ..#.. ..#.. .#...",
    "~": "..... ..... .#... #.#.# ...#. ..... .....",
}
GLYPH_W, GLYPH_H = 5, 7
CELL_W, CELL_H = 6, 8  # one pixel of spacing to the right and below

# (95, 7, 5) bool, index ord(c) - 32
_FONT = np.array([[[p == "#" for p in row] for row in GLYPHS[chr(c)].split()]
                  for c in range(32, 127)], bool)


def text_size(text: str, scale: int = 1) -> tuple[int, int]:
    """(width, height) in pixels of one line of ``text``: cells of 6 x 8 pixels times scale,
    less the spacing after the last character."""
    return max(0, len(text) * CELL_W - 1) * scale, GLYPH_H * scale


def text_mask(text: str, scale: int = 1) -> np.ndarray:
    """One line of text as a coverage mask.

    text:    printable ASCII (other characters are drawn as '?')
    scale:   integer magnification (each font pixel becomes scale x scale pixels)
    returns: (7 scale, (6 len - 1) scale) bool, row 0 at the top
    """
    if not text:
        return np.zeros((GLYPH_H * scale, 0), bool)
    codes = np.array([ord(c) if 32 <= ord(c) < 127 else ord("?") for c in text]) - 32
    glyphs = np.zeros((len(text), GLYPH_H, CELL_W), bool)
    glyphs[:, :, :GLYPH_W] = _FONT[codes]
    line = glyphs.transpose(1, 0, 2).reshape(GLYPH_H, -1)[:, :-1]
    return np.repeat(np.repeat(line, scale, 0), scale, 1)


def draw_text(image: np.ndarray, text: str, x: int, y: int, scale: int = 1,
              color=(1.0, 1.0, 1.0), box=None, pad: int = 0) -> None:
    """Draw ``text`` in place with its top-left corner at pixel (x, y), clipped to the image.

    image: (H, W, 3) float32 display values, modified
    box:   (r, g, b, alpha) of a rectangle drawn behind the text, ``pad`` pixels wider on every
           side, or None
    """
    mask = text_mask(text, scale)
    h, w = image.shape[:2]
    if box is not None:
        bx0, by0 = max(0, x - pad), max(0, y - pad)
        bx1, by1 = min(w, x + mask.shape[1] + pad), min(h, y + mask.shape[0] + pad)
        if bx1 > bx0 and by1 > by0:
            alpha = float(box[3])
            region = image[by0:by1, bx0:bx1]
            region *= 1 - alpha
            region += alpha * np.asarray(box[:3], np.float32)
    x0, y0 = max(0, x), max(0, y)
    x1, y1 = min(w, x + mask.shape[1]), min(h, y + mask.shape[0])
    if x1 <= x0 or y1 <= y0:
        return
    m = mask[y0 - y:y1 - y, x0 - x:x1 - x]
    image[y0:y1, x0:x1][m] = np.asarray(color, np.float32)


def label_scale(height: int) -> int:
    """Font magnification for an image ``height`` pixels tall: 1 up to 269 px, 6 at 1080 px."""
    return max(1, round(height / 180))


def format_seconds(seconds: float) -> str:
    """A render time for a label: 0.84 s, 12.3 s, 2 min 05 s."""
    if seconds < 10:
        return f"{seconds:.2f} s"
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, rest = divmod(round(seconds), 60)
    return f"{minutes} min {rest:02d} s"


def _fit_label(labels: tuple[str, ...], width: int, scale: int) -> str:
    """The first of ``labels`` (longest first) whose text fits in ``width`` pixels."""
    return next((t for t in labels if text_size(t, scale)[0] <= width), labels[-1])


# ---------------------------------------------------------------------------------------------
# Composition (display space)

_BACKGROUND = (0.11, 0.11, 0.11)
_TEXT = (0.95, 0.95, 0.95)


def side_by_side(left: np.ndarray, right: np.ndarray, labels: tuple, scale: int | None = None
                 ) -> np.ndarray:
    """Two images next to each other under a caption strip.

    left, right: (H, W, 3) display images of one shape (BO2 Lighting, Cycles)
    labels:      (left labels, right labels), each a tuple of texts from longest to shortest;
                 the longest that fits above its image is drawn
    returns:     (H + strip, 2 W + gap, 3) float32, strip = 8 scale + 2 pad, gap = 2 scale
    """
    h, w = left.shape[:2]
    s = scale or label_scale(h)
    pad, gap = 2 * s, 2 * s
    strip = CELL_H * s + 2 * pad
    out = np.empty((h + strip, 2 * w + gap, 3), np.float32)
    out[:] = _BACKGROUND
    out[strip:, :w] = left[..., :3]
    out[strip:, w + gap:] = right[..., :3]
    for x0, texts in ((0, labels[0]), (w + gap, labels[1])):
        draw_text(out, _fit_label(texts, w - 2 * pad, s), x0 + pad, pad + s // 2, s, _TEXT)
    return out


def split_view(left: np.ndarray, right: np.ndarray, labels: tuple, scale: int | None = None
               ) -> np.ndarray:
    """The left half of one image and the right half of the other, a thin light divider between
    them and the labels in translucent boxes at the top corners.

    left, right: (H, W, 3) display images of one shape
    labels:      as for ``side_by_side``
    returns:     (H, W, 3) float32
    """
    h, w = left.shape[:2]
    s = scale or label_scale(h)
    half = w // 2
    out = np.concatenate([left[:, :half, :3], right[:, half:, :3]], 1).astype(np.float32)
    d = max(1, s // 2)  # divider width
    out[:, half - d // 2:half - d // 2 + d] = 0.92
    pad = s
    box = (0.0, 0.0, 0.0, 0.55)
    lt = _fit_label(labels[0], half - 3 * pad, s)
    draw_text(out, lt, 2 * pad, 2 * pad, s, _TEXT, box, pad)
    rt = _fit_label(labels[1], w - half - 3 * pad, s)
    draw_text(out, rt, w - 2 * pad - text_size(rt, s)[0], 2 * pad, s, _TEXT, box, pad)
    return out


def _tick_text(v: float) -> str:
    return f"{v:.4g}"


def heat_map(difference: np.ndarray, scale_max: float, caption: str, footer: str = "",
             scale: int | None = None) -> np.ndarray:
    """A difference image in the colour map with a labelled colour scale bar below it.

    difference: (H, W) non-negative values (any units)
    scale_max:  value shown in the brightest colour (larger values are clipped to it)
    caption:    text above the bar (what is shown)
    footer:     optional second line below the tick labels (e.g. the headline metrics)
    returns:    (H + legend, max(W, legend width), 3) float32 display image
    """
    h, w = difference.shape
    s = scale or label_scale(h)
    pad = 3 * s
    ticks = [0.0, scale_max / 2, scale_max]
    texts = [_tick_text(t) for t in ticks]
    lines = [caption] + ([footer] if footer else [])
    need = max(text_size(t, s)[0] for t in lines) + 2 * pad
    need = max(need, sum(text_size(t, s)[0] for t in texts) + 4 * pad + 4 * CELL_W * s)
    width = max(w, need)
    bar_h = 3 * CELL_H * s // 2
    legend = pad + CELL_H * s + s + bar_h + 3 * s + CELL_H * s + pad
    legend += (CELL_H * s + 2 * s) if footer else 0
    out = np.empty((h + legend, width, 3), np.float32)
    out[:] = _BACKGROUND
    x_img = (width - w) // 2
    out[:h, x_img:x_img + w] = colormap(np.asarray(difference, np.float64) / scale_max)
    y = h + pad
    draw_text(out, caption, pad, y, s, _TEXT)
    y += CELL_H * s + s
    bx0, bx1 = pad + CELL_W * s, width - pad - CELL_W * s
    out[y:y + bar_h, bx0:bx1] = colormap(np.linspace(0.0, 1.0, bx1 - bx0))[None]
    y += bar_h
    for t, text in zip(ticks, texts, strict=True):
        x = bx0 + round(t / scale_max * (bx1 - bx0 - 1))
        out[y:y + 2 * s, max(0, x - s // 2):x - s // 2 + s] = _TEXT
        tw = text_size(text, s)[0]
        tx = min(max(x - tw // 2, pad), width - pad - tw)
        draw_text(out, text, tx, y + 3 * s, s, _TEXT)
    if footer:
        draw_text(out, footer, pad, y + 3 * s + CELL_H * s + 2 * s, s, _TEXT)
    return out


# ---------------------------------------------------------------------------------------------
# Output


def to_uint8(image: np.ndarray) -> np.ndarray:
    """Display values in [0, 1] (clipped, NaN -> 0) to 8-bit, rounded: (..., C) uint8."""
    v = np.nan_to_num(np.asarray(image, np.float32), nan=0.0)
    return np.round(np.clip(v, 0.0, 1.0) * 255.0).astype(np.uint8)


def write_png(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write an 8-bit RGB PNG (ISO/IEC 15948), atomically (a temporary file, then renamed).

    path:  destination
    image: (H, W, 3) uint8, or float display values in [0, 1]; row 0 at the top
    """
    rgb = image if image.dtype == np.uint8 else to_uint8(image)
    h, w = rgb.shape[:2]
    rows = np.concatenate([np.zeros((h, 1), np.uint8), rgb[..., :3].reshape(h, w * 3)], 1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(np.ascontiguousarray(rows).tobytes(), 6))
            + chunk(b"IEND", b""))
    path = Path(path)
    tmp = path.with_name(f".{path.name}.partial")
    tmp.write_bytes(data)
    os.replace(tmp, path)
