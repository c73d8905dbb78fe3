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
shadows with depth maps") with a fixed Vogel-spiral disc of taps rotated per point (white-noise
hash of the position, so results are deterministic), and percentage-closer soft shadows
(Fernando 2005, "Percentage-closer soft shadows"): a blocker search in the region where
blockers can hide part of the light, then a disc kernel whose radius at the receiver is the
penumbra half-width of a disc light,

- point, spot, area:  r = R (d_r - d_b) / d_b, R the light radius (area: half its diagonal);
- sun:                r = tan(angle / 2) (d_r - d_b), angle the sun's angular diameter;

never below ``MIN_FILTER_TEXELS`` texels, so hard shadows stay anti-aliased. Taps are placed in
the plane through the receiver perpendicular to the light ray, so the filtered result of a disc
kernel over a straight shadow edge is the visible fraction of a disc light.

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
MIP_FIRST_LEVEL = 3  # finest level of the min-depth pyramid kept (8 x 8 texel blocks)
PCF_TAPS = 32  # taps of the PCF kernel of soft shadows (PCSS)
PCF_TAPS_HARD = 16  # taps of the one-texel kernel of lights of zero size
SPOT_MAX_FOV = np.radians(170.0)  # wider spot cones use a cube map
CASCADE_RATIO = 4.0  # far / near depth ratio one sun cascade may cover
MAX_CASCADES = 4
SPLIT_LAMBDA = 0.75  # practical split scheme: weight of the logarithmic split (Zhang 2006)
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
    min_mips:   min-depth pyramid, levels l = MIP_FIRST_LEVEL, ... of shape
                (F, ceil(res / 2^l), ceil(res / 2^l)) float32: the least distance from the light
                (perspective) or light-space depth (cascades) over each 2^l x 2^l block, metres;
                bounds the blocker search (about 2% of the maps' memory)
    min_depth:  least value of the maps (nearest caster), metres
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

    @property
    def resolution(self) -> int:
        """Side of every map, texels."""
        return int(self.depth.shape[-1])

    @property
    def nbytes(self) -> int:
        """Bytes held by the depth maps and their min-depth pyramid."""
        return int(self.depth.nbytes + sum(m.nbytes for m in self.min_mips))


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


def _min_pyramid(dist: np.ndarray) -> list[np.ndarray]:
    """Min-reduction pyramid of a (res, res) map: levels MIP_FIRST_LEVEL, ... (odd sides are
    padded with inf)."""
    levels = []
    cur = dist
    while cur.shape[-1] > 1:
        if cur.shape[-1] % 2:
            cur = np.pad(cur, ((0, 1), (0, 1)), constant_values=np.inf)
        cur = np.minimum(
            np.minimum(cur[0::2, 0::2], cur[1::2, 0::2]),
            np.minimum(cur[0::2, 1::2], cur[1::2, 1::2]),
        )
        levels.append(cur)
    return levels[MIP_FIRST_LEVEL - 1 :]


def _stack_pyramids(pyramids: list[list[np.ndarray]]) -> list[np.ndarray]:
    """Per-face pyramids -> one (F, side, side) array per level."""
    if not pyramids:
        return []
    return [np.stack(level) for level in zip(*pyramids, strict=True)]


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
        pyramids.append(_min_pyramid(dist))
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
        min_mips=_stack_pyramids(pyramids),
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
        min_mips=_stack_pyramids([_min_pyramid(d) for d in depth]),
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


def _hash01(p: np.ndarray) -> np.ndarray:
    """(N,) float64 white-noise value in [0, 1) of (N, 3) positions (deterministic)."""
    s = np.sin(p.astype(np.float64) @ np.array([12.9898, 78.233, 37.719])) * 43758.5453
    return s - np.floor(s)


def _orthonormal(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two (N, 3) unit vectors perpendicular to unit (N, 3) d (Duff et al. 2017)."""
    sign = np.where(d[:, 2] >= 0.0, 1.0, -1.0).astype(d.dtype)
    a = -1.0 / (sign + d[:, 2])
    b = d[:, 0] * d[:, 1] * a
    t1 = np.stack([1.0 + sign * d[:, 0] ** 2 * a, sign * b, -sign * d[:, 0]], axis=1)
    t2 = np.stack([b, sign + d[:, 1] ** 2 * a, -d[:, 1]], axis=1)
    return t1, t2


def _cube_face(d: np.ndarray) -> np.ndarray:
    """(N,) int32 face index (+X, -X, +Y, -Y, +Z, -Z) of (N, 3) directions."""
    ax, ay, az = np.abs(d[:, 0]), np.abs(d[:, 1]), np.abs(d[:, 2])
    x_major = (ax >= ay) & (ax >= az)
    y_major = ~x_major & (ay >= az)
    face = np.where(x_major, np.int32(0), np.where(y_major, np.int32(2), np.int32(4)))
    comp = np.where(x_major, d[:, 0], np.where(y_major, d[:, 1], d[:, 2]))
    face += comp < 0.0
    return face


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) row-wise dot product of (N, 3) arrays."""
    return np.einsum("nk,nk->n", a, b)


def _norm(a: np.ndarray) -> np.ndarray:
    """(N,) row-wise length of (N, 3) arrays."""
    return np.sqrt(np.einsum("nk,nk->n", a, a))


def _unit_normals(n: np.ndarray, toward_light: np.ndarray) -> np.ndarray:
    """Unit normals turned to face the light (zero normals -> the light direction). (N, 3)."""
    length = _norm(n)
    bad = ~(length > 1e-6)
    n = n / np.where(bad, 1.0, length)[:, None]
    n[bad] = toward_light[bad]
    flip = _dot(n, toward_light) < 0.0
    n[flip] = -n[flip]
    return n


class _Frame:
    """Per-point set-up of the tap loops; every array has one entry per point, (n,).

    A tap at offset o = a t1 + b t2 metres (t1, t2 perpendicular to the light ray) reads its
    point's own map ``m`` at texel coordinates col = cx + Jc1 a + Jc2 b, row = ry + Jr1 a + Jr2 b
    (linearized projection; exact for the sun). With the texel (col, row) it lands in, the
    depth of the receiver's tangent plane along the ray through the texel centre is
    K / (A + B col + C row) (perspective) or A + B col + C row (sun), clamped to
    w0 +- MAX_SLOPE (radius + texel). Taps that leave the map take the exact path (``_fallback``).
    """

    def subset(self, sel: np.ndarray) -> _Frame:
        out = _Frame()
        for k, v in vars(self).items():
            setattr(out, k, v[sel] if isinstance(v, np.ndarray) else v)
        return out


def _plane_in_texels(fr: _Frame, res: int, nf, bx, by) -> None:
    """Set A, B, C from a plane term nf + bx xc + by yc of ndc texel centres (xc, yc)."""
    inv = np.float32(2.0 / res)
    fr.A = nf + bx * (0.5 * inv - 1.0) + by * (1.0 - 0.5 * inv)
    fr.B = bx * inv
    fr.C = -by * inv


def _setup_perspective(sm: ShadowMap, p: np.ndarray, n: np.ndarray):
    """Frame of points for a cube or spot map; returns (indices of points inside, _Frame)."""
    res, s = sm.resolution, np.float32(sm.tan_half)
    h = np.float32(0.5 * res)
    origin = sm.origin.astype(np.float32)
    basis = sm.basis.astype(np.float32)
    cube = sm.kind == "CUBE"
    d = p - origin
    if cube:  # face-axis depth
        w = np.maximum(np.maximum(np.abs(d[:, 0]), np.abs(d[:, 1])), np.abs(d[:, 2]))
    else:
        w = np.maximum(d @ basis[0, 2], 0.0)
    dist = np.maximum(_norm(d), 1e-12)
    n = _unit_normals(n, d / -dist[:, None])
    p = p + n * (NORMAL_OFFSET_TEXELS * 2.0 * s / res * w)[:, None]
    d = p - origin
    dist = _norm(d)
    face = _cube_face(d) if cube else np.zeros(len(p), np.int32)
    rb, ub, fb = basis[face, 0], basis[face, 1], basis[face, 2]
    w = _dot(d, fb)
    ok = dist > 2.0 * sm.near
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_sw = 1.0 / (s * w)
        x0 = _dot(d, rb) * inv_sw
        y0 = _dot(d, ub) * inv_sw
    if not cube:
        ok &= (w > sm.near) & (np.abs(x0) <= 1.0) & (np.abs(y0) <= 1.0)
    idx = np.flatnonzero(ok)
    if idx.size < len(p):
        d, dist, w, inv_sw, n, x0, y0, face, rb, ub, fb = (
            a[idx] for a in (d, dist, w, inv_sw, n, x0, y0, face, rb, ub, fb)
        )
    t1, t2 = _orthonormal(d / dist[:, None])
    fr = _Frame()
    fr.m = face
    fr.cx, fr.ry = (x0 + 1.0) * h, (1.0 - y0) * h
    # gradients of the texel coordinates: d(ndc x)/dX = (R - s x F) / (s w), likewise y with U
    gx = (rb - (s * x0)[:, None] * fb) * (h * inv_sw)[:, None]
    gy = (ub - (s * y0)[:, None] * fb) * (-h * inv_sw)[:, None]
    fr.Jc1, fr.Jc2 = _dot(gx, t1), _dot(gx, t2)  # texels per metre along t1, t2
    fr.Jr1, fr.Jr2 = _dot(gy, t1), _dot(gy, t2)
    fr.w0, fr.dist = w, dist
    fr.texel = 2.0 * s / res * w  # world size of a texel at the receiver, metres
    fr.K = _dot(d, n)  # ray L + t dc (dc.F = 1) meets the plane (X - p).n = 0 at t = K / dc.n
    _plane_in_texels(fr, res, _dot(n, fb), s * _dot(n, rb), s * _dot(n, ub))
    fr.bias = DEPTH_BIAS_RELATIVE * w + DEPTH_BIAS_TEXELS * fr.texel
    fr.d, fr.n, fr.t1, fr.t2 = d, n, t1, t2
    return idx, fr


def _find_cascade(sm: ShadowMap, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N,) int32 finest cascade whose square holds light-plane points (x, y), or -1."""
    out = np.full(x.shape, -1, np.int32)
    for c in range(len(sm.rects) - 1, -1, -1):
        cx, cy, half = sm.rects[c]
        out[(np.abs(x - cx) <= half) & (np.abs(y - cy) <= half)] = c
    return out


def _setup_ortho(sm: ShadowMap, p: np.ndarray, n: np.ndarray):
    """Frame of points for sun cascades; returns (indices of points inside, _Frame)."""
    basis = sm.basis[0].astype(np.float32)
    res = sm.resolution
    h = np.float32(0.5 * res)
    n = _unit_normals(n, np.broadcast_to(-basis[2], p.shape))
    casc = _find_cascade(sm, p @ basis[0], p @ basis[1])
    half = sm.rects[np.maximum(casc, 0), 2].astype(np.float32)
    p = p + n * (NORMAL_OFFSET_TEXELS * 2.0 * half / res)[:, None]
    x, y, z = p @ basis[0], p @ basis[1], p @ basis[2]
    casc = _find_cascade(sm, x, y)
    idx = np.flatnonzero(casc >= 0)
    x, y, z, n, m = x[idx], y[idx], z[idx], n[idx], casc[idx]
    cx, cy, half = (sm.rects[m, i].astype(np.float32) for i in range(3))
    fr = _Frame()
    fr.m = m
    fr.cx, fr.ry = ((x - cx) / half + 1.0) * h, (1.0 - (y - cy) / half) * h
    zero = np.zeros_like(half)
    fr.Jc1, fr.Jc2, fr.Jr1, fr.Jr2 = h / half, zero, zero, -h / half
    fr.w0 = z
    fr.texel = 2.0 * half / res
    fr.nR, fr.nU = n @ basis[0], n @ basis[1]
    fr.nF = np.minimum(n @ basis[2], -1e-6)
    # tangent plane: z = z0 - ((X - x) nR + (Y - y) nU) / nF at X = cx + xc half, Y = cy + yc half
    z0 = z - ((cx - x) * fr.nR + (cy - y) * fr.nU) / fr.nF
    _plane_in_texels(fr, res, z0, -half * fr.nR / fr.nF, -half * fr.nU / fr.nF)
    fr.bias = DEPTH_BIAS_RELATIVE * np.abs(z - sm.z_min) + DEPTH_BIAS_TEXELS * fr.texel
    fr.xw, fr.yw = x, y
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
        basis = sm.basis.astype(np.float32)
        d = fr.d[j] + (r * u)[:, None] * fr.t1[j] + (r * v)[:, None] * fr.t2[j]
        g = _cube_face(d)
        rb, ub, fb = basis[g, 0], basis[g, 1], basis[g, 2]
        w = _dot(d, fb)
        col = np.clip(np.floor((_dot(d, rb) / w + 1.0) * h), 0, res - 1)
        row = np.clip(np.floor((1.0 - _dot(d, ub) / w) * h), 0, res - 1)
        stored[:] = flat[(g * res + row.astype(np.int32)) * res + col.astype(np.int32)]
        nj = fr.n[j]
        xc, yc = (col + 0.5) * inv - 1.0, 1.0 - (row + 0.5) * inv
        den = np.minimum(_dot(nj, fb) + xc * _dot(nj, rb) + yc * _dot(nj, ub), -1e-30)
        recv[:] = np.clip(fr.K[j] / den, w - span, w + span)
        return stored, recv
    xw = fr.xw[j] + r * u  # sun: the finest other cascade that holds the tap
    yw = fr.yw[j] + r * v
    c = _find_cascade(sm, xw, yw)
    k = np.flatnonzero(c >= 0)
    if k.size:
        c, jk = c[k], j[k]
        cx, cy, half = (sm.rects[c, i].astype(np.float32) for i in range(3))
        col = np.clip(np.floor(((xw[k] - cx) / half + 1.0) * h), 0, res - 1)
        row = np.clip(np.floor((1.0 - (yw[k] - cy) / half) * h), 0, res - 1)
        stored[k] = flat[(c * res + row.astype(np.int32)) * res + col.astype(np.int32)]
        xs = cx + ((col + 0.5) * inv - 1.0) * half - fr.xw[jk]
        ys = cy + (1.0 - (row + 0.5) * inv) * half - fr.yw[jk]
        z = fr.w0[jk] - (xs * fr.nR[jk] + ys * fr.nU[jk]) / fr.nF[jk]
        recv[k] = np.clip(z, fr.w0[jk] - span[k], fr.w0[jk] + span[k])
    return stored, recv


def _taps(sm: ShadowMap, fr: _Frame, radius: np.ndarray, disc: np.ndarray, rot, measure: bool):
    """Compare one set of taps with the map around every point of ``fr``.

    radius:  (n,) kernel radius at the receiver, metres (perpendicular to the light ray)
    disc:    (K, 2) unit-disc tap positions;  rot: (cos, sin), each (n,), per-point rotation
    measure: also sum the blocker measure (perspective: d_blocker / d_receiver along the tap's
             ray; sun: d_receiver - d_blocker, metres)
    returns: blocked tap count (n,) int32 and the blocker measure sum (n,) float32 (or None)
    """
    res = sm.resolution
    flat = sm.depth.reshape(-1)
    persp = sm.kind != "ORTHO"
    c, s = rot
    ac = radius * (c * fr.Jc1 + s * fr.Jc2)  # texels per unit of disc coordinate a, b
    bc = radius * (c * fr.Jc2 - s * fr.Jc1)
    ar = radius * (c * fr.Jr1 + s * fr.Jr2)
    br = radius * (c * fr.Jr2 - s * fr.Jr1)
    span = MAX_SLOPE * (radius + fr.texel)
    lo, hi = fr.w0 - span, fr.w0 + span
    base = fr.m.astype(np.int32) * np.int32(res * res)
    count = np.zeros(len(radius), np.int32)
    acc = np.zeros(len(radius), np.float32) if measure else None
    for a, b in disc:
        colf = fr.cx + a * ac
        colf += b * bc
        rowf = fr.ry + a * ar
        rowf += b * br
        np.floor(colf, out=colf)
        np.floor(rowf, out=rowf)
        col = colf.astype(np.int32)
        row = rowf.astype(np.int32)
        inside = col.view(np.uint32) < res
        inside &= row.view(np.uint32) < res
        row *= res
        row += col
        row += base
        stored = flat.take(row, mode="clip")  # taps outside the map are redone below
        t = fr.A + colf * fr.B
        t += rowf * fr.C
        if persp:
            np.minimum(t, -1e-30, out=t)
            np.divide(fr.K, t, out=t)
        np.maximum(t, lo, out=t)
        np.minimum(t, hi, out=t)
        if not inside.all():
            j = np.flatnonzero(~inside)
            u = a * c[j] - b * s[j]
            v = a * s[j] + b * c[j]
            stored[j], t[j] = _fallback(sm, fr, j, u, v, radius[j], span[j])
        biased = stored + fr.bias
        blocked = biased < t
        count += blocked
        if measure:
            with np.errstate(invalid="ignore", divide="ignore"):
                val = stored / t if persp else t - stored
            acc += np.where(blocked, val, 0.0)
    return count, acc


def _footprint_min(sm: ShadowMap, fr: _Frame, radius: np.ndarray) -> np.ndarray:
    """Least map value in the square of half-side ``radius`` (n,) metres around each point.

    Reads the 2 x 2 texels of the min-depth pyramid level whose texels are at least as wide as
    the square; -inf where the square leaves the point's own map (unknown).
    """
    res = sm.resolution
    out = np.full(len(radius), -np.inf, np.float32)
    if not sm.min_mips:
        return out
    rc = radius * (np.abs(fr.Jc1) + np.abs(fr.Jc2))
    rr = radius * (np.abs(fr.Jr1) + np.abs(fr.Jr2))
    c0, c1 = np.floor(fr.cx - rc), np.floor(fr.cx + rc)
    r0, r1 = np.floor(fr.ry - rr), np.floor(fr.ry + rr)
    ok = (c0 >= 0) & (c1 < res) & (r0 >= 0) & (r1 < res)
    width = np.maximum(c1 - c0, r1 - r0) + 1.0
    level = np.maximum(np.ceil(np.log2(np.maximum(width, 1.0))), MIP_FIRST_LEVEL)
    ok &= level < MIP_FIRST_LEVEL + len(sm.min_mips)
    for lvl in np.unique(level[ok]).astype(int):
        k = np.flatnonzero(ok & (level == lvl))
        mip = sm.min_mips[lvl - MIP_FIRST_LEVEL]
        side = mip.shape[-1]
        flat = mip.reshape(-1)
        base = fr.m[k].astype(np.int64) * side
        ca, cb = c0[k].astype(np.int64) >> lvl, c1[k].astype(np.int64) >> lvl
        ra, rb = (base + (r0[k].astype(np.int64) >> lvl)) * side, (
            base + (r1[k].astype(np.int64) >> lvl)
        ) * side
        best = np.minimum(flat[ra + ca], flat[ra + cb])
        np.minimum(best, flat[rb + ca], out=best)
        np.minimum(best, flat[rb + cb], out=best)
        out[k] = best
    return out


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
    if jitter:
        phi = 2.0 * np.pi * _hash01(p[idx])
        rot = (np.cos(phi).astype(np.float32), np.sin(phi).astype(np.float32))
    else:
        rot = (np.ones(idx.size, np.float32), np.zeros(idx.size, np.float32))
    r_min = np.float32(MIN_FILTER_TEXELS) * fr.texel
    size = np.float32(sm.light_size)
    r_search = _search_radius(sm, fr) if size > 0 else r_min
    if size > 0 and np.any(r_search > 1.5 * r_min):
        r_search = np.maximum(r_search, r_min)
        count, acc = _taps(sm, fr, r_search, _BLOCKER_DISC, rot, True)
        sel = np.flatnonzero(count > 0)  # no blocker found: fully lit
        mean = acc[sel] / count[sel]
        if sm.kind == "ORTHO":
            radius = size * mean  # tan(angle / 2) (d_r - d_b)
        else:
            radius = size * (1.0 - mean) / np.maximum(mean, 1e-6)  # R (d_r - d_b) / d_b
        radius = np.clip(radius, r_min[sel], r_search[sel])
        fr = fr.subset(sel)
        rot = (rot[0][sel], rot[1][sel])
        idx = idx[sel]
        disc = _PCF_DISC
    else:
        radius = r_min
        disc = _PCF_DISC_HARD
    count, _ = _taps(sm, fr, radius, disc, rot, False)
    vis[idx] = 1.0 - count.astype(np.float32) / np.float32(len(disc))
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
