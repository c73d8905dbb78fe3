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
Maps without transparent casters take their depths straight from the triangles
(``kernels.raster.ortho_depths`` and ``perspective_depths``: no raster set-up); maps with them
are rasterized and dithered (``_rasterize_casters``).

The maps are queried per point by ``shadow_filter``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..formulas import affine
from ..scene import Camera, Light
from . import projection, raster, transparency

__all__ = ["ShadowMap", "build_shadow_map", "camera_depth_range", "mip_layout",
           "shadow_map_jobs"]

MIP_FIRST_LEVEL = 3  # finest level of the pyramid kept (8 x 8 texel blocks)
SPOT_MAX_FOV = np.radians(170.0)  # wider spot cones use a cube map
CASCADE_RATIO = 4.0  # far / near depth ratio one sun cascade may cover
MAX_CASCADES = 4
SPLIT_LAMBDA = 0.75  # practical split scheme: weight of the logarithmic split (Zhang 2006)


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
    z_min:      (F,) float64 light-space depth of the nearest caster in each cascade's square,
                less a small pad (suns), metres
    light_size: light radius R in metres (point, spot, area), or tan(angle / 2) (sun)
    splits:     (F + 1,) float64 camera view depths bounding the cascades, metres (sun)
    min_mips:   the first column of ``mips`` as one (F, side, side) view per level
    min_depth:  least value of the maps (nearest caster), metres
    max_filter: widest filter radius, metres (suns; the world's dome keeps its soft shadows
                from reaching past the walls of a room); 0: an eighth of the map
    mips:       (M, 3) float32 reduction pyramid of the maps, levels l = MIP_FIRST_LEVEL, ...
                until one texel, each (F, ceil(res / 2^l), ceil(res / 2^l)) blocks of 2^l x 2^l
                texels flattened (level, face, row, column): per block the least distance from the
                light (perspective) or light-space depth (cascades), the least and the greatest
                value of ``depth``, metres; bounds the blocker search and proves points fully lit
                or fully shadowed without taps (about 6% of the maps' memory)
    on_gpu:     the depths are left to a GPU to draw from the casters (``gpu_backend.
                shadow_depths``): ``depth`` is a zero-stride (F, res, res) view of +inf, ``mips``
                is empty and ``min_depth`` unknown (0); the CPU's filter refuses such a map
    kernel_args: the arrays and constants the visibility kernel takes
                (``shadow_filter.packed``), once
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
    z_min: np.ndarray = field(default_factory=lambda: np.zeros(0))
    light_size: float = 0.0
    splits: np.ndarray = field(default_factory=lambda: np.zeros(0))
    min_mips: list[np.ndarray] = field(default_factory=list)
    min_depth: float = 0.0
    max_filter: float = 0.0
    mips: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.float32))
    on_gpu: bool = False
    kernel_args: tuple | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.min_mips and len(self.mips):
            self.min_mips = [
                self.mips[lo : lo + side * side * len(self.depth), 0].reshape(-1, side, side)
                for lo, side in zip(*mip_layout(self.resolution, len(self.depth)), strict=True)
            ]

    @property
    def resolution(self) -> int:
        """Side of every map, texels."""
        return int(self.depth.shape[-1])

    @property
    def nbytes(self) -> int:
        """Bytes held by the depth maps and their pyramid (in this process)."""
        return 0 if self.on_gpu else int(self.depth.nbytes + self.mips.nbytes)


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


