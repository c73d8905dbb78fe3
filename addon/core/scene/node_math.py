"""Blender's shader-node arithmetic over per-point arrays, with Cycles' semantics.

Every function takes and returns float32 arrays of shape (N, 1) (a float socket) or (N, 3)
(a colour or vector socket); N may be 1 for a constant, which broadcasts. The formulas are
those of Cycles' SVM kernel (``intern/cycles/kernel/svm/``: ``math_util.h`` for Math and Vector
Math, ``color_util.h`` for the Mix blend modes, ``mapping_util.h``, ``map_range.h``,
``ramp.h``, ``hsv.h``, ``gamma.h``, ``brightness.h``, ``invert.h``, ``clamp.h`` and
``util/color.h`` for RGB/HSV/HSL), including their "safe" guards: a division by zero gives 0,
a power of a negative base to a non-integer exponent gives 0, the logarithm of a non-positive
number gives 0, so a node tree never produces NaN where Cycles does not.
``tests/blender/test_material_nodes.py`` holds them to Cycles renders of the same nodes.
"""

from __future__ import annotations

import numpy as np

LUMINANCE = np.array([0.2126, 0.7152, 0.0722], np.float32)  # Rec. 709, Blender's default config
_FLT_EPSILON = np.float32(1.1920929e-07)

__all__ = ["LUMINANCE", "MATH", "VECTOR_MATH", "BLEND_MODES", "blend", "hsv_to_rgb",
           "rgb_to_hsv", "hsl_to_rgb", "rgb_to_hsl", "to_float", "euler_xyz", "mapping",
           "map_range", "clamp", "ramp_lookup", "hue_saturation_value", "gamma",
           "bright_contrast", "invert", "fresnel_dielectric_cos"]


def f32(x) -> np.ndarray:
    """x as a float32 array of at least two dimensions (N, k)."""
    a = np.asarray(x, np.float32)
    return a.reshape(1, -1) if a.ndim < 2 else a


def to_float(x: np.ndarray, kind: str) -> np.ndarray:
    """A colour (its luminance) or a vector (its average) as a float socket: (N, 1)."""
    if x.shape[1] == 1:
        return x
    if kind == "color":
        return (x[:, :3] @ LUMINANCE[:, None]).astype(np.float32)
    return x[:, :3].mean(axis=1, keepdims=True, dtype=np.float32)


def _safe_div(a, b):
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(b != 0.0, a / np.where(b != 0.0, b, 1.0), 0.0).astype(np.float32)


def _safe_pow(a, b):
    a, b = np.broadcast_arrays(a, b)
    bad = (a < 0.0) & (b != np.floor(b))
    with np.errstate(all="ignore"):
        return np.where(bad, 0.0, np.power(np.where(bad, 1.0, a), b)).astype(np.float32)


def _safe_log(a, b):
    ok = (a > 0.0) & (b > 0.0)
    with np.errstate(all="ignore"):
        r = np.log(np.where(ok, a, 1.0)) / np.log(np.where(ok, b, 2.0))
    return np.where(ok & np.isfinite(r), r, 0.0).astype(np.float32)


def _smoothmin(a, b, c):
    with np.errstate(all="ignore"):
        h = np.maximum(c - np.abs(a - b), 0.0) / np.where(c != 0.0, c, 1.0)
    return np.where(c != 0.0, np.minimum(a, b) - h * h * h * c * (1.0 / 6.0), np.minimum(a, b))


def _wrap(value, top, bottom):
    rng = top - bottom
    with np.errstate(all="ignore"):
        w = value - rng * np.floor((value - bottom) / np.where(rng != 0.0, rng, 1.0))
    return np.where(rng != 0.0, w, bottom)


def _pingpong(a, b):
    with np.errstate(all="ignore"):
        x = (a - b) / np.where(b != 0.0, b * 2.0, 1.0)
        r = np.abs((x - np.floor(x)) * b * 2.0 - b)
    return np.where(b != 0.0, r, 0.0)


def _fmod(a, b):
    with np.errstate(all="ignore"):
        return np.where(b != 0.0, np.fmod(a, np.where(b != 0.0, b, 1.0)), 0.0)


