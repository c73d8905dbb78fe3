"""Order-3 (9-coefficient) real spherical harmonics: projection of radiance, irradiance, the
talk's tinted scalar SH, and windowing against ringing.

Conventions (docs/sh.md, "Conventions"): real SH without the Condon-Shortley sign, in the order
(l, m) = (0,0) (1,-1) (1,0) (1,1) (2,-2) (2,-1) (2,0) (2,1) (2,2), evaluated on unit
directions (x, y, z) in Blender world axes (Z up):

    0.282095;  0.488603 y;  0.488603 z;  0.488603 x;
    1.092548 xy;  1.092548 yz;  0.315392 (3 z^2 - 1);  1.092548 xz;  0.546274 (x^2 - y^2)

(the constants of Ramamoorthi & Hanrahan 2001, eq. 3, written here in closed form:
1 / (2 sqrt(pi)), sqrt(3 / (4 pi)), sqrt(15 / (4 pi)), sqrt(5 / (16 pi)), sqrt(15 / (16 pi))).
Coefficients store the projection of RADIANCE L, L_lm = integral of L(w) Y_lm(w) dw, in the
radiance's own units (W m^-2 sr^-1, per channel); irradiance comes from them by the
convolution with the clamped cosine.

What the module follows, and where from:

- Projection: a quadrature over texels, sum of L Y_lm dw with each texel's exact solid angle
  (``project``). Lat-long images use Blender's Environment Texture mapping
  (``texture.direction_to_equirect_uv``): u = 0.5 - atan2(y, x) / (2 pi),
  v = 0.5 + atan2(z, hypot(x, y)) / pi, v = 0 at the bottom; images are (H, W, C) with row 0 at
  the top, so texel (r, c) has its centre at u = (c + 0.5) / W, v = 1 - (r + 0.5) / H and covers
  polar angles theta in [pi r / H, pi (r + 1) / H], a solid angle of
  (2 pi / W) (cos theta_top - cos theta_bottom) (``equirect_solid_angles``; the rows add up to
  exactly 4 pi).
- Irradiance: R. Ramamoorthi and P. Hanrahan, "An Efficient Representation for Irradiance
  Environment Maps", SIGGRAPH 2001: E(n) = sum over l, m of A_l L_lm Y_lm(n) with the clamped
  cosine's band factors A_0 = pi, A_1 = 2 pi / 3, A_2 = pi / 4 (their eq. 8-9).
- Tinted scalar SH: slide "Environment map normalization: new idea" (Lazarov 2013): "Pass
  environment map's directional irradiance to run-time (used tinted scalar 3rd-order Spherical
  Harmonics)". The talk gives no formula; ``to_tinted`` documents the definition used here.
- Windowing: P.-P. Sloan, "Stupid Spherical Harmonics (SH) Tricks", GDC 2008, section
  "Windowing": multiply band l by a window w_l (Hanning or Lanczos) to trade sharpness for less
  ringing. Its effect on the irradiance of a narrow bright lobe is measured by
  ``tools/measure_sh_window.py`` (docs/sh.md).

References
----------
- D. Lazarov, "Getting More Physical in Call of Duty: Black Ops II", SIGGRAPH 2013 course
  "Physically Based Shading in Theory and Practice".
- R. Ramamoorthi, P. Hanrahan, "An Efficient Representation for Irradiance Environment Maps",
  SIGGRAPH 2001.
- P.-P. Sloan, "Stupid Spherical Harmonics (SH) Tricks", Game Developers Conference 2008.
- ITU-R BT.709-6 (luminance weights 0.2126, 0.7152, 0.0722 of linear Rec.709 RGB).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "BAND",
    "BAND_FACTORS",
    "COEFFICIENTS",
    "LUMINANCE_REC709",
    "ORDER",
    "basis",
    "equirect_directions",
    "fibonacci_directions",
    "equirect_solid_angles",
    "irradiance",
    "project",
    "project_equirect",
    "radiance_luminance",
    "rotate",
    "tinted_irradiance",
    "to_tinted",
    "window",
    "window_weights",
]

ORDER = ((0, 0), (1, -1), (1, 0), (1, 1), (2, -2), (2, -1), (2, 0), (2, 1), (2, 2))
COEFFICIENTS = len(ORDER)
BAND = np.array([l for l, _ in ORDER])  # band l of each coefficient, (9,)

# Ramamoorthi & Hanrahan 2001, eq. 3, in closed form.
_C0 = 0.5 / np.sqrt(np.pi)  # 0.282095
_C1 = np.sqrt(3.0 / (4.0 * np.pi))  # 0.488603
_C2 = np.sqrt(15.0 / (4.0 * np.pi))  # 1.092548
_C20 = np.sqrt(5.0 / (16.0 * np.pi))  # 0.315392
_C22 = np.sqrt(15.0 / (16.0 * np.pi))  # 0.546274

# Clamped-cosine band factors A_l (Ramamoorthi & Hanrahan 2001, eq. 8-9), per coefficient.
BAND_FACTORS = np.array([np.pi, 2.0 * np.pi / 3.0, np.pi / 4.0])[BAND]

# Rec.709 / sRGB luminance weights (ITU-R BT.709-6): the Y row of linear Rec.709 -> XYZ.
LUMINANCE_REC709 = np.array([0.2126, 0.7152, 0.0722])

# Directions per block inside ``project``: bounds the (N, 9) float64 temporaries.
_CHUNK = 1 << 16


def basis(d) -> np.ndarray:
    """The 9 real SH basis functions at unit directions (the order and signs above).

    Ramamoorthi & Hanrahan 2001, eq. 3 (no Condon-Shortley sign).

    d:       (..., 3) unit directions in Blender world axes (Z up); not normalised here
    returns: (..., 9) float64 if d is float64, float32 otherwise
    """
    d = np.asarray(d)
    dtype = np.float64 if d.dtype == np.float64 else np.float32
    d = d.astype(np.float64, copy=False)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    out = np.stack([
        np.full_like(x, _C0),
        _C1 * y,
        _C1 * z,
        _C1 * x,
        _C2 * x * y,
        _C2 * y * z,
        _C20 * (3.0 * z * z - 1.0),
        _C2 * x * z,
        _C22 * (x * x - y * y),
    ], -1)
    return out.astype(dtype, copy=False)


def project(directions, values, solid_angles) -> np.ndarray:
    """SH projection of radiance by quadrature: sum over i of values_i Y(d_i) solid_angles_i.

    Ramamoorthi & Hanrahan 2001, eq. 2 (L_lm = integral of L Y_lm dw), as a weighted sum.

    directions:   (N, 3) unit directions, Blender world axes
    values:       (N, C) or (N,) radiance per direction (any linear unit, per channel)
    solid_angles: (N,) or scalar, steradians represented by each direction
    returns:      (9, C) float64 coefficients (or (9,) for (N,) values), same unit as values;
                  accumulated in float64, in blocks of directions
    """
    directions, values = np.asarray(directions), np.asarray(values)
    n = values.shape[0]
    weights = np.broadcast_to(np.asarray(solid_angles, np.float64), (n,))
    out = np.zeros((COEFFICIENTS,) + values.shape[1:])
    for s in range(0, n, _CHUNK):
        block = slice(s, s + _CHUNK)
        y = basis(directions[block].astype(np.float64)) * weights[block, None]
        out += y.T @ values[block].astype(np.float64)
    return out


def fibonacci_directions(count: int) -> np.ndarray:
    """(count, 3) float64 unit directions of a Fibonacci sphere: each stands for a cell of
    solid angle 4 pi / count (none for count 0)."""
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    phi = k * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def radiance_luminance(sh, directions) -> np.ndarray:
    """(N,) float64 Rec.709 luminance of the radiance of SH ``sh`` (9, 3) towards unit
    ``directions`` (N, 3), clamped at 0."""
    radiance = basis(directions) @ np.asarray(sh, np.float64)  # (N, 3)
    return np.maximum(radiance @ LUMINANCE_REC709, 0.0)


def equirect_directions(height: int, width: int) -> np.ndarray:
    """Unit directions of the texel centres of a lat-long image (Environment Texture mapping).

    Texel (r, c) of an (H, W) image, row 0 at the top, has u = (c + 0.5) / W and
    v = 1 - (r + 0.5) / H, and the direction that ``texture.direction_to_equirect_uv`` maps to
    that UV: azimuth 2 pi (0.5 - u) from +X towards +Y, elevation pi (v - 0.5).

    height, width: image size in texels
    returns:       (H, W, 3) float32 unit directions in Blender world axes (Z up)
    """
    u = (np.arange(width) + 0.5) / width
    v = 1.0 - (np.arange(height) + 0.5) / height
    azimuth = 2.0 * np.pi * (0.5 - u)
    elevation = np.pi * (v - 0.5)
    ce, se = np.cos(elevation)[:, None], np.sin(elevation)[:, None]
    out = np.empty((height, width, 3), np.float32)
    out[..., 0] = ce * np.cos(azimuth)[None, :]
    out[..., 1] = ce * np.sin(azimuth)[None, :]
    out[..., 2] = np.broadcast_to(se, (height, width))
    return out


def equirect_solid_angles(height: int, width: int) -> np.ndarray:
    """Exact solid angle of one texel of each row of a lat-long image.

    Row r (row 0 at the top) spans polar angles theta from pi r / H to pi (r + 1) / H and
    2 pi / W of azimuth: dw = (2 pi / W) (cos theta_top - cos theta_bottom). The H W texels
    add up to 4 pi.

    height, width: image size in texels
    returns:       (H,) float64 steradians per texel of each row
    """
    cos_edge = np.cos(np.pi * np.arange(height + 1) / height)
    return (2.0 * np.pi / width) * (cos_edge[:-1] - cos_edge[1:])


def project_equirect(image) -> np.ndarray:
    """SH projection of a lat-long radiance image (Blender's Environment Texture mapping).

    ``project`` over every texel centre with its exact solid angle (``equirect_directions``,
    ``equirect_solid_angles``); Ramamoorthi & Hanrahan 2001, eq. 2.

    image:   (H, W, C) radiance, row 0 at the top (the +Z pole), linear (e.g. W m^-2 sr^-1)
    returns: (9, C) float64 coefficients of radiance, same unit as image
    """
    image = np.asarray(image)
    if image.ndim != 3:
        raise ValueError(f"expected an (H, W, C) image, got shape {image.shape}")
    height, width, channels = image.shape
    return project(equirect_directions(height, width).reshape(-1, 3),
                   image.reshape(-1, channels),
                   np.repeat(equirect_solid_angles(height, width), width))


def irradiance(sh, normals) -> np.ndarray:
    """Irradiance from radiance SH: E(n) = sum of A_l L_lm Y_lm(n), A_l = pi, 2 pi / 3, pi / 4.

    Ramamoorthi & Hanrahan 2001, eq. 7-9 (convolution with the clamped cosine max(0, n.l)).
    Order 3 leaves a small error where the radiance has high frequencies, and can go slightly
    negative opposite a bright narrow light (see ``window`` and docs/sh.md).

    sh:      (9, C) or (9,) radiance coefficients (``project``)
    normals: (N, 3) unit normals, Blender world axes
    returns: (N, C) or (N,) irradiance (W m^-2 for radiance in W m^-2 sr^-1), float32
    """
    sh = np.asarray(sh, np.float64)
    convolved = sh * BAND_FACTORS.reshape((COEFFICIENTS,) + (1,) * (sh.ndim - 1))
    return (basis(np.asarray(normals, np.float64)) @ convolved).astype(np.float32)


def to_tinted(sh, weights=LUMINANCE_REC709) -> tuple[np.ndarray, np.ndarray]:
    """Tinted scalar SH of an RGB radiance SH: one luminance SH and one RGB tint.

    Slide "Environment map normalization: new idea" (Lazarov 2013): "tinted scalar 3rd-order
    Spherical Harmonics". The talk gives no formula; the definition here is

        scalar_k = sum over c of weights_c sh_k,c        (luminance of every coefficient)
        tint_c   = sh_0,c / scalar_0                     (DC colour over DC luminance)

    and the RGB reconstruction is tint * (scalar reconstruction). So the DC term, i.e. the
    colour of the mean radiance and of the irradiance averaged over all normals, is reproduced
    exactly (tint * scalar_0 = sh_0), the scalar SH is the true luminance SH (directional
    irradiance in luminance units, what the talk's normalization divides by), and the tint has
    luminance 1. Only the colour of the directional (l >= 1) part is lost: it takes the DC
    colour. An environment whose colour is the same in every direction (L(w) = colour f(w)) is
    reproduced exactly. With a black DC (scalar_0 = 0) the tint is white (1, 1, 1).

    sh:      (9, 3) radiance coefficients, linear RGB
    weights: (3,) luminance weights of the RGB space; default Rec.709 (0.2126, 0.7152, 0.0722),
             the Y row of the working space's RGB -> XYZ matrix for other spaces
    returns: (scalar (9,) float64 luminance coefficients, tint (3,) float64)
    """
    sh = np.asarray(sh, np.float64)
    if sh.shape != (COEFFICIENTS, 3):
        raise ValueError(f"expected (9, 3) RGB coefficients, got shape {sh.shape}")
    scalar = sh @ np.asarray(weights, np.float64)
    if scalar[0] != 0.0:
        tint = sh[0] / scalar[0]
    else:
        tint = np.ones(3)
    return scalar, tint


def tinted_irradiance(scalar, tint, normals) -> np.ndarray:
    """RGB irradiance of tinted scalar SH: tint * E_scalar(n).

    Slide "Environment map normalization: new idea" (Lazarov 2013) with the irradiance of
    Ramamoorthi & Hanrahan 2001 (``irradiance``); ``to_tinted`` defines scalar and tint.

    scalar:  (9,) luminance radiance coefficients
    tint:    (3,) RGB tint (luminance 1)
    normals: (N, 3) unit normals, Blender world axes
    returns: (N, 3) float32 irradiance, linear RGB
    """
    e = irradiance(np.asarray(scalar, np.float64), normals).astype(np.float64)
    return (e[:, None] * np.asarray(tint, np.float64)[None, :]).astype(np.float32)


def window_weights(kind: str = "hanning", width: float = 3.0) -> np.ndarray:
    """Per-band window factors w_l, l = 0, 1, 2 (Sloan 2008, "Windowing").

    hanning: w_l = (1 + cos(pi l / width)) / 2 for l < width, 0 beyond;
    lanczos: w_l = sin(pi l / width) / (pi l / width) for 0 < l < width, w_0 = 1, 0 beyond.
    Both keep band 0 (w_0 = 1), so the mean radiance and mean irradiance are unchanged; a
    larger width filters less.

    kind:    "hanning" or "lanczos"
    width:   window width in bands, > 0 (Sloan suggests at least the SH order, 3 here)
    returns: (3,) float64 factors for bands 0, 1, 2
    """
    if not width > 0:
        raise ValueError(f"window width must be positive, got {width}")
    t = np.arange(3) / float(width)
    if kind == "hanning":
        w = 0.5 * (1.0 + np.cos(np.pi * t))
    elif kind == "lanczos":
        w = np.sinc(t)  # numpy's sinc is sin(pi t) / (pi t)
    else:
        raise ValueError(f"unknown window {kind!r}, expected 'hanning' or 'lanczos'")
    return np.where(t < 1.0, w, 0.0)


def window(sh, kind: str = "hanning", width: float = 3.0) -> np.ndarray:
    """Windowed SH: every coefficient of band l multiplied by w_l (Sloan 2008, "Windowing").

    Damps the higher bands to reduce ringing (negative lobes opposite a bright narrow light)
    at the cost of blur; docs/sh.md has the measured trade-off for irradiance.

    sh:      (9, ...) coefficients (any trailing channel shape)
    kind:    "hanning" or "lanczos" (``window_weights``)
    width:   window width in bands
    returns: (9, ...) float64 windowed coefficients
    """
    sh = np.asarray(sh, np.float64)
    w = window_weights(kind, width)[BAND]
    return sh * w.reshape((COEFFICIENTS,) + (1,) * (sh.ndim - 1))


def rotate(sh, rotation) -> np.ndarray:
    """The SH of the same radiance in turned axes: directions d become R d.

    Exact for order 3 (each band turns within itself): the coefficients are fitted by least
    squares to the radiance's values at 64 Fibonacci directions.

    sh:       (9, C) or (9,) coefficients in the old axes
    rotation: (3, 3) orthonormal R, old axes -> new axes (``gpu_textures.Y_UP`` for instance)
    returns:  same shape, float64 coefficients in the new axes
    """
    d = fibonacci_directions(64)
    old = basis(d).astype(np.float64)
    new = basis(d @ np.asarray(rotation, np.float64).T).astype(np.float64)
    values = old @ np.asarray(sh, np.float64).reshape(COEFFICIENTS, -1)
    turned, *_ = np.linalg.lstsq(new, values, rcond=None)
    return turned.reshape(np.shape(sh))
