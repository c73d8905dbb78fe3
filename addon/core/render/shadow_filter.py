"""Shadow maps queried per shaded point (``shadows`` builds them): the fraction of a light that
reaches a surface point.

Filtering: percentage-closer filtering (Reeves, Salesin & Cook 1987, "Rendering antialiased
shadows with depth maps") with a fixed Vogel-spiral disc of taps rotated per point (one of 1024
angles picked by a white-noise hash of three words: the position's bits, or for a camera's
points their pixel, triangle and sample (``seeds``), which a GPU draws alike; results are
deterministic and do not depend on the other points of a query), and percentage-closer soft
shadows
(Fernando 2005, "Percentage-closer soft shadows"): a blocker search in the region where
blockers can hide part of the light, then a disc kernel whose radius at the receiver is the
penumbra half-width of a disc light,

- point, spot, area:  r = R (d_r - d_b) / d_b, R the light radius (area: half its diagonal);
- sun:                r = tan(angle / 2) (d_r - d_b), angle the sun's angular diameter;

never below ``MIN_FILTER_TEXELS`` texels, so hard shadows stay anti-aliased (points whose
search region is under 1.5 texels, and lights of zero size, get that one-texel kernel). Taps
are placed in the plane through the receiver perpendicular to the light ray, so the filtered
result of a disc kernel over a straight shadow edge is the visible fraction of a disc light.

Evaluation (the same result as comparing every tap, faster; ``kernels.shadows``, one point at
a time): the taps of a kernel land in a texel rectangle known from its radius whatever the
rotation. When it is at most 4 x 4 texels, each of its texels is compared first (all blocked
-> 0, none -> 1, without taps). Wider rectangles are first tested against the least and
greatest depth of the pyramid blocks over them (``ShadowMap.mips``) and the receiver-plane
depths at their corners: provably unblocked or blocked points skip their taps, and so does the
blocker search of points whose search region is blocked everywhere.

Bias (no acne, no peter-panning): every tap compares the stored depth with the depth of the
receiver's tangent plane along the ray through the centre of the texel it reads (receiver-plane
depth, exact for planar receivers whatever the slope), after moving the receiver along its
normal by ``NORMAL_OFFSET_TEXELS`` texels (normal offset: Holbert 2011, "Saying goodbye to
shadow acne"), which buys a depth margin of that offset divided by cos(theta) along the ray,
i.e. a slope-scaled bias that absorbs curvature, tessellation and shading normals. A small
constant bias (``DEPTH_BIAS_TEXELS`` texels plus ``DEPTH_BIAS_RELATIVE`` of the depth) covers
rounding. The tangent-plane depth is clamped to +-``MAX_SLOPE`` times the tap distance so that
grazing receivers stay bounded.
"""

from __future__ import annotations

import numpy as np

from .shadows import MIP_FIRST_LEVEL, ShadowMap, mip_layout

__all__ = ["constants", "packed", "pixel_seeds", "shadow_visibility", "FILTER_TABLES"]

NORMAL_OFFSET_TEXELS = 1.0  # receiver moved along its normal by this many texels (world size)
DEPTH_BIAS_TEXELS = 0.05  # constant depth bias, texels (world size at the receiver)
DEPTH_BIAS_RELATIVE = 2e-5  # constant depth bias, fraction of the receiver's depth (rounding)
MAX_SLOPE = 10.0  # receiver-plane depth clamped to +-MAX_SLOPE * tap distance (about 84 deg)
MIN_FILTER_TEXELS = 1.0  # smallest PCF kernel radius, texels
BLOCKER_TAPS = 16  # taps of the PCSS blocker search (the point's own ray and a disc of 15)
SEARCH_REFINEMENTS = 3  # min-depth pyramid look-ups that shrink the blocker search region
PCF_TAPS = 32  # taps of the PCF kernel of soft shadows (PCSS)
PCF_TAPS_HARD = 16  # taps of the one-texel kernel (lights of zero size, contact shadows)


def _vogel(n: int) -> np.ndarray:
    """(n, 2) float32 Vogel (golden-angle spiral) points, uniform over the unit disc."""
    k = np.arange(n) + 0.5
    r = np.sqrt(k / n)
    th = k * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(th), r * np.sin(th)], axis=1).astype(np.float32)


_BLOCKER_DISC = np.concatenate([np.zeros((1, 2), np.float32), _vogel(BLOCKER_TAPS - 1)])
_PCF_DISC = _vogel(PCF_TAPS)
_PCF_DISC_HARD = _vogel(PCF_TAPS_HARD)


_ROT_STEPS = 1024  # per-point rotations of the tap discs, 2 pi / _ROT_STEPS apart
_ROT_ANGLE = (np.arange(_ROT_STEPS) + 0.5) * (2.0 * np.pi / _ROT_STEPS)
_ROT_COS = np.cos(_ROT_ANGLE).astype(np.float32)
_ROT_SIN = np.sin(_ROT_ANGLE).astype(np.float32)
_FACES = np.float32([  # per cube face (columns): 0/1 of its major axis x, y, z; its sign
    [1, 1, 0, 0, 0, 0],
    [0, 0, 1, 1, 0, 0],
    [0, 0, 0, 0, 1, 1],
    [1, -1, 1, -1, 1, -1],
])
_SLACK = 1e-3  # texels (plus 1e-6 res) added to footprint bounds (rounding of tap positions)