def _floored_mod(a, b):
    with np.errstate(all="ignore"):
        return np.where(b != 0.0, a - np.floor(a / np.where(b != 0.0, b, 1.0)) * b, 0.0)


def _snap(a, b):
    return np.floor(_safe_div(a, b)) * b


def _sign(a):
    return np.sign(a)


def _compare(a, b, c):
    return ((a == b) | (np.abs(a - b) <= np.maximum(c, _FLT_EPSILON))).astype(np.float32)


def _trig(fn):
    def f(a, b, c):
        with np.errstate(all="ignore"):
            return fn(a)
    return f


# Math node (ShaderNodeMath.operation): (a, b, c) -> value, Cycles ``svm_math``.
MATH = {
    "ADD": lambda a, b, c: a + b,
    "SUBTRACT": lambda a, b, c: a - b,
    "MULTIPLY": lambda a, b, c: a * b,
    "DIVIDE": lambda a, b, c: _safe_div(a, b),
    "MULTIPLY_ADD": lambda a, b, c: a * b + c,
    "POWER": lambda a, b, c: _safe_pow(a, b),
    "LOGARITHM": lambda a, b, c: _safe_log(a, b),
    "SQRT": lambda a, b, c: np.sqrt(np.maximum(a, 0.0)),
    "INVERSE_SQRT": lambda a, b, c: _safe_div(np.float32(1.0), np.sqrt(np.maximum(a, 0.0))),
    "ABSOLUTE": lambda a, b, c: np.abs(a),
    "EXPONENT": _trig(np.exp),
    "MINIMUM": lambda a, b, c: np.minimum(a, b),
    "MAXIMUM": lambda a, b, c: np.maximum(a, b),
    "LESS_THAN": lambda a, b, c: (a < b).astype(np.float32),
    "GREATER_THAN": lambda a, b, c: (a > b).astype(np.float32),
    "SIGN": lambda a, b, c: _sign(a),
    "COMPARE": _compare,
    "SMOOTH_MIN": _smoothmin,
    "SMOOTH_MAX": lambda a, b, c: -_smoothmin(-a, -b, c),
    "ROUND": lambda a, b, c: np.floor(a + 0.5),
    "FLOOR": lambda a, b, c: np.floor(a),
    "CEIL": lambda a, b, c: np.ceil(a),
    "TRUNC": lambda a, b, c: np.trunc(a),
    "FRACT": lambda a, b, c: a - np.floor(a),
    "MODULO": lambda a, b, c: _fmod(a, b),
    "FLOORED_MODULO": lambda a, b, c: _floored_mod(a, b),
    "WRAP": lambda a, b, c: _wrap(a, b, c),
    "SNAP": lambda a, b, c: _snap(a, b),
    "PINGPONG": lambda a, b, c: _pingpong(a, b),
    "SINE": _trig(np.sin),
    "COSINE": _trig(np.cos),
    "TANGENT": _trig(np.tan),
    "ARCSINE": lambda a, b, c: np.arcsin(np.clip(a, -1.0, 1.0)),
    "ARCCOSINE": lambda a, b, c: np.arccos(np.clip(a, -1.0, 1.0)),
    "ARCTANGENT": lambda a, b, c: np.arctan(a),
    "ARCTAN2": lambda a, b, c: np.arctan2(a, b),
    "SINH": _trig(np.sinh),
    "COSH": _trig(np.cosh),
    "TANH": _trig(np.tanh),
    "RADIANS": lambda a, b, c: a * np.float32(np.pi / 180.0),
    "DEGREES": lambda a, b, c: a * np.float32(180.0 / np.pi),
}


def math(operation: str, a, b, c, use_clamp: bool = False) -> np.ndarray:
    """The Math node: (N, 1) float32, non-finite results (overflow) as 0, clamped to [0, 1]
    with ``use_clamp``."""
    r = f32(MATH[operation](f32(a), f32(b), f32(c)))
    r = np.where(np.isfinite(r), r, 0.0).astype(np.float32)
    return np.clip(r, 0.0, 1.0) if use_clamp else r


