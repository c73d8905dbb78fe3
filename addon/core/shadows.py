"""Shadow maps and their filtering: depth maps rendered from each light, queried per shaded point.

The talk's direct lighting needs a visibility term that the talk itself does not cover; this
module supplies it with the standard real-time techniques listed below: the fraction of a light
that reaches a surface point, from depth maps rendered with ``raster``.

Maps (Williams 1978, "Casting curved shadows on curved surfaces"):

- point and area lights: a cube map, six 90-degree perspective faces at the light's position
  (area lights light only the hemisphere in front; ``shade`` applies that);
- spot lights: one perspective map whose field of view covers the cone, or a cube map when the
  cone is wider than ``SPOT_MAX_FOV``;
- sun: 1 to 4 orthographic cascades (cascaded / parallel-split shadow maps: Dimitrov 2007,
  "Cascaded shadow maps"; Engel 2006, ShaderX5; Zhang et al. 2006, "Parallel-split shadow maps
  for large-scale virtual environments"). The camera frustum, clipped in view depth to the
  bounding box of the casters, is split with Zhang's practical scheme (a blend of logarithmic
  and uniform splits) into as many cascades as its depth ratio needs; each cascade is a square
  orthographic map fitted to its slice (clipped to the casters' extent) and reaching towards the
  light over every caster.

Perspective maps store the depth along the face axis (clip w, metres); cascades store the depth
along the sun's direction (metres). Casters are two-sided (no culling); empty texels hold +inf.

Filtering: percentage-closer filtering (Reeves, Salesin & Cook 1987, "Rendering antialiased
shadows with depth maps") with a fixed Vogel-spiral disc of taps rotated per point (one of 1024
angles picked by a white-noise hash of the position's bits, so results are deterministic and do
not depend on the other points of a query), and percentage-closer soft shadows
(Fernando 2005, "Percentage-closer soft shadows"): a blocker search in the region where
blockers can hide part of the light, then a disc kernel whose radius at the receiver is the
penumbra half-width of a disc light,

- point, spot, area:  r = R (d_r - d_b) / d_b, R the light radius (area: half its diagonal);
- sun:                r = tan(angle / 2) (d_r - d_b), angle the sun's angular diameter;

never below ``MIN_FILTER_TEXELS`` texels, so hard shadows stay anti-aliased (points whose
search region is under 1.5 texels, and lights of zero size, get that one-texel kernel). Taps
are placed in the plane through the receiver perpendicular to the light ray, so the filtered
result of a disc kernel over a straight shadow edge is the visible fraction of a disc light.

Evaluation (the same result as comparing every tap, faster): the taps of a kernel land in a
texel rectangle known from its radius whatever the rotation. When it is at most 4 x 4 texels,
each of its texels is compared once and the taps read those results (all blocked -> 0, none ->
1, without taps). Wider rectangles are first tested against the least and greatest depth of
the pyramid blocks over them (``ShadowMap.mips``) and the receiver-plane depths at their
corners: provably unblocked or blocked points skip their taps, and so does the blocker search
of points whose search region is blocked everywhere.

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

from dataclasses import dataclass, field

import numpy as np

from . import raster
from .scene import Camera, Light

__all__ = ["ShadowMap", "build_shadow_map", "shadow_visibility"]

NORMAL_OFFSET_TEXELS = 1.0  # receiver moved along its normal by this many texels (world size)
DEPTH_BIAS_TEXELS = 0.05  # constant depth bias, texels (world size at the receiver)
DEPTH_BIAS_RELATIVE = 2e-5  # constant depth bias, fraction of the receiver's depth (rounding)
MAX_SLOPE = 10.0  # receiver-plane depth clamped to +-MAX_SLOPE * tap distance (about 84 deg)
MIN_FILTER_TEXELS = 1.0  # smallest PCF kernel radius, texels
BLOCKER_TAPS = 16  # taps of the PCSS blocker search (the point's own ray and a disc of 15)
SEARCH_REFINEMENTS = 3  # min-depth pyramid look-ups that shrink the blocker search region
MIP_FIRST_LEVEL = 3  # finest level of the pyramid kept (8 x 8 texel blocks)
PCF_TAPS = 32  # taps of the PCF kernel of soft shadows (PCSS)
PCF_TAPS_HARD = 16  # taps of the one-texel kernel (lights of zero size, contact shadows)
SPOT_MAX_FOV = np.radians(170.0)  # wider spot cones use a cube map
CASCADE_RATIO = 4.0  # far / near depth ratio one sun cascade may cover
MAX_CASCADES = 4
SPLIT_LAMBDA = 0.75  # practical split scheme: weight of the logarithmic split (Zhang 2006)
FLAG_SIDE = 4  # kernels within FLAG_SIDE x FLAG_SIDE texels: each texel compared once
COMPACT = 0.8  # a stage copies out the points it needs only when under this fraction of them
FLAT_PAIRS = 1 << 13  # below this many (point, tap) pairs, all are compared in one pass
CHUNK = 1 << 15  # query points processed at once (bounds temporaries)


def _vogel(n: int) -> np.ndarray:
    """(n, 2) float32 Vogel (golden-angle spiral) points, uniform over the unit disc."""
    k = np.arange(n) + 0.5
    r = np.sqrt(k / n)
    th = k * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(th), r * np.sin(th)], axis=1).astype(np.float32)


_BLOCKER_DISC = np.concatenate([np.zeros((1, 2), np.float32), _vogel(BLOCKER_TAPS - 1)])
_PCF_DISC = _vogel(PCF_TAPS)
_PCF_DISC_HARD = _vogel(PCF_TAPS_HARD)


def _frame(forward: np.ndarray) -> np.ndarray:
    """(3, 3) float64 rows R, U, F: an orthonormal frame with F = forward and R x U = -F."""
    f = np.asarray(forward, np.float64)
    f = f / np.linalg.norm(f)
    up = np.array([0.0, 0.0, 1.0]) if abs(f[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    return np.stack([r, np.cross(r, f), f])


# Cube faces +X, -X, +Y, -Y, +Z, -Z; face index = 2 * major axis + (component < 0).
_CUBE = np.stack([_frame(s * np.eye(3)[a]) for a in range(3) for s in (1.0, -1.0)])


@dataclass
class ShadowMap:
    """Depth maps of one light.

    kind:       "CUBE" (6 faces), "PERSPECTIVE" (1 face, spot) or "ORTHO" (sun cascades)
    light_kind: the light's kind ("POINT", "SPOT", "SUN", "AREA")
    depth:      (F, res, res) float32 depth per face/cascade, metres, +inf where empty; face-axis
                depth (clip w) for perspective faces, depth along the sun direction for cascades
    view_proj:  (F, 4, 4) float64 world -> clip matrices (OpenGL convention) used to render them
    basis:      (F, 3, 3) float64 rows R, U, F of each face (F: its axis, away from the light)
    origin:     (3,) float64 light position (perspective maps)
    tan_half:   tangent of half the field of view of a perspective face
    near:       near plane of perspective faces, metres
    rects:      (F, 3) float64 cascade squares (cx, cy, half side) in the sun's (R, U) plane, m
    z_min:      light-space depth of the nearest caster (cascades), metres
    light_size: light radius R in metres (point, spot, area), or tan(angle / 2) (sun)
    splits:     (F + 1,) float64 camera view depths bounding the cascades, metres (sun)
    min_mips:   the first column of ``mips`` as one (F, side, side) view per level
    min_depth:  least value of the maps (nearest caster), metres
    mips:       (M, 3) float32 reduction pyramid of the maps, levels l = MIP_FIRST_LEVEL, ...
                until one texel, each (F, ceil(res / 2^l), ceil(res / 2^l)) blocks of 2^l x 2^l
                texels flattened (level, face, row, column): per block the least distance from the
                light (perspective) or light-space depth (cascades), the least and the greatest
                value of ``depth``, metres; bounds the blocker search and proves points fully lit
                or fully shadowed without taps (about 6% of the maps' memory)
    """

    kind: str
    light_kind: str
    depth: np.ndarray
    view_proj: np.ndarray
    basis: np.ndarray
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    tan_half: float = 1.0
    near: float = 0.0
    rects: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    z_min: float = 0.0
    light_size: float = 0.0
    splits: np.ndarray = field(default_factory=lambda: np.zeros(0))
    min_mips: list[np.ndarray] = field(default_factory=list)
    min_depth: float = 0.0
    mips: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))

    def __post_init__(self) -> None:
        if not self.min_mips and len(self.mips):
            self.min_mips = [
                self.mips[lo : lo + side * side * len(self.depth), 0].reshape(-1, side, side)
                for lo, side in zip(*_mip_layout(self.resolution, len(self.depth)), strict=True)
            ]

    @property
    def resolution(self) -> int:
        """Side of every map, texels."""
        return int(self.depth.shape[-1])

    @property
    def nbytes(self) -> int:
        """Bytes held by the depth maps and their pyramid."""
        return int(self.depth.nbytes + self.mips.nbytes)


# --------------------------------------------------------------------------------------------
# building


def _perspective(tan_half: float, near: float, far: float) -> np.ndarray:
    """(4, 4) OpenGL perspective matrix, square aspect."""
    f = 1.0 / tan_half
    return np.array(
        [
            [f, 0.0, 0.0, 0.0],
            [0.0, f, 0.0, 0.0],
            [0.0, 0.0, (far + near) / (near - far), 2.0 * far * near / (near - far)],
            [0.0, 0.0, -1.0, 0.0],
        ]
    )


def _view(basis: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """(4, 4) world -> view matrix of a frame (rows R, U, F) at ``origin``, looking down -Z."""
    rot = np.stack([basis[0], basis[1], -basis[2]])
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = -rot @ origin
    return m


def _homogeneous(tris: np.ndarray) -> np.ndarray:
    """(T, 3, 3) -> (T, 3, 4) float64 with w = 1."""
    return np.concatenate([tris, np.ones(tris.shape[:2] + (1,))], axis=-1)


def _mip_layout(res: int, faces: int) -> tuple[list[int], list[int]]:
    """Offsets (rows of ``ShadowMap.mips``) and sides of the pyramid levels MIP_FIRST_LEVEL, ..."""
    offsets, sides, side, level, row = [], [], res, 0, 0
    while side > 1:
        side, level = (side + 1) // 2, level + 1
        if level >= MIP_FIRST_LEVEL:
            offsets.append(row)
            sides.append(side)
            row += faces * side * side
    return offsets, sides


def _pyramid(dist: np.ndarray, depth: np.ndarray) -> list[np.ndarray]:
    """Reduction pyramid of one (res, res) map: levels MIP_FIRST_LEVEL, ... as (side, side, 3)
    float32 (least dist, least depth, greatest depth); odd sides are padded with texels that
    change no reduction."""
    levels = []
    cur, level = [dist, depth, depth], 0
    while cur[0].shape[-1] > 1:
        if cur[0].shape[-1] % 2:
            cur = [np.pad(c, ((0, 1), (0, 1)), constant_values=v)
                   for c, v in zip(cur, (np.inf, np.inf, -np.inf), strict=True)]
        cur = [
            op(op(c[0::2, 0::2], c[1::2, 0::2]), op(c[0::2, 1::2], c[1::2, 1::2]))
            for c, op in zip(cur, (np.minimum, np.minimum, np.maximum), strict=True)
        ]
        level += 1
        if level >= MIP_FIRST_LEVEL:
            levels.append(np.stack(cur, -1))
    return levels


def _flatten_pyramids(pyramids: list[list[np.ndarray]]) -> np.ndarray:
    """Per-face pyramids -> (M, 3) float32 rows ordered (level, face, row, column)."""
    rows = [np.stack(level).reshape(-1, 3) for level in zip(*pyramids, strict=True)]
    return np.concatenate(rows) if rows else np.zeros((0, 3), np.float32)


def _build_perspective(light: Light, tris: np.ndarray, res: int) -> ShadowMap:
    origin = np.asarray(light.position, np.float64)
    if light.kind == "AREA":
        size = 0.5 * float(np.hypot(*np.asarray(light.size, np.float64)[:2]))
    else:
        size = float(light.radius)
    fov = float(light.spot_size) * 1.05 + 0.02  # a little margin for the filter kernels
    if light.kind == "SPOT" and fov < SPOT_MAX_FOV:
        kind, basis, tan_half = "PERSPECTIVE", _frame(light.direction)[None], np.tan(0.5 * fov)
    else:
        kind, basis, tan_half = "CUBE", _CUBE, 1.0
    reach = float(np.sqrt(((tris - origin) ** 2).sum(-1)).max()) if len(tris) else 1.0
    far = 1.01 * reach + 1e-3
    near = max(1e-5 * far, 1e-6)
    proj = _perspective(tan_half, near, far)
    homog = _homogeneous(tris)
    centre = (np.arange(res) + 0.5) * (2.0 / res) - 1.0
    ray_len = np.sqrt(1.0 + tan_half**2 * (centre[:, None] ** 2 + centre[None, :] ** 2))
    ray_len = ray_len.astype(np.float32)  # distance from the light / face-axis depth
    depth = np.empty((len(basis), res, res), np.float32)
    view_proj = np.empty((len(basis), 4, 4))
    pyramids, min_depth = [], np.inf
    for f, frame in enumerate(basis):
        view_proj[f] = proj @ _view(frame, origin)
        frags = raster.rasterize(homog @ view_proj[f].T, res, res)
        depth[f] = frags.depth
        del frags
        dist = depth[f] * ray_len  # distance from the light, metres
        min_depth = min(min_depth, float(dist.min()))
        pyramids.append(_pyramid(dist, depth[f]))
    return ShadowMap(
        kind=kind,
        light_kind=light.kind,
        depth=depth,
        view_proj=view_proj,
        basis=basis.copy(),
        origin=origin,
        tan_half=float(tan_half),
        near=near,
        light_size=max(size, 0.0),
        mips=_flatten_pyramids(pyramids),
        min_depth=min_depth,
    )


def _camera_depth_range(camera: Camera, lo: np.ndarray, hi: np.ndarray):
    """Camera near/far frustum corners and the view-depth range of the box [lo, hi].

    returns: near corners (4, 3), far corners (4, 3) in camera space, near, far, and the
             depth range (z0, z1) of the box clamped to [near, far] (z0 >= z1 when empty)
    """
    ndc = np.array([[x, y, z, 1.0] for z in (-1.0, 1.0) for x, y in
                    ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    cs = ndc @ np.linalg.inv(np.asarray(camera.projection, np.float64)).T
    cs = cs[:, :3] / cs[:, 3:]
    near_c, far_c = cs[:4], cs[4:]
    n, f = -near_c[:, 2].mean(), -far_c[:, 2].mean()
    box = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                    for z in (lo[2], hi[2])])
    w2c = np.asarray(camera.world_to_camera, np.float64)
    depth = -(box @ w2c[2, :3] + w2c[2, 3])
    return near_c, far_c, n, f, max(n, depth.min()), min(f, depth.max())


def _fit_cascades(camera: Camera, basis: np.ndarray, tris: np.ndarray, res: int):
    """Cascade squares (C, 3) (cx, cy, half side) in the light's (R, U) plane and splits (C+1,).

    The camera's view-depth range, clipped to the casters' bounding box, is split with the
    practical scheme z_i = l z0 (z1/z0)^(i/C) + (1 - l)(z0 + (z1 - z0) i/C) (Zhang et al. 2006),
    with C = ceil(log(z1/z0) / log(CASCADE_RATIO)) in [1, MAX_CASCADES] (1 for an orthographic
    camera). Each slice's eight corners are projected onto the light plane; their bounding
    rectangle, clipped to the casters' extent, becomes a square with a 4-texel margin.
    """
    pts = tris.reshape(-1, 3)
    lo, hi = pts.min(0), pts.max(0)
    near_c, far_c, n, f, z0, z1 = _camera_depth_range(camera, lo, hi)
    if not z1 > z0:
        return np.zeros((0, 3)), np.zeros(0)
    z0 = max(z0, 1e-6)
    if camera.orthographic:
        count = 1
    else:
        count = int(np.clip(np.ceil(np.log(z1 / z0) / np.log(CASCADE_RATIO)), 1, MAX_CASCADES))
    i = np.arange(count + 1) / count
    splits = SPLIT_LAMBDA * z0 * (z1 / z0) ** i + (1.0 - SPLIT_LAMBDA) * (z0 + (z1 - z0) * i)
    splits[0], splits[-1] = z0, z1
    c2w = np.linalg.inv(np.asarray(camera.world_to_camera, np.float64))
    xy = pts @ basis[:2].T
    ext_lo, ext_hi = xy.min(0), xy.max(0)
    rects = []
    for a, b in zip(splits[:-1], splits[1:], strict=True):
        corners = np.concatenate(
            [near_c + (far_c - near_c) * ((z - n) / (f - n)) for z in (a, b)]
        )
        world = corners @ c2w[:3, :3].T + c2w[:3, 3]
        sxy = world @ basis[:2].T
        r_lo = np.maximum(sxy.min(0), ext_lo)
        r_hi = np.minimum(sxy.max(0), ext_hi)
        centre = 0.5 * (r_lo + r_hi)
        half = 0.5 * max(float((r_hi - r_lo).max()), 1e-6)
        half *= 1.0 + 8.0 / res
        rects.append([centre[0], centre[1], half])
    return np.array(rects), splits


def _build_sun(light: Light, tris: np.ndarray, camera: Camera, res: int) -> ShadowMap:
    basis = _frame(light.direction)
    tan_half = float(np.tan(0.5 * max(float(light.radius), 0.0)))
    if len(tris) and camera is not None:
        rects, splits = _fit_cascades(camera, basis, tris, res)
    elif len(tris):
        xy = tris.reshape(-1, 3) @ basis[:2].T
        lo, hi = xy.min(0), xy.max(0)
        half = 0.5 * max(float((hi - lo).max()), 1e-6) * (1.0 + 8.0 / res)
        rects, splits = np.array([[*(0.5 * (lo + hi)), half]]), np.zeros(0)
    else:
        rects, splits = np.zeros((0, 3)), np.zeros(0)
    zs = tris @ basis[2]  # (T, 3) depth of every corner along the light
    z_lo = float(zs.min()) if len(tris) else 0.0
    z_hi = float(zs.max()) if len(tris) else 1.0
    pad = 1e-3 * (z_hi - z_lo) + 1e-4
    z_lo, z_hi = z_lo - pad, z_hi + pad
    homog = _homogeneous(tris)
    depth = np.empty((len(rects), res, res), np.float32)
    view_proj = np.empty((len(rects), 4, 4))
    for c, (cx, cy, half) in enumerate(rects):
        m = np.zeros((4, 4))
        m[0, :3], m[0, 3] = basis[0] / half, -cx / half
        m[1, :3], m[1, 3] = basis[1] / half, -cy / half
        m[2, :3], m[2, 3] = basis[2] * (2.0 / (z_hi - z_lo)), -2.0 * z_lo / (z_hi - z_lo) - 1.0
        m[3, 3] = 1.0
        view_proj[c] = m
        frags = raster.rasterize(homog @ m.T, res, res)
        hit = frags.tri >= 0
        d = np.full((res, res), np.inf, np.float32)
        d[hit] = np.einsum("nk,nk->n", frags.bary[hit].astype(np.float64), zs[frags.tri[hit]])
        depth[c] = d
        del frags, hit, d
    return ShadowMap(
        kind="ORTHO",
        light_kind="SUN",
        depth=depth,
        view_proj=view_proj,
        basis=np.broadcast_to(basis, (len(rects), 3, 3)).copy(),
        rects=rects,
        z_min=z_lo,
        light_size=tan_half,
        splits=splits,
        mips=_flatten_pyramids([_pyramid(d, d) for d in depth]),
        min_depth=float(depth.min()) if depth.size else np.inf,
    )


def build_shadow_map(
    light: Light, triangles: np.ndarray, camera: Camera | None, *, resolution: int = 1024
) -> ShadowMap | None:
    """Render the depth maps of one light (Williams 1978; cascades: Zhang et al. 2006).

    light:      scene light; ``light.shadow`` False -> None
    triangles:  (T, 3, 3) float32 world-space corners of every shadow caster, metres (finite,
                non-degenerate); two-sided
    camera:     the frame's camera (fits the sun's cascades to the visible depth range); None
                gives the sun one cascade over every caster
    resolution: side of each face/cascade, texels (memory: 6 res^2 float32 for a cube map,
                up to 4 res^2 for the sun)
    returns:    ShadowMap, or None when the light casts no shadow
    """
    if not light.shadow:
        return None
    res = max(1, int(resolution))
    tris = np.asarray(triangles, np.float64).reshape(-1, 3, 3)
    if light.kind == "SUN":
        return _build_sun(light, tris, camera, res)
    return _build_perspective(light, tris, res)


# --------------------------------------------------------------------------------------------
# queries
#
# Every per-point quantity is a flat float32 array (structure of arrays): no (N, 3) dot products,
# no per-point matrices, no np.where over incoherent masks, and buffers reused across taps.

_NEG = np.float32(-1e-30)
_ROT_STEPS = 1024  # per-point rotations of the tap discs, 2 pi / _ROT_STEPS apart
_ROT_ANGLE = (np.arange(_ROT_STEPS) + 0.5) * (2.0 * np.pi / _ROT_STEPS)
_ROT_COS = np.cos(_ROT_ANGLE).astype(np.float32)
_ROT_SIN = np.sin(_ROT_ANGLE).astype(np.float32)
_FACE_SELECT = (  # per cube face: 0/1 of its major axis x, y, z and the sign along it
    np.float32([1, 1, 0, 0, 0, 0]),
    np.float32([0, 0, 1, 1, 0, 0]),
    np.float32([0, 0, 0, 0, 1, 1]),
    np.float32([1, -1, 1, -1, 1, -1]),
)
_SLACK = 1e-3  # texels (plus 1e-6 res) added to footprint bounds (rounding of tap positions)


def _disc_reach(disc: np.ndarray) -> float:
    """Largest distance of a disc's taps from its centre, a little enlarged (footprints)."""
    return float(np.sqrt((disc.astype(np.float64) ** 2).sum(1)).max()) * (1.0 + 1e-5)


