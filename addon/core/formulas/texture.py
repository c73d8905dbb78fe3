"""Image textures: sRGB decoding, mip chains, trilinear sampling, ray-differential LOD, and the
equirectangular (lat-long) mapping of the Environment Texture (tangent frames and normal maps:
``tangents``).

What the module follows, and where from:

- sRGB: the exact piecewise transfer functions of IEC 61966-2-1:1999 (linear segment below
  0.04045 / 0.0031308, power 2.4 above), which is what Blender's "sRGB" colour space decodes.
  Level 0 of an sRGB texture keeps its encoded values and a look-up decodes after the
  bilinear step, as Cycles does with 8-bit sRGB images, so magnified texels blend as in
  Cycles; the mip levels are built from the decoded image.
- Mip maps: Williams 1983, "Pyramidal parametrics". Level k+1 halves level k with a box filter
  (size max(1, floor(n / 2)) per axis, the OpenGL rule); an odd axis of n = 2m + 1 texels uses
  the exact area weights of output texel i over input texels 2i, 2i+1, 2i+2:
  ((m - i) / n, m / n, (i + 1) / n), so every level keeps the mean of the image (the
  polyphase box filter of Sandmel et al., "Non-power-of-two mipmapping", NVIDIA 2005).
  Channels are filtered independently on straight alpha; the data may be channel-packed
  (gloss in alpha, say), so colour is never weighted by alpha. Cycles filters colour images on
  associated alpha: texels next to fully transparent ones can therefore differ in colour.
- Sampling: Blender's Image Texture conventions (Cycles ``kernel/device/cpu/image.h``): UV (0, 0)
  is the bottom-left corner, (1, 1) the top-right, texel centres at (i + 0.5) / w; extension
  modes REPEAT (wrap), EXTEND (clamp to the edge texel), CLIP (taps outside the image read
  transparent black, so the image fades out over the half texel beyond its edge, as in
  Cycles) and MIRROR (mirrored repeat, the edge texel repeated:
  ... 1 0 | 0 1 ... w-1 | w-1 w-2 ...). Bilinear within a level, linear between
  the two nearest levels (trilinear, Williams 1983). "Closest" reads the nearest texel of level 0;
  "Cubic" (and "Smart", which is Cubic in Cycles) the uniform cubic B-spline of level 0's 4 x 4
  texels around the position, as Cycles' Cubic.
- LOD: the isotropic scale factor of the OpenGL 4.6 specification (section 8.14.1),
  rho = max(|d(uv * size)/dx|, |d(uv * size)/dy|), lod = log2(rho).
- UV derivatives: ray differentials (Igehy 1999, "Tracing ray differentials"): the rays of the
  neighbouring pixels are intersected with the plane of the shaded triangle, and the hit points'
  barycentric coordinates give their UVs.
- Equirectangular: the mapping of Blender's Environment Texture node in Blender world axes (Z
  up), measured with Cycles renders (``tests/blender/test_environment_mapping.py``):
  u = 0.5 - atan2(d_y, d_x) / (2 pi), v = 0.5 + atan2(d_z, hypot(d_x, d_y)) / pi. So -X is at the
  left and right edges, +X at the centre, +Y at u = 0.25, -Y at u = 0.75, +Z at the top.

Arrays are float32 unless stated; images are (H, W, C) with row 0 at the TOP (the project's
convention), while UV v grows upwards, so v = 1 is row 0.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

__all__ = [
    "EXTENSIONS",
    "INTERPOLATIONS",
    "Texture",
    "build_mips",
    "direction_to_equirect_uv",
    "equirect_uv_to_direction",
    "linear_to_srgb",
    "lod_from_uv_derivatives",
    "make_texture",
    "sample",
    "srgb_to_linear",
    "uv_derivatives",
]

EXTENSIONS = ("REPEAT", "EXTEND", "CLIP", "MIRROR")
INTERPOLATIONS = ("Linear", "Closest", "Cubic", "Smart")

# UV change per pixel reported where the ray differential is undefined (neighbour ray parallel
# to the triangle's plane, zero-area triangle or UV triangle): one whole texture per pixel, which
# puts the lod at (or beyond) the coarsest level of any texture.
DEGENERATE_DUV = 1.0


# ---------------------------------------------------------------------------------------------
# sRGB transfer functions (IEC 61966-2-1)


def srgb_to_linear(x):
    """Decode sRGB-encoded values to linear: x / 12.92 below 0.04045, ((x + 0.055) / 1.055)^2.4
    above (IEC 61966-2-1).

    x:       any shape, encoded values (negative values stay on the linear segment)
    returns: same shape, float32 linear values
    """
    x = np.asarray(x, np.float32)
    power = ((np.maximum(x, np.float32(0.04045)) + np.float32(0.055)) / np.float32(1.055)) ** (
        np.float32(2.4)
    )
    return np.where(x <= np.float32(0.04045), x / np.float32(12.92), power).astype(np.float32)


_SRGB_LUT = srgb_to_linear(np.arange(256, dtype=np.float32) / np.float32(255.0))
_NO_TABLE = np.empty(0, np.float32)
# linear values halfway between consecutive 8-bit sRGB codes: the nearest code of a value
_SRGB_HALFWAY = srgb_to_linear((np.arange(255, dtype=np.float64) + 0.5) / 255.0)


def linear_to_srgb(x):
    """Encode linear values to sRGB: 12.92 x below 0.0031308, 1.055 x^(1/2.4) - 0.055 above
    (IEC 61966-2-1).

    x:       any shape, linear values (negative values stay on the linear segment)
    returns: same shape, float32 encoded values
    """
    x = np.asarray(x, np.float32)
    power = np.float32(1.055) * np.maximum(x, np.float32(0.0031308)) ** np.float32(
        1.0 / 2.4
    ) - np.float32(0.055)
    return np.where(x <= np.float32(0.0031308), x * np.float32(12.92), power).astype(np.float32)


# ---------------------------------------------------------------------------------------------
# Textures and mip chains


@dataclass
class _Fill:
    pending: bool
    lock: threading.Lock


def _check_sampling(extension: str, interpolation: str) -> None:
    if extension not in EXTENSIONS:
        raise ValueError(f"unknown texture extension {extension!r}, expected one of {EXTENSIONS}")
    if interpolation not in INTERPOLATIONS:
        raise ValueError(
            f"unknown texture interpolation {interpolation!r}, expected one of {INTERPOLATIONS}"
        )


class Texture:
    """An image texture and its mip chain, filled when a look-up first needs it.

    Texels are float32 (scene-linear, or Non-Color data) or, for 8-bit images kept at their
    stored precision, uint8 codes (value = code / 255). The first ``encoded`` channels of level
    0 are sRGB-encoded (``linear`` decodes); the other levels of a float texture are linear,
    those of an 8-bit texture hold sRGB codes in the ``encoded`` channels (filtered in linear,
    encoded again, as GPUs store sRGB mips).

    mips:          list of (h_k, w_k, C) arrays, row 0 at the top; mips[0] is the image, the
                   last level is 1 x 1 (reading ``mips`` fills a pending chain)
    extension:     "REPEAT", "EXTEND", "CLIP" or "MIRROR" (Image Texture node's Extension)
    interpolation: "Linear", "Closest", "Cubic" or "Smart" (Cubic, as Cycles)
    name:          the image's name, for messages
    pending:       levels 1, 2, ... are not filled yet (``make_texture``'s chains)
    """

    def __init__(self, mips: list[np.ndarray], extension: str = "REPEAT",
                 interpolation: str = "Linear", name: str = "", encoded: int = 0,
                 pending: bool = False):
        self._levels = list(mips)
        self.extension = extension
        self.interpolation = interpolation
        self.name = name
        self.encoded = encoded
        # whether levels 1, 2, ... are still to be filled, and the lock of filling them:
        # shared with the textures of ``sampled_as``
        self._fill = _Fill(pending and len(self._levels) > 1, threading.Lock())

    def sampled_as(self, extension: str, interpolation: str) -> Texture:
        """This texture read with another extension and interpolation: the same levels (one
        chain in memory, filled once); itself when they are its own."""
        if (extension, interpolation) == (self.extension, self.interpolation):
            return self
        _check_sampling(extension, interpolation)
        other = copy.copy(self)
        other.extension, other.interpolation = extension, interpolation
        return other

    @property
    def mips(self) -> list[np.ndarray]:
        """Every level, filled (``fill_mips``)."""
        self.fill_mips()
        return self._levels

    @property
    def image(self) -> np.ndarray:
        """Level 0, (H, W, C) as stored."""
        return self._levels[0]

    @property
    def pending(self) -> bool:
        """Whether levels 1, 2, ... are still to be filled."""
        return self._fill.pending

    @property
    def codes(self) -> bool:
        """Whether the texels are 8-bit codes (uint8) rather than float32."""
        return self._levels[0].dtype == np.uint8

    def fill_mips(self) -> None:
        """Fill levels 1, 2, ... once, each the area-weighted box filter of the one above
        (``kernels.textures.halve``, ``halve_bytes`` for 8-bit codes); safe across threads."""
        if not self._fill.pending:
            return
        from ..kernels import textures as kernels

        with self._fill.lock:
            if not self._fill.pending:
                return
            levels = self._levels
            for k, (above, level) in enumerate(zip(levels[:-1], levels[1:], strict=True)):
                if self.codes:
                    kernels.halve_bytes(above, level, self.encoded, _SRGB_LUT, _SRGB_HALFWAY)
                else:
                    kernels.halve(self.linear(0) if k == 0 and self.encoded else above, level)
            self._fill.pending = False

    def linear(self, k: int = 0) -> np.ndarray:
        """Mip level k, (h_k, w_k, C) float32 scene-linear (sRGB codes and encoded channels
        decoded)."""
        level = self.mips[k] if k else self._levels[0]
        if self.codes:
            out = level * np.float32(1.0 / 255.0)
            if self.encoded:
                out[..., :self.encoded] = _SRGB_LUT[level[..., :self.encoded]]
            return out
        if k or not self.encoded:
            return level
        out = level.copy()
        out[..., :self.encoded] = srgb_to_linear(np.maximum(level[..., :self.encoded], 0.0))
        return out

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) of level 0 in texels."""
        h, w = self._levels[0].shape[:2]
        return w, h

    @property
    def channels(self) -> int:
        """Number of channels C."""
        return self._levels[0].shape[2]

    @property
    def levels(self) -> int:
        """Number of mip levels."""
        return len(self._levels)

    @property
    def nbytes(self) -> int:
        """Bytes of the whole chain once filled."""
        return sum(m.nbytes for m in self._levels)

    @functools.cached_property
    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The mip chain as ``kernels.textures.sample`` reads it: every level's texels in one
        flat array (float32 or uint8), and (levels, 3) int64 rows (offset, height, width). A
        chain of ``make_texture`` already lies in one array, which is returned without a copy
        (levels still pending are filled in place later)."""
        levels = self._levels
        sizes = np.array([m.size for m in levels], np.int64)
        offsets = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        shapes = np.array([m.shape[:2] for m in levels], np.int64)
        rows = np.ascontiguousarray(np.column_stack([offsets, shapes]), np.int64)
        dtype = levels[0].dtype
        flat = levels[0].base
        if not (isinstance(flat, np.ndarray) and flat.dtype == dtype and flat.ndim == 1
                and flat.size == sizes.sum()
                and all(m.base is flat and m.flags.c_contiguous
                        and m.ctypes.data == flat.ctypes.data + dtype.itemsize * int(o)
                        for m, o in zip(levels, offsets, strict=True))):
            flat = np.concatenate([np.ascontiguousarray(m, dtype).reshape(-1)
                                   for m in self.mips])
        return flat, rows

    @functools.cached_property
    def digest(self) -> str:
        """A digest of level 0's stored values, computed once: equal images have equal
        digests (a float image's is the one bakes have always recorded)."""
        level = np.ascontiguousarray(self._levels[0])
        return hashlib.blake2b(memoryview(level).cast("B"), digest_size=16).hexdigest()


def _chain(shape, dtype=np.float32) -> list[np.ndarray]:
    """Empty levels (h_k, w_k, C) of a mip chain of an (H, W, C) image, views in order of one
    flat array (``Texture.packed``): h_{k+1} = max(1, h_k // 2), same for w. Pages of levels
    not yet written take no memory."""
    shapes = [tuple(shape)]
    while shapes[-1][0] > 1 or shapes[-1][1] > 1:
        h, w, c = shapes[-1]
        shapes.append((max(1, h // 2), max(1, w // 2), c))
    flat = np.empty(sum(h * w * c for h, w, c in shapes), dtype)
    levels, at = [], 0
    for h, w, c in shapes:
        levels.append(flat[at:at + h * w * c].reshape(h, w, c))
        at += h * w * c
    return levels


def build_mips(image: np.ndarray) -> list[np.ndarray]:
    """The mip chain of an image, from the image itself down to 1 x 1 (Williams 1983): each
    level the area-weighted box filter of the one above (``kernels.textures.halve``).

    image:   (H, W, C) float32
    returns: list of (h_k, w_k, C) float32 with h_{k+1} = max(1, h_k // 2), same for w, views
             of one flat array
    """
    levels = _chain(np.shape(image))
    levels[0][...] = np.asarray(image, np.float32)
    return Texture(levels, pending=True).mips


PREPARE_BAND = 1 << 20  # values per thread, at least, when an image is copied


def make_texture(
    pixels,
    *,
    srgb: bool,
    extension: str = "REPEAT",
    interpolation: str = "Linear",
    name: str = "",
) -> Texture:
    """A texture from an image; its mip chain is filled when a look-up first needs it.

    pixels:        (H, W, C) or (H, W) image, row 0 at the top, C in {1, 3, 4}: uint8 codes
                   (kept 8-bit) or floats (kept float32, non-finite values replaced by 0)
    srgb:          True when the values are sRGB-encoded colour: the colour channels (all of
                   C = 1 or 3, the first three of C = 4; never alpha) are decoded to linear
                   (IEC 61966-2-1) after each bilinear look-up of level 0, as Cycles does, and
                   filtered in linear for the other levels. False for linear or Non-Color data
    extension:     one of ``EXTENSIONS``
    interpolation: one of ``INTERPOLATIONS``
    returns:       Texture with straight-alpha levels
    """
    _check_sampling(extension, interpolation)
    from ..kernels import textures as kernels

    image = np.asarray(pixels)
    if image.dtype != np.uint8:
        image = image.astype(np.float32, copy=False)
    if image.ndim == 2:
        image = image[:, :, None]
    if image.ndim != 3 or image.shape[2] not in (1, 3, 4) or 0 in image.shape[:2]:
        raise ValueError(f"expected an (H, W, C) image with C in 1, 3, 4, got {image.shape}")
    levels = _chain(image.shape, image.dtype)
    level0 = levels[0]
    if image.dtype == np.uint8:
        level0[...] = image
    else:
        count = max(1, min(os.cpu_count() or 1, image.size // PREPARE_BAND))
        edges = np.linspace(0, image.shape[0], count + 1).astype(int)
        with ThreadPoolExecutor(count) as pool:  # row bands; the kernel releases Python's lock
            list(pool.map(lambda y0, y1: kernels.prepare(image[y0:y1], 0, _SRGB_LUT,
                                                         level0[y0:y1]), edges[:-1], edges[1:]))
    decode = min(image.shape[2], 3) if srgb else 0
    return Texture(levels, extension, interpolation, name, encoded=decode, pending=True)


# ---------------------------------------------------------------------------------------------
# Sampling


def sample(texture: Texture, uv, lod=None, associate: int = 0) -> np.ndarray:
    """Filtered texture lookups (Williams 1983 trilinear filtering, Blender's UV conventions):
    ``kernels.textures.sample``.

    Bilinear between the four texels around the position (texel centres at ((i + 0.5) / w,
    (j + 0.5) / h)), wrapped by the texture's extension as Cycles' wrap functions do (REPEAT,
    MIRROR, EXTEND clamps (and so does an unknown mode), CLIP reads 0 outside the image);
    "Closest" takes the nearest texel, "Cubic" and "Smart" the cubic B-spline of level 0 (as
    Cycles); with ``lod``, linear between the two nearest levels.

    texture: the texture
    uv:      (N, 2) UV; (0, 0) is the bottom-left corner of the image, (1, 1) the top-right,
             texel centres at ((i + 0.5) / w, (j + 0.5) / h) with j counted from the bottom;
             non-finite UVs read as (0, 0)
    lod:     None for level 0, or a scalar or (N,) level of detail (log2 of the footprint in
             level-0 texels), clamped to [0, levels - 1]; NaN means the coarsest level
    associate: for RGBA textures, 0 filters the channels independently (data, channel-packed
             images); 1 filters colour times alpha and returns it (Cycles' Color output of an
             image with alpha when its Alpha output is not used); 2 divides that by the
             filtered alpha (Cycles' straight Color when the Alpha output is used)
    returns: (N, C) float32 scene-linear (sRGB level 0 decoded); with CLIP, 0 (all channels,
             alpha too) beyond half a texel outside the unit square
    """
    from ..kernels import textures as kernels

    uv = np.asarray(uv).reshape(-1, 2)
    u, v = (np.require(uv[:, k], np.float64, ["C", "W"]) for k in (0, 1))
    n = len(uv)
    texels, levels = texture.packed
    use_lod = lod is not None
    lod = np.require(np.broadcast_to(np.asarray(0.0 if lod is None else lod, np.float64), (n,)),
                     np.float64, ["C", "W"])
    mode = kernels.FILTERS.get(texture.interpolation, kernels.LINEAR)
    if texture.pending and use_lod and mode != kernels.CLOSEST and not (lod <= 0.0).all():
        texture.fill_mips()  # some look-up reaches level 1 (NaN: the coarsest level)
    out = np.empty((n, texture.channels), np.float32)
    kernels.sample(texels, levels, kernels.EXTENSIONS.get(texture.extension, kernels.EXTEND),
                   texture.channels, mode, u, v, lod, use_lod, texture.encoded, int(associate),
                   _SRGB_LUT if texture.codes else _NO_TABLE, out)
    return out


# ---------------------------------------------------------------------------------------------
# Level of detail from ray differentials


def lod_from_uv_derivatives(texture: Texture, duv_dx, duv_dy) -> np.ndarray:
    """Isotropic level of detail, lod = log2(max(|duv/dx * size|, |duv/dy * size|)).

    OpenGL 4.6 specification, section 8.14.1 (scale factor rho), with size = (w, h) of level 0.

    texture: the texture (only its level-0 size is used)
    duv_dx:  (N, 2) UV change for one pixel step in x
    duv_dy:  (N, 2) UV change for one pixel step in y
    returns: (N,) float32 lod, unclamped (``sample`` clamps it); non-finite derivatives give a
             lod beyond the coarsest level
    """
    size = np.array(texture.size, np.float64)
    a = np.linalg.norm(np.asarray(duv_dx, np.float64).reshape(-1, 2) * size, axis=-1)
    b = np.linalg.norm(np.asarray(duv_dy, np.float64).reshape(-1, 2) * size, axis=-1)
    rho = np.maximum(a, b)
    rho = np.where(np.isfinite(rho), rho, np.float64(texture.levels) * max(texture.size))
    return np.log2(np.maximum(rho, 1e-30)).astype(np.float32)


def uv_derivatives(
    tri_positions, tri_uvs, points, origin_dx, direction_dx, origin_dy, direction_dy
) -> tuple[np.ndarray, np.ndarray]:
    """UV screen derivatives by ray differentials (Igehy 1999, "Tracing ray differentials").

    The rays of the neighbouring pixels (x + 1 and y + 1) are intersected with the plane of the
    triangle under each shaded point; the UVs of the hit points, from their barycentric
    coordinates in that triangle, minus the point's UV are the derivatives. Rays are lines (a hit
    behind the origin still counts, so any point of a ray is a valid origin). Both camera kinds
    work: a perspective camera's rays share one origin (its position, or any point on each ray,
    such as the near-plane points of ``Camera.rays``) and differ in direction; an orthographic
    camera's rays share the direction ((3,) broadcasts) and differ in origin. With a
    ``core.scene.Camera`` and a pixel centre (x, y) in window coordinates:
    ``uv_derivatives(..., *cam.rays(x + 1, y), *cam.rays(x, y + 1))``.

    tri_positions: (N, 3, 3) world-space corners of the triangle under each point, metres
    tri_uvs:       (N, 3, 2) corner UVs
    points:        (N, 3) shaded points on those triangles, metres
    origin_dx:     (N, 3) or (3,) a point on the ray through the pixel to the right, metres
    direction_dx:  (N, 3) or (3,) direction of that ray (any length)
    origin_dy:     (N, 3) or (3,) a point on the ray through the next pixel in y, metres
    direction_dy:  (N, 3) or (3,) direction of that ray (any length)
    returns:       duv_dx, duv_dy, each (N, 2) float32 UV change per pixel step. Where a
                   neighbour ray is parallel to the plane, or the triangle or its UV triangle
                   has zero area, both are ``DEGENERATE_DUV`` in u and v (coarsest lod).
    """
    p = np.asarray(tri_positions, np.float64).reshape(-1, 3, 3)
    t = np.asarray(tri_uvs, np.float64).reshape(-1, 3, 2)
    q = np.asarray(points, np.float64).reshape(-1, 3)
    e1 = p[:, 1] - p[:, 0]
    e2 = p[:, 2] - p[:, 0]
    normal = np.cross(e1, e2)
    nn = np.einsum("nc,nc->n", normal, normal)
    f1 = t[:, 1] - t[:, 0]
    f2 = t[:, 2] - t[:, 0]
    uv_area = np.abs(f1[:, 0] * f2[:, 1] - f1[:, 1] * f2[:, 0])
    scale = np.maximum(np.einsum("nc,nc->n", e1, e1), np.einsum("nc,nc->n", e2, e2))
    uv_scale = np.maximum(np.einsum("nc,nc->n", f1, f1), np.einsum("nc,nc->n", f2, f2))
    bad = ~(nn > 1e-12 * scale * scale) | ~(uv_area > 1e-9 * uv_scale)
    safe_nn = np.where(bad, 1.0, nn)
    # Barycentric gradients: for s in the plane, s - p0 = b1 e1 + b2 e2 with
    # b1 = (s - p0) . (e2 x n) / |n|^2 and b2 = (s - p0) . (n x e1) / |n|^2.
    g1 = np.cross(e2, normal) / safe_nn[:, None]
    g2 = np.cross(normal, e1) / safe_nn[:, None]

    def uv_step(origin, direction):
        o = np.asarray(origin, np.float64)
        d = np.asarray(direction, np.float64)
        denom = np.einsum("nc,nc->n", normal, np.broadcast_to(d, q.shape))
        d_len = np.linalg.norm(np.broadcast_to(d, q.shape), axis=-1)
        parallel = ~(np.abs(denom) > 1e-9 * np.sqrt(nn) * d_len)
        dist = np.einsum("nc,nc->n", normal, q - o) / np.where(parallel, 1.0, denom)
        delta = o + dist[:, None] * d - q  # hit point minus shaded point, in the plane
        db1 = np.einsum("nc,nc->n", delta, g1)
        db2 = np.einsum("nc,nc->n", delta, g2)
        duv = db1[:, None] * f1 + db2[:, None] * f2
        broken = bad | parallel | ~np.isfinite(duv).all(axis=-1)
        return np.where(broken[:, None], DEGENERATE_DUV, duv), broken

    duv_dx, broken_x = uv_step(origin_dx, direction_dx)
    duv_dy, broken_y = uv_step(origin_dy, direction_dy)
    broken = (broken_x | broken_y)[:, None]
    duv_dx = np.where(broken, DEGENERATE_DUV, duv_dx)
    duv_dy = np.where(broken, DEGENERATE_DUV, duv_dy)
    return duv_dx.astype(np.float32), duv_dy.astype(np.float32)


# ---------------------------------------------------------------------------------------------
# Equirectangular (lat-long) mapping of the Environment Texture node


def direction_to_equirect_uv(d) -> np.ndarray:
    """UV of a direction in a lat-long image, as Blender's Environment Texture (Equirectangular).

    u = 0.5 - atan2(d_y, d_x) / (2 pi), v = 0.5 + atan2(d_z, hypot(d_x, d_y)) / pi (measured
    with Cycles renders, see the module docstring).

    d:       (..., 3) directions in Blender world axes (Z up), any non-zero length
    returns: (..., 2) float32 UV in [0, 1]; v = 1 is +Z (row 0 of a top-first image)
    """
    d = np.asarray(d, np.float64)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    u = 0.5 - np.arctan2(y, x) / (2.0 * np.pi)
    v = 0.5 + np.arctan2(z, np.hypot(x, y)) / np.pi
    return np.stack([u, v], -1).astype(np.float32)


def equirect_uv_to_direction(uv) -> np.ndarray:
    """Unit direction of a lat-long UV, the inverse of ``direction_to_equirect_uv``.

    uv:      (..., 2) UV of Blender's Environment Texture (Equirectangular)
    returns: (..., 3) float32 unit directions in Blender world axes (Z up)
    """
    uv = np.asarray(uv, np.float64)
    azimuth = 2.0 * np.pi * (0.5 - uv[..., 0])
    elevation = np.pi * (uv[..., 1] - 0.5)
    c = np.cos(elevation)
    return np.stack([c * np.cos(azimuth), c * np.sin(azimuth), np.sin(elevation)], -1).astype(
        np.float32
    )