def _dot(a, b):
    return np.einsum("nc,nc->n", *np.broadcast_arrays(a, b))[:, None].astype(np.float32)


def _length(a):
    return np.sqrt(_dot(a, a))


def _normalize(a):
    length = _length(a)
    return np.where(length > 0.0, a / np.where(length > 0.0, length, 1.0), 0.0)


def _project(a, b):
    d = _dot(b, b)
    return np.where(d != 0.0, _dot(a, b) / np.where(d != 0.0, d, 1.0) * b, 0.0)


def _reflect(a, b):
    n = _normalize(b)
    return a - 2.0 * _dot(a, n) * n


def _refract(a, b, eta):
    n = _normalize(b)
    d = _dot(n, a)
    k = 1.0 - eta * eta * (1.0 - d * d)
    return np.where(k < 0.0, 0.0, eta * a - (eta * d + np.sqrt(np.maximum(k, 0.0))) * n)


def _faceforward(a, b, c):
    return np.where(_dot(c, b) < 0.0, a, -a)


# Vector Math node: (a, b, c, scale) -> vector (N, 3) or value (N, 1), Cycles
# ``svm_vector_math``.
VECTOR_MATH = {
    "ADD": lambda a, b, c, s: a + b,
    "SUBTRACT": lambda a, b, c, s: a - b,
    "MULTIPLY": lambda a, b, c, s: a * b,
    "DIVIDE": lambda a, b, c, s: _safe_div(a, b),
    "MULTIPLY_ADD": lambda a, b, c, s: a * b + c,
    "CROSS_PRODUCT": lambda a, b, c, s: np.cross(*np.broadcast_arrays(a, b)),
    "PROJECT": lambda a, b, c, s: _project(a, b),
    "REFLECT": lambda a, b, c, s: _reflect(a, b),
    "REFRACT": lambda a, b, c, s: _refract(a, b, s),
    "FACEFORWARD": lambda a, b, c, s: _faceforward(a, b, c),
    "DOT_PRODUCT": lambda a, b, c, s: _dot(a, b),
    "DISTANCE": lambda a, b, c, s: _length(a - b),
    "LENGTH": lambda a, b, c, s: _length(a),
    "SCALE": lambda a, b, c, s: a * s,
    "NORMALIZE": lambda a, b, c, s: _normalize(a),
    "SNAP": lambda a, b, c, s: _snap(a, b),
    "FLOOR": lambda a, b, c, s: np.floor(a),
    "CEIL": lambda a, b, c, s: np.ceil(a),
    "MODULO": lambda a, b, c, s: _fmod(a, b),
    "WRAP": lambda a, b, c, s: _wrap(a, b, c),
    "FRACTION": lambda a, b, c, s: a - np.floor(a),
    "ABSOLUTE": lambda a, b, c, s: np.abs(a),
    "POWER": lambda a, b, c, s: _safe_pow(a, b),
    "SIGN": lambda a, b, c, s: np.sign(a),
    "MINIMUM": lambda a, b, c, s: np.minimum(a, b),
    "MAXIMUM": lambda a, b, c, s: np.maximum(a, b),
    "SINE": lambda a, b, c, s: np.sin(a),
    "COSINE": lambda a, b, c, s: np.cos(a),
    "TANGENT": lambda a, b, c, s: np.tan(a),
}
VECTOR_MATH_VALUE = frozenset({"DOT_PRODUCT", "DISTANCE", "LENGTH"})  # the Value output

def vector_math(operation: str, a, b, c, scale) -> np.ndarray:
    """The Vector Math node: (N, 3), or (N, 1) for dot product, distance and length; non-finite
    components as 0."""
    with np.errstate(all="ignore"):
        r = f32(VECTOR_MATH[operation](f32(a), f32(b), f32(c), f32(scale)))
    return np.where(np.isfinite(r), r, 0.0).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# Colour models (Cycles ``util/color.h``)