_PCF_REACH = _disc_reach(_PCF_DISC)
_PCF_REACH_HARD = _disc_reach(_PCF_DISC_HARD)


def _rotation(p: np.ndarray, jitter: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per-point (cos, sin) float32 rotation of the tap discs for (n, 3) positions.

    jitter: a white-noise integer hash of the position's float32 bits picks one of _ROT_STEPS
    angles (deterministic); otherwise the identity.
    """
    if not jitter:
        return np.ones(len(p), np.float32), np.zeros(len(p), np.float32)
    bits = np.ascontiguousarray(p, np.float32).view(np.uint32).reshape(-1, 3)
    h = bits[:, 0] * np.uint32(0x9E3779B1)
    h ^= bits[:, 1] * np.uint32(0x85EBCA77)
    h ^= bits[:, 2] * np.uint32(0xC2B2AE3D)
    h ^= h >> np.uint32(16)  # finaliser of "lowbias32" (C. Wellons, hash-prospector)
    h *= np.uint32(0x7FEB352D)
    h ^= h >> np.uint32(15)
    h *= np.uint32(0x846CA68B)
    h ^= h >> np.uint32(16)
    k = h >> np.uint32(32 - 10)  # _ROT_STEPS = 2^10
    return _ROT_COS.take(k), _ROT_SIN.take(k)


def _cube_axes(x: np.ndarray, y: np.ndarray, z: np.ndarray):
    """Cube face (+X, -X, +Y, -Y, +Z, -Z) of directions and the selectors of ``_to_face``.

    returns: (n,) int32 face, and a tuple of float32 arrays: 0/1 per major axis (x, y, z),
             y - z, x + y, and the sign of the direction along its major axis
    """
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    xm = (ax >= ay) & (ax >= az)
    ym = (ay >= az) & ~xm
    zm = ~(xm | ym)
    fx, fy, fz = (m.astype(np.float32) for m in (xm, ym, zm))
    major = x * fx
    major += y * fy
    major += z * fz
    neg = major < 0.0
    face = ym.astype(np.int32)
    face += zm
    face += zm
    face *= 2
    face += neg
    sign = 1.0 - 2.0 * neg.astype(np.float32)
    return face, (fx, fy, fz, fy - fz, fx + fy, sign)


def _to_face(sel, x: np.ndarray, y: np.ndarray, z: np.ndarray):
    """World vectors (x, y, z) in the (R, U, F) frame of their cube face (``_cube_axes``).

    Faces are signed permutations of the axes: +X (-y, z, x), -X (y, z, -x), +Y (x, z, y),
    -Y (-x, z, -y), +Z (-x, y, z), -Z (x, y, -z); every product below is exact.
    """
    fx, fy, fz, fyz, fxy, sign = sel
    r = fyz * x
    r -= fx * y
    r *= sign
    u = y * fz
    u += z * fxy
    f = x * fx
    f += y * fy
    f += z * fz
    f *= sign
    return r, u, f


def _unit_normals(n: np.ndarray, ax, ay, az):
    """Unit normals (3 arrays) of (n, 3) ``n`` turned against ``a`` (from the light towards the
    point; arrays or scalars); zero normals become -a / |a|."""
    nx, ny, nz = n[:, 0], n[:, 1], n[:, 2]
    length = np.sqrt(nx * nx + ny * ny + nz * nz)
    bad = ~(length > 1e-6)
    flip = (nx * ax + ny * ay + nz * az) > 0.0
    scale = length * (1.0 - 2.0 * flip.astype(np.float32))
    scale[bad] = 1.0
    nx, ny, nz = nx / scale, ny / scale, nz / scale
    if bad.any():
        j = np.flatnonzero(bad)
        bx, by, bz = (np.broadcast_to(np.asarray(a, np.float32), n.shape[:1])[j]
                      for a in (ax, ay, az))
        inv = -1.0 / np.maximum(np.sqrt(bx * bx + by * by + bz * bz), np.float32(1e-12))
        nx[j], ny[j], nz[j] = bx * inv, by * inv, bz * inv
    return nx, ny, nz


class _Frame:
    """Per-point set-up of the tap loops; every array has one entry per point, (n,).

    A tap at offset o = a t1 + b t2 metres (t1, t2 perpendicular to the light ray) reads its
    point's own map ``m`` (flat offset ``base``) at texel coordinates col = cx + Jc1 a + Jc2 b,
    row = ry + Jr1 a + Jr2 b (linearized projection; exact for the sun). With the texel
    (col, row) it lands in, the depth of the receiver's tangent plane along the ray through the
    texel centre is K / (A + B col + C row) (perspective) or A + B col + C row (sun), clamped to
    w0 +- MAX_SLOPE (radius + texel). Taps that leave the map take the exact path
    (``_fallback``). The disc is turned per point by (c, s); ac, bc, ar, br are the texel
    gradients along the turned disc axes. ``subset`` gives a lazy frame of some points: arrays
    are copied on first use, once, from the full frame.
    """

    _parent = None
    _sel = None

    def subset(self, sel: np.ndarray) -> _Frame:
        out = _Frame()
        if self._parent is None:
            out._parent, out._sel = self, sel
        else:  # one copy per array from the full frame
            out._parent, out._sel = self._parent, self._sel.take(sel)
        return out

    def __getattr__(self, name: str):
        parent = self._parent
        if parent is None or name.startswith("__"):
            raise AttributeError(name)
        value = getattr(parent, name)
        if isinstance(value, np.ndarray):
            value = value.take(self._sel, axis=0)
        setattr(self, name, value)
        return value


def _finish_frame(fr: _Frame, res: int) -> None:
    """Derived per-point values: footprint extents per metre and the flat map offset."""
    fr.jc = np.sqrt(fr.Jc1 * fr.Jc1 + fr.Jc2 * fr.Jc2)  # texels per metre, any direction
    fr.jr = np.sqrt(fr.Jr1 * fr.Jr1 + fr.Jr2 * fr.Jr2)
    fr.base = fr.m.astype(np.intp) * (res * res)
    fr.mf = fr.m.astype(np.float32)  # map index for the pyramid rows


def _plane_in_texels(fr: _Frame, res: int, nf, bx, by) -> None:
    """Set A, B, C from a plane term nf + bx xc + by yc of ndc texel centres (xc, yc)."""
    inv = np.float32(2.0 / res)
    fr.A = nf + bx * (0.5 * inv - 1.0) + by * (1.0 - 0.5 * inv)
    fr.B = bx * inv
    fr.C = -by * inv


def _setup_perspective(sm: ShadowMap, p: np.ndarray, n: np.ndarray):
    """Frame of points for a cube or spot map; returns (indices of points inside, _Frame).

    Everything is computed in the (R, U, F) frame of the face that holds the point (cube faces
    are signed permutations of the world axes). The tangent frame t1, t2 of the taps is the
    one of Duff et al. (2017) built from the unit ray e in that frame (e.F > 0),
    t1 = (1 - eR^2 / (1 + eF), -eR eU / (1 + eF), -eR), t2 = (-eR eU / (1 + eF),
    1 - eU^2 / (1 + eF), -eU), so that the texel gradients along them take a closed form.
    """
    res, s = sm.resolution, np.float32(sm.tan_half)
    h = np.float32(0.5 * res)
    o = sm.origin.astype(np.float32)
    cube = sm.kind == "CUBE"
    dx, dy, dz = p[:, 0] - o[0], p[:, 1] - o[1], p[:, 2] - o[2]
    basis = sm.basis[0].astype(np.float32)
    if cube:  # face-axis depth
        w = np.maximum(np.maximum(np.abs(dx), np.abs(dy)), np.abs(dz))
    else:
        w = np.maximum(dx * basis[2, 0] + dy * basis[2, 1] + dz * basis[2, 2], 0.0)
    nx, ny, nz = _unit_normals(n, dx, dy, dz)
    w *= np.float32(NORMAL_OFFSET_TEXELS * 2.0 * sm.tan_half / res)  # normal offset, metres
    dx += nx * w
    dy += ny * w
    dz += nz * w
    if cube:
        face, sel = _cube_axes(dx, dy, dz)
        dr, du, w = _to_face(sel, dx, dy, dz)
        nr, nu, nf = _to_face(sel, nx, ny, nz)
    else:
        face = np.zeros(len(p), np.int32)
        dr, du, w = (dx * b[0] + dy * b[1] + dz * b[2] for b in basis)
        nr, nu, nf = (nx * b[0] + ny * b[1] + nz * b[2] for b in basis)
    dist = np.sqrt(dr * dr + du * du + w * w)
    ok = dist > 2.0 * sm.near
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_sw = 1.0 / (s * w)
        x0 = dr * inv_sw
        y0 = du * inv_sw
    if not cube:
        ok &= (w > sm.near) & (np.abs(x0) <= 1.0) & (np.abs(y0) <= 1.0)
    idx = np.flatnonzero(ok)
    if idx.size < len(p):
        dr, du, w, dist, inv_sw, nr, nu, nf, x0, y0, face = (
            a.take(idx) for a in (dr, du, w, dist, inv_sw, nr, nu, nf, x0, y0, face)
        )
    fr = _Frame()
    fr.m = face
    fr.cx, fr.ry = (x0 + 1.0) * h, (1.0 - y0) * h
    inv_d = 1.0 / dist
    er, eu, ef = dr * inv_d, du * inv_d, w * inv_d
    # d(col)/dX = h (R - s x0 F) / (s w), d(row)/dX = -h (U - s y0 F) / (s w), along t1, t2
    g = h * inv_sw
    q = g / (ef * (1.0 + ef))
    fr.Jc2 = er * eu * q
    fr.Jc1 = g + er * er * q
    fr.Jr1 = -fr.Jc2
    fr.Jr2 = -(g + eu * eu * q)
    fr.w0, fr.dist = w, dist
    fr.texel = np.float32(2.0 * sm.tan_half / res) * w  # world size of a texel at the receiver
    fr.K = dr * nr + du * nu + w * nf  # ray L + t dc (dc.F = 1) meets the plane at t = K / dc.n
    _plane_in_texels(fr, res, nf, s * nr, s * nu)
    fr.bias = DEPTH_BIAS_RELATIVE * w + DEPTH_BIAS_TEXELS * fr.texel
    fr.l1c = np.abs(fr.Jc1) + np.abs(fr.Jc2)
    fr.l1r = np.abs(fr.Jr1) + np.abs(fr.Jr2)
    if cube:  # for the exact look-ups of taps that leave the face
        fr.dr, fr.du, fr.nr, fr.nu, fr.nf = dr, du, nr, nu, nf
    _finish_frame(fr, res)
    return idx, fr


def _find_cascade(sm: ShadowMap, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N,) int32 finest cascade whose square holds light-plane points (x, y), or -1."""
    out = np.full(x.shape, -1, np.int32)
    free = np.ones(x.shape, bool)
    for c, (cx, cy, half) in enumerate(sm.rects.astype(np.float32)):
        inside = np.abs(x - cx) <= half
        inside &= np.abs(y - cy) <= half
        inside &= free
        free &= ~inside
        out += inside.astype(np.int32) * np.int32(c + 1)
    return out


def _setup_ortho(sm: ShadowMap, p: np.ndarray, n: np.ndarray):
    """Frame of points for sun cascades; returns (indices of points inside, _Frame)."""
    b = sm.basis[0].astype(np.float32)
    rects = sm.rects.astype(np.float32)
    res = sm.resolution
    h = np.float32(0.5 * res)
    nx, ny, nz = _unit_normals(n, *b[2])
    px, py, pz = p[:, 0], p[:, 1], p[:, 2]
    casc = _find_cascade(sm, px * b[0, 0] + py * b[0, 1] + pz * b[0, 2],
                         px * b[1, 0] + py * b[1, 1] + pz * b[1, 2])
    off = rects[:, 2].take(np.maximum(casc, 0)) * np.float32(NORMAL_OFFSET_TEXELS * 2.0 / res)
    px, py, pz = px + nx * off, py + ny * off, pz + nz * off
    x, y, z = (px * r[0] + py * r[1] + pz * r[2] for r in b)
    casc = _find_cascade(sm, x, y)
    idx = np.flatnonzero(casc >= 0)
    if idx.size < len(p):
        x, y, z, nx, ny, nz, casc = (a.take(idx) for a in (x, y, z, nx, ny, nz, casc))
    cx, cy, half = (rects[:, i].take(casc) for i in range(3))
    fr = _Frame()
    fr.m = casc
    g = h / half
    fr.cx, fr.ry = (x - cx) * g + h, h - (y - cy) * g
    zero = np.zeros_like(half)
    fr.Jc1, fr.Jc2, fr.Jr1, fr.Jr2 = g, zero, zero, -g
    fr.w0, fr.K = z, zero  # K: unused (the receiver depth is linear in the texel)
    fr.texel = np.float32(2.0 / res) * half
    nr, nu = (nx * r[0] + ny * r[1] + nz * r[2] for r in b[:2])
    nf = np.minimum(nx * b[2, 0] + ny * b[2, 1] + nz * b[2, 2], np.float32(-1e-6))
    # tangent plane: z = z0 - ((X - x) nR + (Y - y) nU) / nF at X = cx + xc half, Y = cy + yc half
    inv_nf = 1.0 / nf
    z0 = z - ((cx - x) * nr + (cy - y) * nu) * inv_nf
    _plane_in_texels(fr, res, z0, -half * nr * inv_nf, -half * nu * inv_nf)
    fr.bias = DEPTH_BIAS_RELATIVE * np.abs(z - np.float32(sm.z_min)) + DEPTH_BIAS_TEXELS * fr.texel
    fr.xw, fr.yw, fr.nr, fr.nu, fr.nf = x, y, nr, nu, nf
    fr.l1c, fr.l1r = g, g
    _finish_frame(fr, res)
    return idx, fr


def _fallback(sm: ShadowMap, fr: _Frame, j, u, v, r, span):
    """Exact look-up of taps that leave their point's own map.

    j: (k,) points; u, v: (k,) rotated unit-disc position of the tap; r: (k,) kernel radius,
    metres; span: (k,) clamp half-range of the receiver depth, metres
    returns: stored depth (k,) (+inf where no map holds the tap) and receiver-plane depth (k,)
    """
    res = sm.resolution
    stored = np.full(j.size, np.inf, np.float32)
    recv = np.full(j.size, np.inf, np.float32)
    if sm.kind == "PERSPECTIVE":
        return stored, recv  # outside the spot's frustum: unshadowed
    flat = sm.depth.reshape(-1)
    h = np.float32(0.5 * res)
    inv = np.float32(2.0 / res)
    if sm.kind == "CUBE":
        m = fr.m[j]
        dr, du, df, dist = fr.dr[j], fr.du[j], fr.w0[j], fr.dist[j]
        er, eu, ef = dr / dist, du / dist, df / dist
        k = -1.0 / (1.0 + ef)  # the tangent frame of ``_setup_perspective``
        ou, ov = r * u, r * v
        lr = dr + ou * (1.0 + er * er * k) + ov * (er * eu * k)
        lu = du + ou * (er * eu * k) + ov * (1.0 + eu * eu * k)
        lf = df - ou * er - ov * eu
        # face frame -> world (signed permutations, exact): +-X (F, -R, U), +-Y (R, F, U),
        # +-Z (-R, U, F), each axis times the face's sign where it carries F or the R of X/Y
        fx, fy, fz, sg = (table.take(m) for table in _FACE_SELECT)
        fyz, fxy = fy - fz, fx + fy
        nr, nu, nf = fr.nr[j], fr.nu[j], fr.nf[j]
        world = ((fx * lf + fyz * lr) * sg, (fy * lf - fx * lr) * sg + fz * lu,
                 fxy * lu + sg * fz * lf)
        normal = ((fx * nf + fyz * nr) * sg, (fy * nf - fx * nr) * sg + fz * nu,
                  fxy * nu + sg * fz * nf)
        g, sel = _cube_axes(*world)
        x, y, w = _to_face(sel, *world)
        nr, nu, nf = _to_face(sel, *normal)
        col = np.clip(np.floor((x / w + 1.0) * h), 0, res - 1)
        row = np.clip(np.floor((1.0 - y / w) * h), 0, res - 1)
        stored[:] = flat.take((g * res + row.astype(np.int32)) * res + col.astype(np.int32))
        xc, yc = (col + 0.5) * inv - 1.0, 1.0 - (row + 0.5) * inv
        den = np.minimum(nf + xc * nr + yc * nu, _NEG)
        recv[:] = np.clip(fr.K[j] / den, w - span, w + span)
        return stored, recv
    xw = fr.xw[j] + r * u  # sun: the finest other cascade that holds the tap
    yw = fr.yw[j] + r * v
    c = _find_cascade(sm, xw, yw)
    k = np.flatnonzero(c >= 0)
    if k.size:
        c, jk = c[k], j[k]
        cx, cy, half = (sm.rects[:, i].astype(np.float32).take(c) for i in range(3))
        col = np.clip(np.floor(((xw[k] - cx) / half + 1.0) * h), 0, res - 1)
        row = np.clip(np.floor((1.0 - (yw[k] - cy) / half) * h), 0, res - 1)
        stored[k] = flat.take((c * res + row.astype(np.int32)) * res + col.astype(np.int32))
        xs = cx + ((col + 0.5) * inv - 1.0) * half - fr.xw[jk]
        ys = cy + (1.0 - (row + 0.5) * inv) * half - fr.yw[jk]
        z = fr.w0[jk] - (xs * fr.nr[jk] + ys * fr.nu[jk]) / fr.nf[jk]
        recv[k] = np.clip(z, fr.w0[jk] - span[k], fr.w0[jk] + span[k])
    return stored, recv


def _taps(sm: ShadowMap, fr: _Frame, radius: np.ndarray, disc: np.ndarray, measure: bool,
          check: bool, free=None):
    """Compare one set of taps with the map around every point of ``fr``.

    radius:  (n,) kernel radius at the receiver, metres (perpendicular to the light ray)
    disc:    (K, 2) unit-disc tap positions, turned by the points' rotations (fr.c, fr.s)
    measure: also sum the blocker measure (perspective: d_blocker / d_receiver along the tap's
             ray; sun: d_receiver - d_blocker, metres)
    check:   some taps may leave their point's map (else every tap is known to stay inside)
    free:    (n,) bool or None: points whose receiver depth needs neither the clamp nor the
             guard of the plane term at any tap (``_block_test``): a shorter comparison
    returns: blocked tap count (n,) uint8 and the blocker measure sum (n,) float32 (or None)
    """
    n = len(radius)
    if n * len(disc) <= FLAT_PAIRS:
        return _tap_pairs(sm, fr, radius, disc, measure)
    if check or free is None or np.count_nonzero(free) < COMPACT * n:
        return _tap_loop(sm, fr, radius, disc, measure, check, False)
    count, acc = _tap_loop(sm, fr, radius, disc, measure, False, True)
    k = np.flatnonzero(~free)
    if k.size:  # redone with the clamp and the guard
        count[k], a = _tap_loop(sm, fr.subset(k), radius.take(k), disc, measure, False, False)
        if measure:
            acc[k] = a
    return count, acc


def _tap_pairs(sm: ShadowMap, fr: _Frame, radius: np.ndarray, disc: np.ndarray, measure: bool):
    """``_taps`` of few points: every (point, tap) pair at once, the same arithmetic as
    ``_tap_loop`` with its clamp, guard and exact look-ups (few numpy calls, no loop)."""
    res = sm.resolution
    flat = sm.depth.reshape(-1)
    persp = sm.kind != "ORTHO"
    n, taps = len(radius), len(disc)
    j = np.repeat(np.arange(n), taps)
    a, b = np.tile(disc[:, 0], n), np.tile(disc[:, 1], n)
    ac, bc, ar, br = (x.take(j) for x in _tap_axes(fr, radius))
    colf = ac * a
    colf += fr.cx.take(j)
    colf += bc * b
    rowf = ar * a
    rowf += fr.ry.take(j)
    rowf += br * b
    np.floor(colf, out=colf)
    np.floor(rowf, out=rowf)
    out = np.flatnonzero((np.minimum(colf, rowf) < 0.0) | (np.maximum(colf, rowf) >= res))
    index = np.clip(rowf, 0, res - 1).astype(np.intp) * res
    index += np.clip(colf, 0, res - 1).astype(np.intp)
    index += fr.base.take(j)
    stored = flat.take(index)
    t = colf * fr.B.take(j)
    t += fr.A.take(j)
    t += rowf * fr.C.take(j)
    span = MAX_SLOPE * (radius + fr.texel)
    w0 = fr.w0.take(j)
    sp = span.take(j)
    _receiver_depth(t, fr.K.take(j), w0 - sp, w0 + sp, persp)
    if out.size:
        jo = j[out]
        cj, sj = fr.c.take(jo), fr.s.take(jo)
        ao, bo = a[out], b[out]
        stored[out], t[out] = _fallback(sm, fr, jo, ao * cj - bo * sj, ao * sj + bo * cj,
                                        radius.take(jo), span.take(jo))
    hit = stored + fr.bias.take(j) < t
    count = np.bincount(j[hit], minlength=n).astype(np.uint8)
    acc = None
    if measure:
        val = stored[hit] / t[hit] if persp else t[hit] - stored[hit]
        acc = np.bincount(j[hit], weights=val, minlength=n).astype(np.float32)
    return count, acc


def _tap_loop(sm: ShadowMap, fr: _Frame, radius: np.ndarray, disc: np.ndarray, measure: bool,
              check: bool, fast: bool):
    """``_taps`` of one kind of points (fast: every point is ``free``): the compiled loop over
    taps (``kernels.shadows.taps``), then the exact path of the taps that left their map."""
    from .kernels import shadows as kernels

    res = sm.resolution
    persp = sm.kind != "ORTHO"
    npt = len(radius)
    span = MAX_SLOPE * (radius + fr.texel)
    count = np.zeros(npt, np.uint8)  # at most 255 taps
    acc = np.zeros(npt, np.float32)
    flags = np.zeros((len(disc) if check else 1, npt), bool)

    def f32(x):
        return np.ascontiguousarray(x, np.float32)

    kernels.taps(sm.depth.reshape(-1), res, persp, np.ascontiguousarray(fr.base, np.intp),
                 *(f32(x) for x in _tap_axes(fr, radius)), f32(fr.cx), f32(fr.ry), f32(fr.B),
                 f32(fr.C), f32(fr.A), f32(fr.K), f32(fr.bias), f32(fr.w0 - span),
                 f32(fr.w0 + span), np.ascontiguousarray(disc, np.float32), measure, check,
                 fast, _NEG, count, acc, flags)
    bias = fr.bias
    outside = [(k, np.flatnonzero(flags[k])) for k in range(len(disc))] if check else []
    outside = [(k, j) for k, j in outside if j.size]
    acc = acc if measure else None
    if outside:
        j_all = np.concatenate([j for _, j in outside])
        tap_all = np.concatenate([np.full(j.size, k, np.int32) for k, j in outside])
        for lo_j in range(0, j_all.size, CHUNK):  # bounded temporaries
            j, tap = j_all[lo_j : lo_j + CHUNK], tap_all[lo_j : lo_j + CHUNK]
            a, b = disc[tap, 0], disc[tap, 1]
            cj, sj = fr.c.take(j), fr.s.take(j)
            stored, recv = _fallback(sm, fr, j, a * cj - b * sj, a * sj + b * cj,
                                     radius.take(j), span.take(j))
            hit = stored + bias.take(j) < recv
            count += np.bincount(j[hit], minlength=npt).astype(np.uint8)
            if measure:
                val = stored[hit] / recv[hit] if persp else recv[hit] - stored[hit]
                acc += np.bincount(j[hit], weights=val, minlength=npt).astype(np.float32)
    return count, acc


def _level(width: np.ndarray) -> np.ndarray:
    """(n,) int32 max(ceil(log2(width)), MIP_FIRST_LEVEL) of float32 widths >= 1, from the
    exponent and mantissa bits (exact)."""
    bits = width.view(np.int32)
    level = bits >> 23
    level -= 127  # floor(log2(width))
    level += (bits & 0x7FFFFF) != 0
    np.maximum(level, np.int32(MIP_FIRST_LEVEL), out=level)
    return level


def _mip_levels(sm: ShadowMap) -> int:
    """Number of pyramid levels in ``sm.mips`` (0 without a pyramid)."""
    return len(_mip_layout(sm.resolution, sm.depth.shape[0])[0]) if len(sm.mips) else 0


def _mip_tables(sm: ShadowMap) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(offsets, sides) of the pyramid levels MIP_FIRST_LEVEL, ... in ``sm.mips`` and 2^-level
    per level, float32 (float64 for pyramids of 2^24 rows or more: exact integers)."""
    dtype = np.float32 if len(sm.mips) < 1 << 24 else np.float64
    offsets, sides = _mip_layout(sm.resolution, sm.depth.shape[0])
    scales = np.ldexp(1.0, -np.arange(32))
    return (np.asarray(offsets, dtype), np.asarray(sides, dtype), scales.astype(dtype))


def _mip_rows(sm: ShadowMap, m, level, c0, c1, r0, r1):
    """Rows (intp) of ``sm.mips`` of the 2 x 2 blocks of ``level`` (n,) int32 that hold the
    texel rectangles [c0, c1] x [r0, r1] (float32, c1 - c0 and r1 - r0 at most 2^level) of
    maps ``m``; float32 arithmetic, exact (every value is an integer below 2^24)."""
    offsets, sides, scales = _mip_tables(sm)
    li = level - np.int32(MIP_FIRST_LEVEL)
    side, offset, scale = sides.take(li), offsets.take(li), scales.take(level)
    ca, cb = np.floor(c0 * scale), np.floor(c1 * scale)
    first = m * side
    ra = first + np.floor(r0 * scale)
    ra *= side
    ra += offset
    rb = first + np.floor(r1 * scale)
    rb *= side
    rb += offset
    return tuple((r + c).astype(np.intp) for r, c in ((ra, ca), (ra, cb), (rb, ca), (rb, cb)))


def _footprint_min(sm: ShadowMap, fr: _Frame, radius: np.ndarray) -> np.ndarray:
    """Least map value in the square of half-side ``radius`` (n,) metres around each point.

    Reads the 2 x 2 texels of the min-depth pyramid level whose texels are at least as wide as
    the square; -inf where the square leaves the point's own map (unknown).
    """
    res = sm.resolution
    levels = _mip_levels(sm)
    if not levels:
        return np.full(len(radius), -np.inf, np.float32)
    rc = radius * fr.l1c
    rr = radius * fr.l1r
    c0, c1 = np.floor(fr.cx - rc), np.floor(fr.cx + rc)
    r0, r1 = np.floor(fr.ry - rr), np.floor(fr.ry + rr)
    ok = (c0 >= 0) & (c1 < res) & (r0 >= 0) & (r1 < res)
    width = np.maximum(c1 - c0, r1 - r0) + 1.0
    level = _level(width)
    top = np.int32(MIP_FIRST_LEVEL + levels - 1)
    ok &= level <= top
    np.minimum(level, top, out=level)
    flat = sm.mips.reshape(-1)  # (a column view would be copied by every take)
    rows = _mip_rows(sm, fr.mf, level, c0, c1, r0, r1)
    for r in rows:
        r *= 3
    best = flat.take(rows[0], mode="clip")  # rows of points that are not ok are discarded
    for r in rows[1:]:
        np.minimum(best, flat.take(r, mode="clip"), out=best)
    best[~ok] = -np.inf
    return best


def _search_radius(sm: ShadowMap, fr: _Frame) -> np.ndarray:
    """(n,) radius at the receiver, metres, of the region where blockers can hide the light.

    A blocker at distance d_b hides part of a light of radius R from a receiver at d_r when it
    lies within R (d_r - d_b) / d_b of the receiver's ray (sun: tan(angle / 2) (d_r - d_b)).
    Starting from the nearest caster of all maps, the nearest caster inside the current region
    (min-depth pyramid) gives a smaller region, ``SEARCH_REFINEMENTS`` times. The radius is
    capped at a quarter of the face's half-width (about 14 degrees for a cube face).
    """
    size = np.float32(sm.light_size)
    d_near = np.full(len(fr.w0), sm.min_depth, np.float32)
    ortho = sm.kind == "ORTHO"
    if ortho:
        d_r = fr.w0
    else:
        d_r = fr.dist
        np.maximum(d_near, np.float32(max(sm.near, 1e-12)), out=d_near)
    cap = np.float32(0.125 * sm.resolution) * fr.texel
    radius = cap
    for it in range(SEARCH_REFINEMENTS + 1):
        gap = np.maximum(d_r - d_near, 0.0)
        radius = np.minimum(size * gap if ortho else size * gap / d_near, cap)
        if it < SEARCH_REFINEMENTS:
            np.maximum(d_near, _footprint_min(sm, fr, radius), out=d_near)
    return radius


def _receiver_depth(t, fk, lo, hi, persp: bool):
    """Clamped receiver-plane depth from the plane term t (in place), as in ``_taps``."""
    if persp:
        np.minimum(t, _NEG, out=t)
        np.divide(fk, t, out=t)
    np.maximum(t, lo, out=t)
    np.minimum(t, hi, out=t)
    return t


def _footprint(sm: ShadowMap, fr: _Frame, radius: np.ndarray, reach: float):
    """Texel rectangle [c0, c1] x [r0, r1] (float32 (n,) each) of every tap of a disc of
    ``reach`` (largest tap distance, unit disc) scaled to ``radius``, whatever its rotation."""
    slack = np.float32(_SLACK + 1e-6 * sm.resolution)
    ec = radius * (np.float32(reach) * fr.jc) + slack
    er = radius * (np.float32(reach) * fr.jr) + slack
    return (np.floor(fr.cx - ec), np.floor(fr.cx + ec), np.floor(fr.ry - er),
            np.floor(fr.ry + er))


def _texel_flags(sm: ShadowMap, fr: _Frame, c0, c1, r0, r1, lo, hi, side: int):
    """Each texel of footprints of at most side x side texels compared like a tap.

    c0, c1, r0, r1: (n,) footprints, c1 - c0 and r1 - r0 below ``side``; lo, hi: (n,) clamp
    returns: flags (side^2, n) bool, blocked per texel (row-major from (c0, r0); where the
             footprint is narrower the last column / row repeats), and their count (n,) uint8
    """
    res = sm.resolution
    flat = sm.depth.reshape(-1)
    persp = sm.kind != "ORTHO"
    fa, fb, fc, fk, bias, base = fr.A, fr.B, fr.C, fr.K, fr.bias, fr.base
    cols = [c0] + [np.minimum(c0 + np.float32(j), c1) for j in range(1, side)]
    rows = [r0] + [np.minimum(r0 + np.float32(i), r1) for i in range(1, side)]
    col_term = [c * fb + fa for c in cols]
    col_index = [c.astype(np.intp) for c in cols]
    n = len(c0)
    flags = np.empty((side * side, n), bool)
    count = np.zeros(n, np.uint8)
    t, stored = np.empty(n, np.float32), np.empty(n, np.float32)
    index = np.empty(n, np.intp)
    for i, r in enumerate(rows):
        row_term = r * fc
        row_index = (r * np.float32(res)).astype(np.intp)
        row_index += base
        for j in range(side):
            np.add(col_term[j], row_term, out=t)
            _receiver_depth(t, fk, lo, hi, persp)
            np.add(row_index, col_index[j], out=index)
            flat.take(index, out=stored, mode="wrap")
            stored += bias
            blocked = flags[i * side + j]
            np.less(stored, t, out=blocked)
            count += blocked
    return flags, count


def _tap_axes(fr: _Frame, radius: np.ndarray):
    """Texel offsets per unit of disc coordinates a, b: (ac, bc, ar, br), each (n,), for
    discs turned by the points' rotations (fr.c, fr.s)."""
    return radius * fr.ac, radius * fr.bc, radius * fr.ar, radius * fr.br


def _flag_taps(fr: _Frame, radius: np.ndarray, disc: np.ndarray, c0, r0, flags, side: int):
    """Blocked tap count (n,) uint8 of taps read from per-texel ``flags`` (n, side^2) bool
    (``_texel_flags``, one row per point).

    A tap lands in the same texel as in ``_taps``; its result is the flag of that texel.
    """
    n = len(radius)
    ac, bc, ar, br = _tap_axes(fr, radius)
    cx, ry = fr.cx, fr.ry
    off = np.arange(n, dtype=np.float32) * np.float32(side * side)  # exact below 2^24
    off -= r0 * np.float32(side) + c0
    flat = flags.reshape(-1).view(np.uint8)
    count = np.zeros(n, np.uint8)
    colf, rowf, tmp = (np.empty(n, np.float32) for _ in range(3))
    index = np.empty(n, np.intp)
    hit = np.empty(n, np.uint8)
    fside = np.float32(side)
    for a, b in disc:
        np.multiply(ac, a, out=colf)
        colf += cx
        np.multiply(bc, b, out=tmp)
        colf += tmp
        np.multiply(ar, a, out=rowf)
        rowf += ry
        np.multiply(br, b, out=tmp)
        rowf += tmp
        np.floor(colf, out=colf)
        np.floor(rowf, out=rowf)
        np.multiply(rowf, fside, out=tmp)
        tmp += colf
        tmp += off
        np.copyto(index, tmp, casting="unsafe")
        flat.take(index, out=hit, mode="wrap")
        count += hit
    return count


def _block_test(sm: ShadowMap, fr: _Frame, c0, c1, r0, r1, lo, hi, dark_cap=None):
    """Points of ``fr`` whose footprints [c0, c1] x [r0, r1] (inside their maps) are proven
    fully lit or fully blocked by the least and greatest depth of the 2 x 2 pyramid blocks over
    them and the extreme receiver-plane depths at their corners (conservative).

    dark_cap: (n,) upper bound of the receiver depths in the test for ``dark`` (taps of a
              smaller radius, clamped to a smaller range), or None
    returns:  lit, dark, and free: (n,) bool; free: the receiver depth needs neither the clamp
              nor the guard of the plane term anywhere in the footprint (``_taps``)
    """
    persp = sm.kind != "ORTHO"
    n = len(c0)
    fa, fb, fc = fr.A, fr.B, fr.C
    b0, b1 = c0 * fb, c1 * fb
    g0, g1 = r0 * fc, r1 * fc
    t0 = np.minimum(b0, b1)  # least and greatest plane term (rounding is monotonic)
    t0 += fa
    t0 += np.minimum(g0, g1)
    t1 = np.maximum(b0, b1)
    t1 += fa
    t1 += np.maximum(g0, g1)
    free = t1 <= _NEG if persp else np.ones(n, bool)
    t0 = _receiver_depth(t0, fr.K, lo, hi, persp)
    t1 = _receiver_depth(t1, fr.K, lo, hi, persp)
    t_lo, t_hi = np.minimum(t0, t1), np.maximum(t0, t1)
    free &= (t_lo > lo) & (t_hi < hi)
    if dark_cap is not None:
        np.minimum(t_lo, dark_cap, out=t_lo)
    lit, dark = np.zeros(n, bool), np.zeros(n, bool)
    width = np.maximum(np.maximum(c1 - c0, r1 - r0), 1.0)
    level = _level(width)
    top = MIP_FIRST_LEVEL + _mip_levels(sm) - 1
    ok = level <= top
    if not ok.any():
        return lit, dark, free
    np.minimum(level, np.int32(max(top, MIP_FIRST_LEVEL)), out=level)
    flat = sm.mips.reshape(-1)
    for i, row in enumerate(_mip_rows(sm, fr.mf, level, c0, c1, r0, r1)):
        row *= 3
        if i == 0:
            lo_d, hi_d = flat.take(row + 1, mode="clip"), flat.take(row + 2, mode="clip")
        else:
            np.minimum(lo_d, flat.take(row + 1, mode="clip"), out=lo_d)
            np.maximum(hi_d, flat.take(row + 2, mode="clip"), out=hi_d)
    lo_d += fr.bias
    hi_d += fr.bias
    np.greater_equal(lo_d, t_hi, out=lit)
    np.less(hi_d, t_lo, out=dark)
    lit &= ok
    dark &= ok
    return lit, dark, free


def _pcf(sm: ShadowMap, fr: _Frame, radius: np.ndarray, disc: np.ndarray,
         reach: float) -> np.ndarray:
    """(n,) float32 fraction of unblocked taps of ``disc`` scaled to ``radius`` (n,).

    Footprints of at most FLAG_SIDE x FLAG_SIDE texels: every texel is compared once
    (``_texel_flags``); all blocked -> 0, none -> 1, else the taps read the flags. Wider
    footprints: the pyramid test (``_block_test``), then the taps. Footprints that leave the
    map: taps with exact look-ups.
    """
    res = sm.resolution
    n = len(radius)
    vis = np.ones(n, np.float32)
    c0, c1, r0, r1 = _footprint(sm, fr, radius, reach)
    width = np.maximum(np.maximum(c1 - c0, r1 - r0), 2.0)
    group = np.minimum(width, float(FLAG_SIDE)).astype(np.int8)  # side - 1 of the flags
    big, border = FLAG_SIDE, FLAG_SIDE + 1  # wider footprints, footprints leaving the map
    group[~((c0 >= 0.0) & (r0 >= 0.0) & (c1 < res) & (r1 < res))] = border
    scale = np.float32(1.0 / len(disc))
    for code in np.flatnonzero(np.bincount(group, minlength=border + 1)):
        k = np.flatnonzero(group == code)
        if code != border and COMPACT * n <= k.size < n:  # run on all, keep the group's results
            sub, rk, kc0, kc1, kr0, kr1, pick = fr, radius, c0, c1, r0, r1, k
        else:
            sub, (rk, kc0, kc1, kr0, kr1) = _compact(fr, k, n, radius, c0, c1, r0, r1)
            pick = None
        span = MAX_SLOPE * (rk + sub.texel)
        lo, hi = sub.w0 - span, sub.w0 + span
        if code < big:
            side = int(code) + 1
            flags, count = _texel_flags(sm, sub, kc0, kc1, kr0, kr1, lo, hi, side)
            if pick is not None:
                count = count[pick]
            vis[k[count == side * side]] = 0.0
            part = np.flatnonzero((count > 0) & (count < side * side))
            if part.size:
                src = part if pick is None else pick[part]
                hits = _flag_taps(sub.subset(src), rk.take(src), disc, kc0.take(src),
                                  kr0.take(src), np.ascontiguousarray(flags[:, src].T), side)
                vis[k[part]] = 1.0 - hits.astype(np.float32) * scale
            continue
        free = None
        if code == big:
            lit, dark, free = _block_test(sm, sub, kc0, kc1, kr0, kr1, lo, hi)
            if pick is not None:
                lit, dark = lit[pick], dark[pick]
            vis[k[dark]] = 0.0
            todo = np.flatnonzero(~(lit | dark))
            if todo.size == 0:
                continue
            src = todo if pick is None else pick[todo]
            k = k[todo]
            if src.size < COMPACT * len(rk):
                sub, rk, free, pick = sub.subset(src), rk.take(src), free[src], None
            else:
                pick = src
        count, _ = _taps(sm, sub, rk, disc, False, code == border, free)
        vis[k] = 1.0 - (count if pick is None else count[pick]).astype(np.float32) * scale
    return vis


def _compact(fr: _Frame, k: np.ndarray, n: int, *arrays):
    """The points ``k`` of the n points of ``fr``: a (lazy) frame and the arrays, copied."""
    if k.size == n:
        return fr, arrays
    return fr.subset(k), tuple(a.take(k) for a in arrays)


def _pcss(sm: ShadowMap, fr: _Frame, r_search: np.ndarray, r_min: np.ndarray) -> np.ndarray:
    """(n,) float32 percentage-closer soft shadows (Fernando 2005) of the points of ``fr``.

    Before the blocker search, footprints inside the map get the pyramid test: no blocker
    possible -> 1; every tap of the search and of any filter (radius r_min to r_search)
    blocked -> 0. Points whose search leaves the map take exact look-ups throughout.
    """
    res = sm.resolution
    size = np.float32(sm.light_size)
    n = len(r_min)
    vis = np.ones(n, np.float32)
    c0, c1, r0, r1 = _footprint(sm, fr, r_search, 1.0)
    inside = (c0 >= 0.0) & (r0 >= 0.0) & (c1 < res) & (r1 < res)
    for check in (False, True):
        k = np.flatnonzero(inside != check)
        if k.size == 0:
            continue
        sub, (r_s, r_lo, kc0, kc1, kr0, kr1) = _compact(fr, k, n, r_search, r_min, c0, c1, r0, r1)
        free, todo = None, None
        if not check:
            span = MAX_SLOPE * (r_s + sub.texel)
            cap = sub.w0 + MAX_SLOPE * (r_lo + sub.texel)
            lit, dark, free = _block_test(sm, sub, kc0, kc1, kr0, kr1, sub.w0 - span,
                                          sub.w0 + span, dark_cap=cap)
            vis[k[dark]] = 0.0
            todo = ~(lit | dark)
            t = np.flatnonzero(todo)
            if t.size == 0:
                continue
            if t.size < COMPACT * k.size:
                k, sub, r_s, r_lo, free, todo = (k[t], sub.subset(t), r_s.take(t), r_lo.take(t),
                                                  free[t], None)
        count, acc = _taps(sm, sub, r_s, _BLOCKER_DISC, True, check, free)
        need = count > 0  # no blocker found: fully lit
        if todo is not None:
            need &= todo
        mean = acc / np.maximum(count, 1).astype(np.float32)
        if sm.kind == "ORTHO":
            radius = size * mean  # tan(angle / 2) (d_r - d_b)
        else:  # R (d_r - d_b) / d_b
            radius = size * (1.0 - mean) / np.maximum(mean, np.float32(1e-6))
        radius = np.clip(radius, r_lo, r_s)
        t = np.flatnonzero(need)
        if t.size == 0:
            continue
        if t.size < COMPACT * len(need):
            vis[k[t]] = _pcf(sm, sub.subset(t), radius.take(t), _PCF_DISC, _PCF_REACH)
        else:
            vis[k[t]] = _pcf(sm, sub, radius, _PCF_DISC, _PCF_REACH)[t]
    return vis


def _visibility_chunk(sm: ShadowMap, p: np.ndarray, n: np.ndarray, jitter: bool) -> np.ndarray:
    """(N,) float32 visibility of one chunk of points (see ``shadow_visibility``)."""
    vis = np.ones(len(p), np.float32)
    ok = np.flatnonzero(np.isfinite(p[:, 0] + p[:, 1] + p[:, 2] + n[:, 0] + n[:, 1] + n[:, 2]))
    setup = _setup_ortho if sm.kind == "ORTHO" else _setup_perspective
    if ok.size == len(p):
        idx, fr = setup(sm, p, n)
    else:
        idx, fr = setup(sm, p[ok], n[ok])
        idx = ok[idx]
    if idx.size == 0:
        return vis
    c, s = _rotation(p if idx.size == len(p) else p[idx], jitter)
    fr.ac, fr.bc = c * fr.Jc1 + s * fr.Jc2, c * fr.Jc2 - s * fr.Jc1  # texels per metre along
    fr.ar, fr.br = c * fr.Jr1 + s * fr.Jr2, c * fr.Jr2 - s * fr.Jr1  # the turned disc axes
    fr.c, fr.s = c, s
    r_min = np.float32(MIN_FILTER_TEXELS) * fr.texel
    if sm.light_size > 0:
        r_search = _search_radius(sm, fr)
        wide = r_search > 1.5 * r_min  # a light too small for a search gets hard shadows
    else:
        wide = np.zeros(idx.size, bool)
    out = np.ones(idx.size, np.float32)
    for soft in (False, True):
        k = np.flatnonzero(wide == soft)
        if k.size == 0:
            continue
        sub, (r0,) = _compact(fr, k, idx.size, r_min)
        if soft:
            out[k] = _pcss(sm, sub, np.maximum(r_search.take(k), r0), r0)
        else:
            out[k] = _pcf(sm, sub, r0, _PCF_DISC_HARD, _PCF_REACH_HARD)
    vis[idx] = out
    return vis


def shadow_visibility(
    shadow_map: ShadowMap, points: np.ndarray, normals: np.ndarray, *, jitter: bool = True
) -> np.ndarray:
    """Fraction of the light that reaches each point (PCF, Reeves 1987; PCSS, Fernando 2005).

    shadow_map: output of ``build_shadow_map``
    points:     (N, 3) float32 world-space receiver positions, metres
    normals:    (N, 3) unit normals at the points, either side (geometric normals make the
                receiver planes exact; shading normals are absorbed by the normal offset)
    jitter:     rotate the tap disc per point by a hash of its position (noise rather than
                banding in wide penumbrae); False uses one fixed rotation
    returns:    (N,) float32 in [0, 1], 1 = fully lit; points outside every map, and points
                with non-finite coordinates, are lit
    """
    p = np.asarray(points, np.float32).reshape(-1, 3)
    n = np.asarray(normals, np.float32).reshape(-1, 3)
    out = np.ones(len(p), np.float32)
    if shadow_map is None or shadow_map.depth.shape[0] == 0:
        return out
    for lo in range(0, len(p), CHUNK):
        out[lo : lo + CHUNK] = _visibility_chunk(
            shadow_map, p[lo : lo + CHUNK], n[lo : lo + CHUNK], jitter
        )
    return out