def mip_layout(res: int, faces: int) -> tuple[list[int], list[int]]:
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
    float32 (least dist, least depth, greatest depth); an odd side's last blocks are cut by the
    edge (``kernels.raster.reduction``)."""
    from ..kernels import raster as kernels

    levels = []
    side, level = dist.shape[-1], 0
    depth = np.asarray(depth, np.float32)
    planes = np.asarray(dist, np.float32), depth, depth
    while side > 1:
        side = (side + 1) // 2
        out = np.empty((side, side, 3), np.float32)
        kernels.reduction(*planes, out)
        planes, level = (out[..., 0], out[..., 1], out[..., 2]), level + 1
        if level >= MIP_FIRST_LEVEL:
            levels.append(out)
    return levels


def _flatten_pyramids(pyramids: list[list[np.ndarray]]) -> np.ndarray:
    """Per-face pyramids -> (M, 3) float32 rows ordered (level, face, row, column)."""
    rows = [np.stack(level).reshape(-1, 3) for level in zip(*pyramids, strict=True)]
    return np.concatenate(rows) if rows else np.zeros((0, 3), np.float32)


def _gpu_depth(faces: int, res: int) -> np.ndarray:
    """The ``depth`` of a map left to a GPU: (faces, res, res) +inf, no memory."""
    return np.broadcast_to(np.float32(np.inf), (faces, res, res))


def _perspective_jobs(light: Light, tris: np.ndarray, res: int, cutout=None,
                      on_gpu: bool = False):
    """A point, spot or area light's maps: one job per face, and the function that assembles
    the faces' results into the ShadowMap (``shadow_map_jobs``)."""
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
    from ..kernels import raster as kernels

    closest, reach = kernels.distances(tris, origin) if len(tris) else (np.inf, 1.0)
    far = 1.01 * reach + 1e-3
    # the near plane stays in front of every caster: huge geometry (a 1000 km ground) must not
    # push it past the casters next to the light (the clip is float64, so depth holds)
    near = max(min(1e-5 * far, 0.5 * closest), 1e-6)
    proj = _perspective(tan_half, near, far)
    centre = (np.arange(res) + 0.5) * (2.0 / res) - 1.0
    ray_len = np.sqrt(1.0 + tan_half**2 * (centre[:, None] ** 2 + centre[None, :] ** 2))
    ray_len = ray_len.astype(np.float32)  # distance from the light / face-axis depth
    view_proj = np.stack([proj @ _view(frame, origin) for frame in basis])

    def face(f: int):
        if cutout is None:  # the depths straight from the triangles
            depth = np.full((res, res), np.inf, np.float32)
            kernels.perspective_depths(tris, np.ascontiguousarray(view_proj[f][[0, 1, 3]]),
                                       near, depth)
        else:
            depth = _rasterize_casters(projection.Projection(tris, view_proj[f]), res,
                                       cutout, f, False).depth
        dist = depth * ray_len  # distance from the light, metres
        return depth, _pyramid(dist, depth), float(dist.min())

    def finish(faces: list) -> ShadowMap:
        if on_gpu:
            return ShadowMap(kind=kind, light_kind=light.kind,
                             depth=_gpu_depth(len(basis), res), view_proj=view_proj,
                             basis=basis.copy(), origin=origin, tan_half=float(tan_half),
                             near=near, light_size=max(size, 0.0), on_gpu=True)
        return ShadowMap(
            kind=kind,
            light_kind=light.kind,
            depth=np.stack([depth for depth, _, _ in faces]),
            view_proj=view_proj,
            basis=basis.copy(),
            origin=origin,
            tan_half=float(tan_half),
            near=near,
            light_size=max(size, 0.0),
            mips=_flatten_pyramids([pyramid for _, pyramid, _ in faces]),
            min_depth=min((m for _, _, m in faces), default=np.inf),
        )

    if on_gpu:
        return [], finish
    return [lambda f=f: face(f) for f in range(len(basis))], finish