def rgb_to_hsv(rgb) -> np.ndarray:
    """(N, 3) RGB -> HSV, hue in [0, 1)."""
    rgb = f32(rgb)
    r, g, b = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    cmax, cmin = rgb.max(axis=1), rgb.min(axis=1)
    delta = cmax - cmin
    s = np.where(cmax != 0.0, delta / np.where(cmax != 0.0, cmax, 1.0), 0.0)
    safe = np.where(delta != 0.0, delta, 1.0)
    cr, cg, cb = ((cmax - ch) / safe for ch in (r, g, b))
    h = np.where(r == cmax, cb - cg, np.where(g == cmax, 2.0 + cr - cb, 4.0 + cg - cr)) / 6.0
    h = np.where(h < 0.0, h + 1.0, h)
    h = np.where(s != 0.0, h, 0.0)
    return np.stack([h, s, cmax], 1).astype(np.float32)


def hsv_to_rgb(hsv) -> np.ndarray:
    """(N, 3) HSV -> RGB."""
    hsv = f32(hsv)
    h, s, v = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    h = np.where(h == 1.0, 0.0, h) * 6.0
    i = np.floor(h)
    f = h - i
    p, q, t = v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f))
    table = [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)]
    k = np.clip(i, 0, 5).astype(np.int64)
    k = np.where((i >= 0) & (i <= 4), k, 5)
    out = np.empty((len(hsv), 3), np.float32)
    for c in range(3):
        out[:, c] = np.choose(k, [row[c] for row in table])
    grey = s == 0.0
    out[grey] = v[grey, None]
    return out


def rgb_to_hsl(rgb) -> np.ndarray:
    """(N, 3) RGB -> HSL."""
    rgb = f32(rgb)
    r, g, b = rgb[:, 0], rgb[:, 1], rgb[:, 2]
    cmax, cmin = rgb.max(axis=1), rgb.min(axis=1)
    lum = np.minimum(1.0, (cmax + cmin) / 2.0)
    d = cmax - cmin
    same = cmax == cmin
    with np.errstate(all="ignore"):
        s = np.where(lum > 0.5, d / (2.0 - cmax - cmin), d / (cmax + cmin))
        sd = np.where(same, 1.0, d)
        h = np.where(cmax == r, (g - b) / sd + np.where(g < b, 6.0, 0.0),
                     np.where(cmax == g, (b - r) / sd + 2.0, (r - g) / sd + 4.0)) / 6.0
    h = np.where(same, 0.0, h)
    s = np.where(same | ~np.isfinite(s), 0.0, s)
    return np.stack([h, s, lum], 1).astype(np.float32)


def hsl_to_rgb(hsl) -> np.ndarray:
    """(N, 3) HSL -> RGB."""
    hsl = f32(hsl)
    h, s, lum = hsl[:, :1], hsl[:, 1:2], hsl[:, 2:3]
    n = np.concatenate([np.abs(h * 6.0 - 3.0) - 1.0, 2.0 - np.abs(h * 6.0 - 2.0),
                        2.0 - np.abs(h * 6.0 - 4.0)], 1)
    chroma = (1.0 - np.abs(2.0 * lum - 1.0)) * s
    return ((np.clip(n, 0.0, 1.0) - 0.5) * chroma + lum).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# Mix (colour blend modes, Cycles ``svm_mix``)


def _lerp(a, b, t):
    return a + (b - a) * t


def _dodge(c1, c2, t):
    tmp = 1.0 - t * c2
    with np.errstate(all="ignore"):
        q = c1 / np.where(tmp > 0.0, tmp, 1.0)
    r = np.where(tmp <= 0.0, 1.0, np.minimum(q, 1.0))
    return np.where(c1 != 0.0, r, c1)


def _burn(c1, c2, t):
    tmp = (1.0 - t) + t * c2
    with np.errstate(all="ignore"):
        q = 1.0 - (1.0 - c1) / np.where(tmp > 0.0, tmp, 1.0)
    return np.where(tmp <= 0.0, 0.0, np.clip(q, 0.0, 1.0))