def _disc_reach(disc: np.ndarray) -> float:
    """Largest distance of a disc's taps from its centre, a little enlarged (footprints)."""
    return float(np.sqrt((disc.astype(np.float64) ** 2).sum(1)).max()) * (1.0 + 1e-5)


_PCF_REACH = _disc_reach(_PCF_DISC)
_PCF_REACH_HARD = _disc_reach(_PCF_DISC_HARD)


def _cascades(sm: ShadowMap) -> np.ndarray:
    """(F, 4) float32 rows (cx, cy, half side, z_min) of a sun's cascades; (0, 4) else."""
    rects = np.reshape(sm.rects, (-1, 3))
    z_min = sm.z_min if len(sm.z_min) == len(rects) else np.zeros(len(rects))
    return np.ascontiguousarray(np.column_stack([rects, z_min]), np.float32)


def constants(sm: ShadowMap) -> tuple:
    """The map's constants as the visibility kernel (and the GPU's filter) take them: pyramid
    offsets and sides (L,), basis (3, 3), cascades (C, 4), cube faces (4, 6), fparams
    (``kernels.shadows.P_*``), iparams (``I_*``). A map drawn on a GPU (``on_gpu``) has the
    pyramid's layout of its resolution and no least depth (the GPU reads it from the pyramid)."""
    from ..kernels import shadows as kernels

    res = sm.resolution
    kind = {"CUBE": kernels.CUBE, "PERSPECTIVE": kernels.PERSPECTIVE, "ORTHO": kernels.ORTHO}
    offsets, sides = (mip_layout(res, sm.depth.shape[0]) if len(sm.mips) or sm.on_gpu
                      else ([], []))
    ortho = sm.kind == "ORTHO"
    inv = np.float32(2.0 / res)
    fp = np.zeros(kernels.P_SIZE_ALL, np.float32)
    fp[kernels.P_TAN] = sm.tan_half
    fp[kernels.P_HALF_RES] = 0.5 * res
    fp[kernels.P_NEAR] = sm.near
    fp[kernels.P_NEAR2] = 2.0 * sm.near
    fp[kernels.P_OFFSET] = NORMAL_OFFSET_TEXELS * 2.0 * (1.0 if ortho else sm.tan_half) / res
    fp[kernels.P_TEXEL] = 2.0 * sm.tan_half / res
    fp[kernels.P_INV] = inv
    fp[kernels.P_SIZE] = sm.light_size
    fp[kernels.P_MIN_DEPTH] = sm.min_depth
    fp[kernels.P_SLACK] = _SLACK + 1e-6 * res
    fp[kernels.P_CAP] = 0.125 * res
    if ortho and sm.max_filter > 0.0 and len(sm.rects):
        texel = 2.0 * float(np.min(np.reshape(sm.rects, (-1, 3))[:, 2])) / res
        fp[kernels.P_CAP] = min(fp[kernels.P_CAP], max(sm.max_filter / texel, 1.0))
    fp[kernels.P_NEAR_FLOOR] = max(sm.near, 1e-12)
    fp[kernels.P_OX : kernels.P_OZ + 1] = sm.origin
    fp[kernels.P_HALF_INV] = 0.5 * inv - 1.0
    fp[kernels.P_ONE_HALF_INV] = 1.0 - 0.5 * inv
    fp[kernels.P_MAX_SLOPE] = MAX_SLOPE
    fp[kernels.P_BIAS_REL] = DEPTH_BIAS_RELATIVE
    fp[kernels.P_BIAS_TEXELS] = DEPTH_BIAS_TEXELS
    fp[kernels.P_MIN_FILTER] = MIN_FILTER_TEXELS
    ip = np.zeros(kernels.I_SIZE, np.int64)
    ip[kernels.I_KIND], ip[kernels.I_RES], ip[kernels.I_LEVELS] = kind[sm.kind], res, len(sides)
    ip[kernels.I_MIP_FIRST], ip[kernels.I_REFINEMENTS] = MIP_FIRST_LEVEL, SEARCH_REFINEMENTS
    ip[kernels.I_SKIP] = 1
    return (np.asarray(offsets, np.int64), np.asarray(sides, np.int64),
            np.ascontiguousarray(sm.basis[0], np.float32), _cascades(sm), _FACES, fp, ip)


def packed(sm: ShadowMap) -> tuple:
    """The map's arrays and constants as the visibility kernel takes them, built once: depth
    (F*res*res,), mips (M*3,), then ``constants``."""
    if sm.kernel_args is not None:
        return sm.kernel_args
    if sm.on_gpu:
        raise ValueError("this shadow map is drawn on a GPU: the CPU has no depths to filter")
    packed = (sm.depth.reshape(-1), np.ascontiguousarray(sm.mips.reshape(-1), np.float32),
              *constants(sm))
    sm.kernel_args = packed
    return packed


