"""Pictures of a comparison, in NumPy only: a perceptual colour map, a bitmap font, the composed
pictures (side by side, split, heat map with its scale bar) and a PNG writer.

- Colour map: lightness rising linearly in Oklab (B. Ottosson, "A perceptual color space for
  image processing", 2020, whose matrices are used below) from L = 0.18 to 0.97, hue turning
  from violet through red and orange to yellow, chroma brought back into the sRGB gamut by
  bisection at constant L and hue; the result is sRGB-encoded (IEC 61966-2-1). Equal steps in
  value are near-equal steps in perceived lightness, and the map stays readable in grey.
- Font: 5 x 7 pixel glyphs of our own for printable ASCII (32-126), drawn on a 6 x 8 cell.
- PNG: ISO/IEC 15948, 8-bit RGB, one IDAT chunk, filter type 0 on every row.

Images are (H, W, C) float32 with row 0 at the TOP (the project's convention), holding
display-encoded values in [0, 1].
"""

from __future__ import annotations

import os
import struct
import zlib

import numpy as np

from ..formulas.texture import linear_to_srgb
from ..system.atomic import write_bytes

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
    return linear_to_srgb(np.clip(rgb, 0.0, 1.0))


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



def _fit_label(labels: tuple[str, ...], width: int, scale: int) -> str:
    """The first of ``labels`` (longest first) whose text fits in ``width`` pixels."""
    return next((t for t in labels if text_size(t, scale)[0] <= width), labels[-1])


# ---------------------------------------------------------------------------------------------
# Composition (display space)

_BACKGROUND = (0.11, 0.11, 0.11)
_TEXT = (0.95, 0.95, 0.95)


def side_by_side(left: np.ndarray, right: np.ndarray, labels: tuple, scale: int | None = None
                 ) -> np.ndarray:
    """Two images next to each other under a caption strip (``panels``).

    left, right: (H, W, 3) display images of one shape (BO2 Lighting, Cycles)
    labels:      (left labels, right labels), each a tuple of texts from longest to shortest;
                 the longest that fits above its image is drawn
    returns:     (H + strip, 2 W + gap, 3) float32, strip = 8 scale + 2 pad, gap = 2 scale
    """
    return panels([left, right], labels, scale)


def panels(images: list[np.ndarray], labels, scale: int | None = None) -> np.ndarray:
    """K images of one shape (H, W, 3) in a row, each under its caption (labels: K tuples of
    texts, longest first): (H + strip, K W + (K - 1) gap, 3) float32, as ``side_by_side``."""
    h, w = images[0].shape[:2]
    s = scale or label_scale(h)
    pad, gap = 2 * s, 2 * s
    strip = CELL_H * s + 2 * pad
    out = np.empty((h + strip, len(images) * (w + gap) - gap, 3), np.float32)
    out[:] = _BACKGROUND
    for k, (image, texts) in enumerate(zip(images, labels, strict=True)):
        x0 = k * (w + gap)
        out[strip:, x0:x0 + w] = image[..., :3]
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


def png_bytes(image: np.ndarray) -> bytes:
    """An 8-bit RGB or RGBA PNG (ISO/IEC 15948), each row with the "Up" filter.

    image:   (H, W, 3 or 4) uint8, or float display values in [0, 1]; row 0 at the top
    returns: the file's bytes
    """
    px = image if image.dtype == np.uint8 else to_uint8(image)
    h, w, c = px.shape
    if c not in (3, 4):
        raise ValueError(f"a PNG needs 3 or 4 channels, got {c}")
    rows = np.ascontiguousarray(px).reshape(h, w * c)
    up = rows.copy()
    up[1:] -= rows[:-1]  # filter type 2: each byte minus the one above it, modulo 256
    rows = np.concatenate([np.full((h, 1), 2, np.uint8), up], 1)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", w, h, 8, 2 if c == 3 else 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)) + chunk(b"IEND", b""))


def write_png(path: str | os.PathLike, image: np.ndarray) -> None:
    """Write ``png_bytes(image)`` (RGB: the first three channels) atomically: a temporary
    file, then renamed.

    path:  destination
    image: (H, W, >=3) uint8, or float display values in [0, 1]; row 0 at the top
    """
    write_bytes(path, png_bytes(image[..., :3]))