def _hue(c1, c2, t):
    hsv2 = rgb_to_hsv(c2)
    hsv = rgb_to_hsv(c1)
    hsv[:, 0] = hsv2[:, 0]
    return np.where(hsv2[:, 1:2] != 0.0, _lerp(c1, hsv_to_rgb(hsv), t), c1)


def _saturation(c1, c2, t):
    hsv = rgb_to_hsv(c1)
    hsv2 = rgb_to_hsv(c2)
    keep = hsv[:, 1:2] != 0.0
    hsv[:, 1] = _lerp(hsv[:, 1:2], hsv2[:, 1:2], t)[:, 0]
    return np.where(keep, hsv_to_rgb(hsv), c1)


def _value(c1, c2, t):
    hsv = rgb_to_hsv(c1)
    hsv2 = rgb_to_hsv(c2)
    hsv[:, 2] = _lerp(hsv[:, 2:3], hsv2[:, 2:3], t)[:, 0]
    return hsv_to_rgb(hsv)


def _color(c1, c2, t):
    hsv2 = rgb_to_hsv(c2)
    hsv = rgb_to_hsv(c1)
    hsv[:, 0], hsv[:, 1] = hsv2[:, 0], hsv2[:, 1]
    return np.where(hsv2[:, 1:2] != 0.0, _lerp(c1, hsv_to_rgb(hsv), t), c1)


def _soft_light(c1, c2, t):
    scr = 1.0 - (1.0 - c2) * (1.0 - c1)
    return (1.0 - t) * c1 + t * ((1.0 - c1) * c2 * c1 + c1 * scr)


def _divide(c1, c2, t):
    with np.errstate(all="ignore"):
        q = c1 / np.where(c2 != 0.0, c2, 1.0)
    return np.where(c2 != 0.0, (1.0 - t) * c1 + t * q, c1)


def _overlay(c1, c2, t):
    tm = 1.0 - t
    return np.where(c1 < 0.5, c1 * (tm + 2.0 * t * c2),
                    1.0 - (tm + 2.0 * t * (1.0 - c2)) * (1.0 - c1))


BLEND_MODES = {
    "MIX": lambda c1, c2, t: _lerp(c1, c2, t),
    "ADD": lambda c1, c2, t: c1 + t * c2,
    "MULTIPLY": lambda c1, c2, t: c1 * ((1.0 - t) + t * c2),
    "SCREEN": lambda c1, c2, t: 1.0 - ((1.0 - t) + t * (1.0 - c2)) * (1.0 - c1),
    "OVERLAY": _overlay,
    "SUBTRACT": lambda c1, c2, t: c1 - t * c2,
    "DIVIDE": _divide,
    "DIFFERENCE": lambda c1, c2, t: _lerp(c1, np.abs(c1 - c2), t),
    "EXCLUSION": lambda c1, c2, t: np.maximum(_lerp(c1, c1 + c2 - 2.0 * c1 * c2, t), 0.0),
    "DARKEN": lambda c1, c2, t: _lerp(c1, np.minimum(c1, c2), t),
    "LIGHTEN": lambda c1, c2, t: _lerp(c1, np.maximum(c1, c2), t),
    "DODGE": _dodge,
    "BURN": _burn,
    "HUE": _hue,
    "SATURATION": _saturation,
    "VALUE": _value,
    "COLOR": _color,
    "SOFT_LIGHT": _soft_light,
    "LINEAR_LIGHT": lambda c1, c2, t: c1 + t * (2.0 * c2 - 1.0),
}


def blend(mode: str, factor, a, b, clamp_result: bool = False) -> np.ndarray:
    """Mix (colour) and the legacy MixRGB: ``a`` blended with ``b`` by ``mode`` at ``factor``
    (N, 1) (already clamped by the caller where the node clamps it); (N, 3)."""
    a, b, t = np.broadcast_arrays(f32(a), f32(b), f32(factor))
    out = f32(BLEND_MODES[mode](a, b, t[:, :1]))
    out = np.where(np.isfinite(out), out, 0.0).astype(np.float32)
    return np.clip(out, 0.0, 1.0) if clamp_result else out


# ---------------------------------------------------------------------------------------------
# Colour adjustments