_REACHES = np.float32([1.0, _PCF_REACH, _PCF_REACH_HARD])

# The filter's constant tables, for another backend: the tap discs (K, 2) float32, their
# reaches (``_disc_reach``), the disc rotations' cosines and sines (_ROT_STEPS,) float32
FILTER_TABLES = {"blocker_disc": _BLOCKER_DISC, "pcf_disc": _PCF_DISC, "hard_disc": _PCF_DISC_HARD,
                 "pcf_reach": _PCF_REACH, "hard_reach": _PCF_REACH_HARD, "rot_cos": _ROT_COS,
                 "rot_sin": _ROT_SIN, "search_refinements": SEARCH_REFINEMENTS}


def shadow_visibility(
    shadow_map: ShadowMap, points: np.ndarray, normals: np.ndarray, *, jitter: bool = True,
    where: np.ndarray | None = None, seeds: np.ndarray | None = None,
    how: np.ndarray | None = None, skip: bool = True,
) -> np.ndarray:
    """Fraction of the light that reaches each point (PCF, Reeves 1987; PCSS, Fernando 2005).

    shadow_map: output of ``build_shadow_map``
    points:     (N, 3) float32 world-space receiver positions, metres
    normals:    (N, 3) unit normals at the points, either side (geometric normals make the
                receiver planes exact; shading normals are absorbed by the normal offset)
    jitter:     rotate the tap disc per point by a hash of its position (noise rather than
                banding in wide penumbrae); False uses one fixed rotation
    where:      (N,) bool: only these points are queried (the others get 1), or None for all
    seeds:      (N, 3) uint32 words hashed into each point's rotation (``pixel_seeds``), or
                None: the position's float32 bits
    how:        (N,) uint8 filled with how each point was decided (``kernels.shadows.HOW_*``:
                e.g. the share of soft-shadowed points whose blocker search the pyramid
                skipped), or None
    skip:       let the pyramid prove a search region lit or dark (False: every soft-shadowed
                point searches; the same results, for measuring the saving)
    returns:    (N,) float32 in [0, 1], 1 = fully lit; points outside every map, and points
                with non-finite coordinates, are lit
    """
    from ..kernels import shadows as kernels

    p = np.require(np.asarray(points, np.float32).reshape(-1, 3), np.float32, ["C", "W"])
    n = np.require(np.asarray(normals, np.float32).reshape(-1, 3), np.float32, ["C", "W"])
    if len(n) != len(p) or (where is not None and np.shape(where) != (len(p),)):
        raise ValueError(f"points {p.shape}, normals {n.shape} and where "
                         f"{np.shape(where) if where is not None else None} do not match")
    out = np.ones(len(p), np.float32)
    if shadow_map is None or shadow_map.depth.shape[0] == 0 or not len(p):
        return out
    depth, mips, offsets, sides, basis, rects, faces, fp, ip = packed(shadow_map)
    ip = ip.copy()
    ip[kernels.I_JITTER] = bool(jitter)
    ip[kernels.I_SKIP] = bool(skip)
    active = (np.ones(len(p), bool) if where is None else
              np.require(np.asarray(where, bool), bool, ["C", "W"]))
    bits = p.view(np.uint32) if seeds is None else np.require(seeds, np.uint32, ["C"])
    if bits.shape != p.shape:
        raise ValueError(f"seeds {bits.shape} do not match points {p.shape}")
    if how is None:
        how = np.empty(len(p), np.uint8)
    elif how.shape != (len(p),) or how.dtype != np.uint8:
        raise ValueError(f"how {how.shape} {how.dtype}: expected ({len(p)},) uint8")
    kernels.visibility(depth, mips, offsets, sides, basis, rects, faces, fp, ip, _BLOCKER_DISC,
                       _PCF_DISC, _PCF_DISC_HARD, _REACHES, _ROT_COS, _ROT_SIN, p, n, bits,
                       active, out, how)
    return out


def pixel_seeds(x: np.ndarray, y: np.ndarray, tri: np.ndarray, sample: np.ndarray
                ) -> np.ndarray:
    """(N, 3) uint32 rotation seeds of points a camera sees: pixel column ``x`` and row ``y``
    (N,) (under 65536), the triangle ``tri`` (N,) and the sample's number ``sample`` (N,) of
    the point shaded. A GPU shading the same pixel, triangle and sample turns its taps alike,
    wherever its rasterizer puts the point within the float32 rounding."""
    out = np.empty((len(tri), 3), np.uint32)
    out[:, 0] = np.asarray(x, np.uint32) | (np.asarray(y, np.uint32) << np.uint32(16))
    out[:, 1] = np.asarray(tri, np.uint32)
    out[:, 2] = np.asarray(sample, np.uint32)
    return out