def camera_depth_range(camera: Camera, tris: np.ndarray):
    """The camera's frustum corners at a view depth, and the view-depth range of the parts of
    the triangles ``tris`` (T, 3, 3) float32 or float64 inside its frustum (``kernels.raster.
    clipped_depths``), clamped to [near, far] (z0 > z1 when empty): a ground reaching far
    beyond the view counts only as far as the camera sees it.

    Only the near plane is unprojected: a far plane thousands of times farther than the near
    one is at infinity in the float32 projection (its z row rounds to -1), and so is f here.

    returns: corners(z) -> (4, 3) camera-space corners at view depth z, near, far, z0, z1
    """
    from ..kernels import raster as kernels

    proj = np.asarray(camera.projection, np.float64)
    ndc = np.array([[x, y, -1.0, 1.0] for x, y in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    cs = ndc @ affine.inverse(proj).T
    near_c = cs[:, :3] / cs[:, 3:]
    n = float(-near_c[:, 2].mean())
    a, b = proj[2, 2], proj[2, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = float((b - 1.0) / a) if camera.orthographic else float(b / (a + 1.0))
    if not np.isfinite(f) or f <= n:
        f = np.inf

    def corners(z: float) -> np.ndarray:
        if camera.orthographic:
            return np.column_stack([near_c[:, :2], np.full(4, -z)])
        return near_c * (z / n)

    w2c = np.asarray(camera.world_to_camera, np.float64)
    rows = np.concatenate([(proj @ w2c)[[0, 1, 3]], -w2c[2:3]])  # clip x, y, w; view depth
    lo, hi = kernels.clipped_depths(tris, rows, n)
    return corners, n, f, max(n, lo), min(f, hi)


def _extent(tris: np.ndarray, axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The least and greatest (A,) of the corners of ``tris`` (T, 3, 3) along ``axes``
    (A, 3) float64 (``kernels.raster.extent``: one pass, no temporary of the triangles)."""
    from ..kernels import raster as kernels

    rows = np.zeros((len(axes), 4))
    rows[:, :3] = axes
    out = np.empty((len(axes), 2))
    kernels.extent(tris, rows, out)
    return out[:, 0], out[:, 1]


def _fit_cascades(camera: Camera, basis: np.ndarray, tris: np.ndarray, res: int,
                  view_range: tuple | None = None):
    """Cascade squares (C, 3) (cx, cy, half side) in the light's (R, U) plane and splits (C+1,).

    The view-depth range the camera sees of the casters (``camera_depth_range``) is split
    with the practical scheme z_i = l z0 (z1/z0)^(i/C) + (1 - l)(z0 + (z1 - z0) i/C)
    (Zhang et al. 2006), with C = ceil(log(z1/z0) / log(CASCADE_RATIO)) in [1, MAX_CASCADES]
    (1 for an orthographic camera); l = SPLIT_LAMBDA, rising linearly to 1 (logarithmic) as
    the range needs from MAX_CASCADES to MAX_CASCADES + 1 cascades. Each slice's eight
    corners are projected onto the light plane; their bounding rectangle, clipped to the
    casters' extent, becomes a square with a 4-texel margin. ``view_range``: the
    ``camera_depth_range`` of these, when known.
    """
    corners, n, f, z0, z1 = view_range or camera_depth_range(camera, tris)
    if not z1 >= z0:  # (a flat receiver facing an orthographic camera: one depth)
        return np.zeros((0, 3)), np.zeros(0)
    z0 = max(z0, 1e-6)
    needed = 0.0 if camera.orthographic else float(np.log(z1 / z0) / np.log(CASCADE_RATIO))
    count = int(np.clip(np.ceil(needed), 1, MAX_CASCADES))
    # a range longer than the cascades hold turns logarithmic over one more cascade's ratio:
    # the linear part would give the first cascade most of a long range
    weight = SPLIT_LAMBDA + (1.0 - SPLIT_LAMBDA) * float(np.clip(needed - MAX_CASCADES, 0, 1))
    i = np.arange(count + 1) / count
    splits = weight * z0 * (z1 / z0) ** i + (1.0 - weight) * (z0 + (z1 - z0) * i)
    splits[0], splits[-1] = z0, z1
    c2w = affine.inverse(camera.world_to_camera)
    ext_lo, ext_hi = _extent(tris, basis[:2])
    rects = []
    for a, b in zip(splits[:-1], splits[1:], strict=True):
        slab = np.concatenate([corners(z) for z in (a, b)])
        sxy = affine.linear(affine.transform(slab, c2w), basis[:2])
        r_lo = np.maximum(sxy.min(0), ext_lo)
        r_hi = np.minimum(sxy.max(0), ext_hi)
        centre = 0.5 * (r_lo + r_hi)
        half = 0.5 * max(float((r_hi - r_lo).max()), 1e-6)
        half *= 1.0 + 8.0 / res
        rects.append([centre[0], centre[1], half])
    return np.array(rects), splits


def _sun_jobs(light: Light, tris: np.ndarray, camera: Camera, res: int, cutout=None,
              max_filter: float = 0.0, view_range: tuple | None = None,
              focus: tuple | None = None, on_gpu: bool = False):
    """The sun's cascades: one job per cascade, and the function that assembles them."""
    basis = _frame(light.direction)
    # Blender's largest angle is pi (in float32, a little above): keep the half angle below
    # 90 degrees, where the tangent turns negative
    tan_half = float(np.tan(0.5 * min(max(float(light.radius), 0.0), np.pi - 1e-3)))
    if len(tris) and camera is not None:
        rects, splits = _fit_cascades(camera, basis, tris, res, view_range)
    elif len(tris):
        lo, hi = _extent(tris, basis[:2])
        if focus is not None:
            lo3, hi3 = (np.asarray(v, np.float64) for v in focus)
            box = np.array([[(lo3, hi3)[(k >> a) & 1][a] for a in range(3)] for k in range(8)])
            on_plane = box @ basis[:2].T
            lo, hi = np.maximum(lo, on_plane.min(0)), np.minimum(hi, on_plane.max(0))
            if not (lo <= hi).all():  # no caster over the region
                lo, hi = on_plane.min(0), on_plane.max(0)
        half = 0.5 * max(float((hi - lo).max()), 1e-6) * (1.0 + 8.0 / res)
        rects, splits = np.array([[*(0.5 * (lo + hi)), half]]), np.zeros(0)
    else:
        rects, splits = np.zeros((0, 3)), np.zeros(0)
    from ..kernels import raster as kernels

    view_proj = np.zeros((len(rects), 4, 4))
    z_min = np.zeros(len(rects))
    for c, (cx, cy, half) in enumerate(rects):
        # the casters inside the cascade's square: a ground far wider than the view would
        # otherwise stretch the depth range (and the bias) beyond what float32 can tell apart
        rows = np.zeros((4, 4))
        rows[0, :3], rows[0, 3] = basis[0], -cx
        rows[1, :3], rows[1, 3] = basis[1], -cy
        rows[2, 3], rows[3, :3] = half, basis[2]
        z_lo, z_hi = kernels.clipped_depths(tris, rows, -np.inf)
        if not z_lo <= z_hi:
            z_lo, z_hi = 0.0, 1.0
        pad = 1e-3 * (z_hi - z_lo) + 1e-4
        z_lo, z_hi = z_lo - pad, z_hi + pad
        z_min[c] = z_lo
        m = view_proj[c]
        m[0, :3], m[0, 3] = basis[0] / half, -cx / half
        m[1, :3], m[1, 3] = basis[1] / half, -cy / half
        m[2, :3], m[2, 3] = basis[2] * (2.0 / (z_hi - z_lo)), -2.0 * z_lo / (z_hi - z_lo) - 1.0
        m[3, 3] = 1.0

    def cascade(c: int):
        from ..kernels import raster as kernels

        if cutout is None:  # the depths straight from the triangles
            cx, cy, half = rects[c]
            g = 0.5 * res / half  # texels per metre
            rows = np.zeros((3, 4))
            rows[0, :3], rows[0, 3] = basis[0] * g, 0.5 * res - cx * g
            rows[1, :3], rows[1, 3] = -basis[1] * g, 0.5 * res + cy * g
            rows[2, :3] = basis[2]
            d = np.full((res, res), np.inf, np.float32)
            kernels.ortho_depths(tris, rows, d)
            return d, _pyramid(d, d)
        frags = _rasterize_casters(projection.Projection(tris, view_proj[c]), res,
                                   cutout, c, True)
        d = np.full((res, res), np.inf, np.float32)  # depth along the light of each texel
        hit = np.flatnonzero(frags.tri.reshape(-1) >= 0)
        for lo in range(0, len(hit), 1 << 18):  # (the corners' depths of the triangles seen,
            part = hit[lo:lo + (1 << 18)]         # a block of texels at a time)
            corners = np.asarray(tris[frags.tri.reshape(-1)[part]], np.float64)
            zs = np.ascontiguousarray(affine.linear(corners, basis[2:])[..., 0])
            out = np.empty((1, len(part)), np.float32)
            kernels.corner_sum(np.arange(len(part), dtype=np.int32)[None], np.ascontiguousarray(
                frags.bary.reshape(-1, 3)[part][None]), zs, out)
            d.reshape(-1)[part] = out[0]
        return d, _pyramid(d, d)

    def finish(cascades: list) -> ShadowMap:
        if on_gpu:
            depth = _gpu_depth(len(rects), res)
        else:
            depth = (np.stack([d for d, _ in cascades]) if cascades
                     else np.empty((0, res, res), np.float32))
        return ShadowMap(
            kind="ORTHO",
            light_kind="SUN",
            depth=depth,
            view_proj=view_proj,
            basis=np.broadcast_to(basis, (len(rects), 3, 3)).copy(),
            rects=rects,
            z_min=z_min,
            light_size=tan_half,
            splits=splits,
            mips=_flatten_pyramids([pyramid for _, pyramid in cascades]),
            min_depth=0.0 if on_gpu else float(depth.min()) if depth.size else np.inf,
            max_filter=max_filter,
            on_gpu=on_gpu,
        )

    if on_gpu:
        return [], finish
    return [lambda c=c: cascade(c) for c in range(len(rects))], finish


def shadow_map_jobs(
    light: Light, triangles: np.ndarray, camera: Camera | None, *, resolution: int = 1024,
    cutout=None, max_filter: float = 0.0, view_range: tuple | None = None,
    focus: tuple | None = None, on_gpu: bool = False,
) -> tuple[list[Callable[[], object]], Callable[[list], ShadowMap | None]]:
    """The work of ``build_shadow_map`` as independent jobs (one per cube face or cascade, to
    run on any threads) and the function that assembles their results, in order, into the
    ShadowMap (None when the light casts no shadow). Arguments as ``build_shadow_map``, and
    cutout: None, or (fades (T,) bool, alpha(tri (N,), bary (N, 3)) -> (N,)): casters that may
    be transparent and their alpha at texels (``_rasterize_casters``); max_filter: a sun's
    widest filter radius, metres (``ShadowMap.max_filter``); view_range: the
    ``camera_depth_range`` of ``camera`` and these triangles, when known (many suns);
    focus: without a camera, the world box (lo (3,), hi (3,)) whose shadows matter (the
    region probe captures see): a sun's one cascade covers it rather than every caster (a
    far terrain would leave a few texels to the whole of a room); on_gpu: leave the depths
    to a GPU (``ShadowMap.on_gpu``: no jobs), unless casters are transparent (``cutout``) or
    the map is under ``2 ** MIP_FIRST_LEVEL`` texels (then built here as usual)."""
    if not light.shadow:
        return [], lambda results: None
    res = max(1, int(resolution))
    tris = np.asarray(triangles)  # float32 as the frame holds them (no copy), or float64
    tris = np.ascontiguousarray(tris.reshape(-1, 3, 3),
                                tris.dtype if tris.dtype == np.float32 else np.float64)
    on_gpu = on_gpu and cutout is None and res >= 1 << MIP_FIRST_LEVEL
    if light.kind == "SUN":
        return _sun_jobs(light, tris, camera, res, cutout, max_filter, view_range, focus,
                         on_gpu)
    return _perspective_jobs(light, tris, res, cutout, on_gpu)


def _rasterize_casters(clip, res: int, cutout, face: int, weights: bool):
    """The nearest caster of every texel; with ``cutout``, transparent casters let the texels
    through stochastically (``transparency.dither`` with ``transparency.ordered_thresholds``),
    so that the filtered shadow of a surface of alpha a is a dark."""
    frags = raster.rasterize(clip, res, res, weights=weights or cutout is not None)
    if cutout is None or frags.keys is None:  # (no keys: nothing drawn, a face with no caster)
        return frags
    fades, alpha = cutout
    tri, bary, depth = (frags.tri.reshape(-1).copy(), frags.bary.reshape(-1, 3).copy(),
                        frags.depth.reshape(-1).copy())
    py, px = np.divmod(np.arange(res * res), res)

    def next_layer(floor):
        f = raster.rasterize(clip, res, res, behind=floor)
        return f.tri.reshape(-1), f.bary.reshape(-1, 3), f.depth.reshape(-1), f.keys

    transparency.dither((tri, bary, depth, frags.keys.copy()), np.arange(res * res), fades,
                  lambda pixels, t, b: alpha(t, b),
                  lambda pixels, layer: transparency.ordered_thresholds(px[pixels] + face * res,
                                                                  py[pixels], layer),
                  next_layer)
    return raster.Fragments(tri.reshape(res, res), bary.reshape(res, res, 3),
                            depth.reshape(res, res))


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
    jobs, finish = shadow_map_jobs(light, triangles, camera, resolution=resolution)
    return finish([job() for job in jobs])