def invert(factor, color) -> np.ndarray:
    """Invert Color: lerp(c, 1 - c, factor)."""
    c = f32(color)
    return _lerp(c, 1.0 - c, f32(factor)).astype(np.float32)


def gamma(color, g) -> np.ndarray:
    """Gamma: c^g for c > 0, c elsewhere; 1 for g = 0 (Cycles ``svm_math_gamma_color``)."""
    c, g = np.broadcast_arrays(f32(color), f32(g))
    with np.errstate(all="ignore"):
        r = np.where(c > 0.0, np.power(np.where(c > 0.0, c, 1.0), g), c)
    r = np.where(g == 0.0, 1.0, r)  # Cycles: a gamma of 0 gives white
    return np.where(np.isfinite(r), r, 0.0).astype(np.float32)


def bright_contrast(color, bright, contrast) -> np.ndarray:
    """Brightness/Contrast: max((1 + contrast) c + bright - contrast / 2, 0)."""
    a = 1.0 + f32(contrast)
    b = f32(bright) - f32(contrast) * 0.5
    return np.maximum(a * f32(color) + b, 0.0).astype(np.float32)


def hue_saturation_value(hue, saturation, value, factor, color) -> np.ndarray:
    """Hue/Saturation/Value (hue 0.5 is neutral)."""
    hue, saturation, value, factor = (f32(x)[:, :1] for x in (hue, saturation, value, factor))
    n = max(len(x) for x in (hue, saturation, value, factor, f32(color)))
    c = np.broadcast_to(f32(color)[:, :3], (n, 3))
    hsv = rgb_to_hsv(c)
    hsv[:, 0] = np.mod(hsv[:, 0] + hue[:, 0] + 0.5, 1.0)  # Cycles' fractf
    hsv[:, 1] = np.clip(hsv[:, 1] * saturation[:, 0], 0.0, 1.0)
    hsv[:, 2] = hsv[:, 2] * value[:, 0]
    return np.maximum(_lerp(c, hsv_to_rgb(hsv), factor), 0.0).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# Mapping, Map Range, Clamp, ramps


def euler_xyz(rotation) -> np.ndarray:
    """(N, 3) XYZ Euler angles, radians -> (N, 3, 3) rotation matrices Rz Ry Rx."""
    r = f32(rotation).astype(np.float64)
    cx, cy, cz = np.cos(r[:, 0]), np.cos(r[:, 1]), np.cos(r[:, 2])
    sx, sy, sz = np.sin(r[:, 0]), np.sin(r[:, 1]), np.sin(r[:, 2])
    m = np.empty((len(r), 3, 3))
    m[:, 0] = np.stack([cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz], 1)
    m[:, 1] = np.stack([cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz], 1)
    m[:, 2] = np.stack([-sy, cy * sx, cy * cx], 1)
    return m


def mapping(kind: str, vector, location, rotation, scale) -> np.ndarray:
    """The Mapping node (Cycles ``svm_mapping``): POINT, TEXTURE, VECTOR or NORMAL; (N, 3)."""
    v, loc, s = f32(vector), f32(location), f32(scale)
    r = f32(rotation)
    rot = euler_xyz(r).astype(np.float32)  # (1 or N, 3, 3)

    def turn(d, transposed=False):
        if len(rot) == 1:  # one rotation for every point: none, or one matrix product
            return d if not r.any() else d @ (rot[0] if transposed else rot[0].T)
        m = rot.transpose(0, 2, 1) if transposed else rot
        return (d[:, :1] * m[:, :, 0] + d[:, 1:2] * m[:, :, 1] + d[:, 2:3] * m[:, :, 2])

    if kind == "TEXTURE":
        return _safe_div(turn(v - loc, transposed=True), s)
    if kind == "NORMAL":
        return _normalize(turn(_safe_div(v, s))).astype(np.float32)
    out = turn(v * s)
    return (out + loc if kind == "POINT" else out).astype(np.float32)


def _smoothstep(e0, e1, x):
    with np.errstate(all="ignore"):
        t = (x - e0) / np.where(e1 != e0, e1 - e0, 1.0)
    return np.where(x < e0, 0.0, np.where(x >= e1, 1.0, (3.0 - 2.0 * t) * t * t))


def _smootherstep(e0, e1, x):
    x = np.clip(_safe_div(x - e0, e1 - e0), 0.0, 1.0)
    return x * x * x * (x * (x * 6.0 - 15.0) + 10.0)


def map_range(kind: str, value, from_min, from_max, to_min, to_max, steps,
              use_clamp: bool) -> np.ndarray:
    """Map Range (Cycles ``svm_map_range``): LINEAR, STEPPED, SMOOTHSTEP, SMOOTHERSTEP, per
    component for vectors."""
    value, from_min, from_max, to_min, to_max, steps = np.broadcast_arrays(
        *(f32(x) for x in (value, from_min, from_max, to_min, to_max, steps)))
    if kind in ("LINEAR", "STEPPED"):
        factor = _safe_div(value - from_min, from_max - from_min)
        if kind == "STEPPED":
            factor = np.where(steps > 0.0, np.floor(factor * (steps + 1.0))
                              / np.where(steps > 0.0, steps, 1.0), 0.0)
    else:
        step = _smoothstep if kind == "SMOOTHSTEP" else _smootherstep
        factor = np.where(from_min > from_max, 1.0 - step(from_max, from_min, value),
                          step(from_min, from_max, value))
    result = to_min + factor * (to_max - to_min)
    if use_clamp and kind in ("LINEAR", "STEPPED"):
        result = np.where(to_max > to_min, np.clip(result, to_min, to_max),
                          np.clip(result, to_max, to_min))
    return np.where(np.isfinite(result), result, 0.0).astype(np.float32)


def clamp(kind: str, value, lo, hi) -> np.ndarray:
    """Clamp: MINMAX min(max(value, lo), hi); RANGE swaps lo and hi when lo > hi."""
    value, lo, hi = f32(value), f32(lo), f32(hi)
    if kind == "RANGE":
        lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    return np.minimum(np.maximum(value, lo), hi).astype(np.float32)


def ramp_lookup(table: np.ndarray, f, interpolate: bool, extrapolate: bool) -> np.ndarray:
    """Cycles' ``rgb_ramp_lookup`` of a (S, C) table at positions f (N, 1) in [0, 1]; beyond
    it, the end entries (or their slopes with ``extrapolate``). Returns (N, C) float32."""
    table = np.asarray(table, np.float32)
    size = len(table)
    f = f32(f)[:, 0].astype(np.float64)
    f = np.where(np.isfinite(f), f, 0.0)
    x = np.clip(f, 0.0, 1.0) * (size - 1)
    i = np.clip(x.astype(np.int64), 0, size - 1)
    t = (x - i)[:, None]
    out = table[i].astype(np.float64)
    if interpolate:
        nxt = table[np.minimum(i + 1, size - 1)]
        out = np.where(t > 0.0, (1.0 - t) * out + t * nxt, out)
    if extrapolate and size > 1:
        lo, hi = f < 0.0, f > 1.0
        out[lo] = table[0] + (table[0] - table[1]) * (-f[lo, None]) * (size - 1)
        out[hi] = table[-1] + (table[-1] - table[-2]) * (f[hi, None] - 1.0) * (size - 1)
    return out.astype(np.float32)


def fresnel_dielectric_cos(cosi, eta) -> np.ndarray:
    """Unpolarized dielectric Fresnel reflectance at |cos| = cosi for relative IOR eta, 1 under
    total internal reflection (Cycles ``fresnel_dielectric_cos``); (N, 1)."""
    c = np.abs(f32(cosi))
    g = f32(eta) ** 2 - 1.0 + c * c
    ok = g > 0.0
    g = np.sqrt(np.where(ok, g, 1.0))
    with np.errstate(all="ignore"):
        a = (g - c) / (g + c)
        b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0)
        r = 0.5 * a * a * (1.0 + b * b)
    return np.where(ok, np.where(np.isfinite(r), r, 1.0), 1.0).astype(np.float32)
