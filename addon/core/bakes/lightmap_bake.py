"""Lightmap baking: texels, direct light, gathers through a BVH, clean-up (``lightmap``).

The method and its references are in ``lightmap``'s docstring; this module renders: it reads
the scene through a prepared frame (``pipeline.prepare``: buffers, materials) and writes
nothing to disk (the host writes the results with ``lightmap_file``), so a bake that is
stopped leaves the previous files as they were.
"""

from __future__ import annotations

import dataclasses
import hashlib
import threading
import time
import weakref
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from ..formulas.cubemap import FACES, with_border
from ..lighting import probes as probe_light
from ..lighting import shade
from ..lighting.lightmap import (
    SH_SCALE_C0,
    SH_SCALE_C1,
    Lightmap,
    LightmapError,
    Settings,
    Target,
    denoise_steps,
    dilate,
    seams,
    stitch,
    uv_islands,
)
from ..lighting.world_probes import world_cube
from ..render import pipeline
from ..render.buffers import broken_triangles
from ..render.job import Cancelled, RenderJob
from ..render.shadow_maps import casters, shadow_map_count
from ..render.surfaces import surface_params
from ..scene import Scene, linking
from . import series
from .capture import face_camera

__all__ = ["bake", "bake_bytes", "geometry_key", "light_key", "ray_offset", "steps"]

_FACES = np.array(FACES)  # writable, as the kernel takes it


@dataclass
class _Texels:
    """The texels of one target that lie on its surface."""

    at: np.ndarray        # (M,) flat texel index
    tri: np.ndarray       # (M,) int64 triangle of the frame
    p: np.ndarray         # (M, 3) float32
    n: np.ndarray         # (M, 3) unit interpolated normal
    geo: np.ndarray       # (M, 3) unit face normal
    chart: np.ndarray     # (H, W) int64 chart id of each texel, -1 none
    texel: float          # metres: the side of a texel on the surface, on average
    offset: np.ndarray    # (M,) float32 metres: rays start this far above the surface


def _frame_index(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """Per mesh batch the index of its first triangle in a prepared frame's arrays, and per
    concatenated triangle its index in the frame (-1: dropped as broken, ``pipeline.prepare``)."""
    counts = [len(m.positions) for m in scene.meshes]
    first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    if not scene.meshes:
        return first, np.zeros(0, np.int64)
    keep, _, _ = broken_triangles(np.concatenate([m.positions for m in scene.meshes]))
    index = np.where(keep, np.cumsum(keep) - 1, -1)
    return first, index


def _texels(target: Target, frame, first, index, scene_positions) -> _Texels:
    """The texels of ``target`` on its surface, in ``frame`` (``_frame_index``'s ``first`` and
    ``index``; ``scene_positions`` (T, 3, 3) every batch's triangles, concatenated)."""
    from ..kernels import lightmap as kernels

    w, h = target.width, target.height
    tri = np.full(w * h, -1, np.int32)
    bary = np.zeros((w * h, 3), np.float32)
    uvs = np.ascontiguousarray(target.uvs, np.float32)
    kernels.texels(uvs, w, h, kernels.SUBSAMPLES, tri, bary)
    at = np.flatnonzero(tri >= 0)
    global_tri = index[first[target.mesh] + tri[at]]
    ok = global_tri >= 0
    at, global_tri, b = at[ok], global_tri[ok], bary[at[ok]]
    q = frame.positions[global_tri]
    p = np.einsum("nk,nkc->nc", b, q).astype(np.float32)
    geo = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    geo /= np.maximum(np.linalg.norm(geo, axis=1, keepdims=True), 1e-30)
    n = np.einsum("nk,nkc->nc", b, frame.normals[global_tri])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    flip = np.einsum("nc,nc->n", n, geo) < 0.0  # a shading normal facing away: the face's
    n[flip] = geo[flip]
    # a texel's chart: the UV island of its triangle (the filter does not cross islands)
    chart = np.full(w * h, -1, np.int64)
    chart[at] = uv_islands(target.uvs)[tri[at]]
    q3 = np.asarray(target.uvs, np.float64)
    e1, e2 = q3[:, 1] - q3[:, 0], q3[:, 2] - q3[:, 0]
    uv_area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum() * w * h
    pts = np.asarray(scene_positions[first[target.mesh]:first[target.mesh] + len(target.uvs)],
                     np.float64)
    area = 0.5 * np.linalg.norm(np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0]),
                                axis=1)
    texel = float(np.sqrt(np.nansum(area) / max(uv_area, 1e-12)))
    return _Texels(at, global_tri, p, n.astype(np.float32), geo.astype(np.float32),
                   chart.reshape(h, w), texel, ray_offset(q))


OFFSET = 2.0 ** -16  # of a triangle's largest coordinate: ``ray_offset``
OFFSET_FLOOR = 1e-7  # metres: the least offset (a triangle at the origin)


def ray_offset(corners: np.ndarray) -> np.ndarray:
    """(N,) float32 metres: how far above its triangle (corners (N, 3, 3), float32 world
    space) a ray starts so that it cannot meet the triangle it leaves. The point on the
    triangle and the triangle's plane both come from float32 coordinates, whose rounding is
    2^-24 of their magnitude: the offset follows the largest coordinate of the triangle, 256
    times that rounding, so it stays far below any feature of the scene near the point
    whatever the scene's extent (Waechter and Binder, "A Fast and Robust Method for Avoiding
    Self-Intersection", Ray Tracing Gems, 2019, offset by the magnitude of the position)."""
    scale = np.abs(np.asarray(corners, np.float64)).max(axis=(1, 2)) if len(corners) else \
        np.zeros(0)
    return np.maximum(OFFSET * scale, OFFSET_FLOOR).astype(np.float32)


@dataclass
class _Bvh:
    """Triangles (T, 3, 3) float32 and their BVH (``kernels.lightmap.build_bvh``)."""

    tris: np.ndarray
    order: np.ndarray
    bounds: np.ndarray
    links: np.ndarray

    @classmethod
    def of(cls, tris: np.ndarray) -> _Bvh:
        from ..kernels import lightmap as kernels

        tris = np.ascontiguousarray(tris, np.float32)
        order = np.empty(len(tris), np.int32)
        bounds = np.empty((max(2 * len(tris), 1), 6), np.float32)
        links = np.empty((max(2 * len(tris), 1), 4), np.int32)
        if len(tris):
            kernels.build_bvh(tris, order, bounds, links)
        return cls(tris, order, bounds, links)


SHADOW_RAYS = 16  # shadow rays per texel and light, spread over the light's shape


def light_samples(light, count: int = SHADOW_RAYS) -> tuple[np.ndarray, bool]:
    """Where shadow rays go to reach ``light``: (samples (S, 3) float64, toward). A sun gives
    unit directions within its disc (``radius``: its angular diameter), toward False; point
    and spot lights points on their sphere, area lights points on a disc of half their
    diagonal facing their direction (as their shadow maps, ``shadows``), toward True. A light
    of no size gives one sample. Points on a disc follow Vogel's spiral (golden angle)."""
    k = np.arange(count) + 0.5
    r, phi = np.sqrt(k / count), k * np.pi * (3.0 - np.sqrt(5.0))
    disc = np.stack([r * np.cos(phi), r * np.sin(phi)], 1)
    axis = -np.asarray(light.direction, np.float64)[:3]
    axis = axis / max(np.linalg.norm(axis), 1e-30)
    t = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
    t /= np.linalg.norm(t)
    b = np.cross(axis, t)
    if light.kind == "SUN":
        spread = np.tan(0.5 * min(max(float(light.radius), 0.0), np.pi - 1e-3))
        if spread <= 0.0:
            return axis[None], False
        d = axis + spread * (disc[:, :1] * t + disc[:, 1:] * b)
        return d / np.linalg.norm(d, axis=1, keepdims=True), False
    centre = np.asarray(light.position, np.float64)[:3]
    if light.kind == "AREA":
        size = 0.5 * float(np.hypot(*np.asarray(light.size, np.float64)[:2]))
        if size <= 0.0:
            return centre[None], True
        return centre + size * (disc[:, :1] * t + disc[:, 1:] * b), True
    radius = float(light.radius)
    if radius <= 0.0:
        return centre[None], True
    z = 1.0 - 2.0 * k / count  # a Fibonacci sphere
    ring = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    return centre + radius * np.stack([ring * np.cos(phi), ring * np.sin(phi), z], 1), True


class _Casters:
    """The frame's shadow casters as BVHs, per shadow linking set (``linking``; set 0: every
    caster), each built when first asked for."""

    def __init__(self, frame, every: _Bvh):
        self.frame, self.sets = frame, {0: every}

    def of(self, blockers: int) -> _Bvh:
        """The BVH of the casters that shadow the lights of set ``blockers``."""
        if blockers not in self.sets:
            self.sets[blockers] = _Bvh.of(casters(self.frame, blockers)[0])
        return self.sets[blockers]


def _direct(frame, casters: _Casters, reach: float, tri, p, n, geo, offsets) -> np.ndarray:
    """(N, 3) irradiance of the scene's lights at points p on triangles tri (N,) with normals
    n, face normals geo, shadowed by ray tracing ``casters`` (``SHADOW_RAYS`` per light, rays
    starting ``offsets`` (N,) m above the surface): exact at any scale, where a shadow map over
    the whole scene (a far terrain) would blur every shadow away. A linked light lights and is
    shadowed by its sets alone, as in a frame."""
    from ..kernels import lightmap as kernels

    out = np.zeros((len(p), 3), np.float32)
    for light in frame.scene.lights:
        l_dir, irradiance, lit = shade.light_incidence(light, p, geo)
        if light.receivers:
            lit &= linking.in_set(frame.receives[tri], light.receivers)
        if not lit.any():
            continue
        vis = np.ones(len(p), np.float32)
        mine = casters.of(light.blockers if frame.blocks is not None else 0)
        if light.shadow and len(mine.tris):
            samples, toward = light_samples(light)
            at = np.flatnonzero(lit)
            v = np.empty(len(at), np.float32)
            kernels.visibility(np.ascontiguousarray(p[at], np.float32),
                               np.ascontiguousarray(geo[at], np.float32),
                               np.ascontiguousarray(offsets[at], np.float32),
                               np.ascontiguousarray(samples, np.float64), toward,
                               mine.tris, mine.order, mine.bounds, mine.links,
                               reach, v)
            vis[at] = v
        cos = np.maximum(np.einsum("nk,nk->n", n, l_dir), 0.0)
        out += irradiance * (cos * vis * lit)[:, None]
    return out


def _surface(frame, tri, p, n, geo, bary=None):
    """Reflectance (albedo (1 - rf0) + rf0) and emission (N, 3) of the frame's surfaces at
    the points."""
    if bary is None:
        q = frame.positions[tri].astype(np.float64)
        e1, e2, d = q[:, 1] - q[:, 0], q[:, 2] - q[:, 0], p - q[:, 0]
        d00, d01, d11 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
        d20, d21 = (d * e1).sum(1), (d * e2).sum(1)
        den = np.maximum(d00 * d11 - d01 * d01, 1e-30)
        v = (d11 * d20 - d01 * d21) / den
        w = (d00 * d21 - d01 * d20) / den
        bary = np.stack([1 - v - w, v, w], 1).astype(np.float32)
    zero = np.zeros(len(tri), np.float32)
    s = surface_params(frame, np.asarray(tri, np.int64), bary, p, n, geo, n, zero, zero,
                       shifts=False, layered=False)
    # what the surface reflects of the light it gets, diffusely and specularly (a gather reads
    # its radiance as a diffuse surface's, so a metal reflects its colour): the specular layer
    # takes rf0 and the diffuse one the rest, as a layered BSDF conserves energy
    rf0 = np.asarray(s.rf0, np.float32)
    reflectance = np.asarray(s.albedo, np.float32) * (1.0 - rf0) + rf0
    return reflectance, np.asarray(s.emission, np.float32)


def _corner_radiance(frame, scene: Scene, dynamic: np.ndarray, casters: _Casters,
                     reach: float) -> np.ndarray:
    """(T, 3, 3) radiance of the corners (moved 5% in) of the frame's triangles ``dynamic``
    (bool (T,)), lit directly (``_direct``) and by the probes; 0 elsewhere."""
    out = np.zeros((len(frame.positions), 3, 3), np.float32)
    tri = np.flatnonzero(dynamic)
    if not len(tri):
        return out
    q = frame.positions[tri]
    centre = q.mean(1, keepdims=True)
    p = (q + 0.05 * (centre - q)).reshape(-1, 3).astype(np.float32)
    t3 = np.repeat(tri, 3)
    geo = np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])
    geo = np.repeat(geo / np.maximum(np.linalg.norm(geo, axis=1, keepdims=True), 1e-30), 3, 0)
    n = frame.normals[tri].reshape(-1, 3)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    geo, n = geo.astype(np.float32), n.astype(np.float32)
    albedo, emission = _surface(frame, t3, p, n, geo)
    e = _direct(frame, casters, reach, t3, p, n, geo, np.repeat(ray_offset(q), 3))
    radiance = emission + albedo * e / np.float32(np.pi)
    if scene.probes is not None:
        diffuse, _ = probe_light.indirect(scene.probes, p, n, n, albedo,
                                          np.zeros_like(albedo), np.zeros(len(p), np.float32),
                                          extrapolate=scene.settings.volume_extrapolation,
                                          visibility=scene.settings.volume_visibility)
        radiance += diffuse
    out[tri] = radiance.reshape(-1, 3, 3)
    return out


def bake(job: RenderJob, targets: list[Target], settings: Settings | None = None
         ) -> list[Lightmap]:
    """Bake the lightmaps of ``targets`` (``Target``) in the job's scene: one ``Lightmap``
    each, in order (``steps`` run to the end). The job's progress gets the finished fraction;
    raises ``Cancelled`` when the job is stopped."""
    results: list[Lightmap] = []
    for fraction in steps(job, targets, settings, results):
        if job.progress is not None:
            job.progress(fraction)
    return results


STEP_SECONDS = 0.1  # ``steps`` yields at most this often: a modal bake redraws at each step


def steps(job: RenderJob, targets: list[Target], settings: Settings | None, results: list,
          runner=None) -> Iterator[float]:
    """``bake`` as a generator of progress fractions in [0, 1], one every ``STEP_SECONDS``
    or so; the lightmaps are appended to ``results`` at the end. The scene's probes light the
    objects without a lightmap that the rays meet. Closing it early stops the work; nothing
    is written here. ``runner``: where the bounces' gathers run (``Here``, on the job's
    threads, by default; a cluster's runner has the same generator)."""
    last = time.monotonic()
    for fraction in _steps(job, targets, settings, results, runner):
        now = time.monotonic()
        if fraction >= 1.0 or now - last >= STEP_SECONDS:
            last = now
            yield fraction


def _steps(job: RenderJob, targets: list[Target], settings: Settings | None, results: list,
           runner=None) -> Iterator[float]:
    """``steps``, a fraction after every short piece of work."""
    from .. import kernels as all_kernels

    all_kernels.load(modules=all_kernels.MODULES)  # (the lightmaps' after a frame's)

    settings = settings or Settings()
    scene, poll = job.scene, job.poll

    base = dataclasses.replace(scene, camera=face_camera(np.zeros(3), 0, 16, 0.1, 100.0),
                               settings=dataclasses.replace(scene.settings, border=None,
                                                            cryptomatte=(), light_groups=(),
                                                            aovs=()))
    base = dataclasses.replace(base, probes=None)
    # no shadow maps: the direct light of the texels is ray traced (``_direct``)
    frame = pipeline.prepare(job.on(base), shadow_maps=[None] * shadow_map_count(base))
    frame.scene = dataclasses.replace(frame.scene, probes=scene.probes)
    first, index = _frame_index(scene)
    positions = (np.concatenate([m.positions for m in scene.meshes]) if scene.meshes
                 else np.zeros((0, 3, 3), np.float32))
    poll()
    texels = []
    for target in targets:
        poll()
        if target.width * target.height <= 0:
            raise LightmapError(f"{target.name}: an empty lightmap")
        texels.append(_texels(target, frame, first, index, positions))
    yield 0.05
    # per frame triangle: its lightmap and lightmap UVs
    tri_map = np.full(len(frame.positions), -1, np.int32)
    tri_uv = np.zeros((len(frame.positions), 3, 2), np.float32)
    for k, target in enumerate(targets):
        local = index[first[target.mesh]:first[target.mesh] + len(target.uvs)]
        ok = local >= 0
        tri_map[local[ok]] = k
        tri_uv[local[ok]] = target.uvs[ok]
    sizes = np.array([t.width * t.height for t in targets], np.int64)
    map_base = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    map_width = np.array([t.width for t in targets], np.int64)
    map_height = np.array([t.height for t in targets], np.int64)
    bvh = _Bvh.of(frame.positions)
    tris, order, bounds, links = bvh.tris, bvh.order, bvh.bounds, bvh.links
    casters = _Casters(frame, bvh if frame.casts is None else
                       _Bvh.of(frame.positions[frame.casts]))
    extent = np.ptp(tris.reshape(-1, 3), axis=0) if len(tris) else np.ones(3)
    reach = float(np.linalg.norm(extent)) * 2.0 + 1.0
    # what each texel is: albedo, emission and direct light, once
    albedo = [np.empty((len(tx.at), 3), np.float32) for tx in texels]
    emission = [np.empty((len(tx.at), 3), np.float32) for tx in texels]
    direct = [np.empty((len(tx.at), 3), np.float32) for tx in texels]
    texel_count = sum(len(tx.at) for tx in texels)
    seen = 0
    for k, tx in enumerate(texels):
        for lo in range(0, len(tx.at), CHUNK):
            poll()
            part = slice(lo, lo + CHUNK)
            albedo[k][part], emission[k][part] = _surface(frame, tx.tri[part], tx.p[part],
                                                          tx.n[part], tx.geo[part])
            direct[k][part] = _direct(frame, casters, reach, tx.tri[part], tx.p[part],
                                      tx.n[part], tx.geo[part], tx.offset[part])
            seen += len(tx.p[part])
            yield 0.05 + 0.05 * seen / max(texel_count, 1)
    corner = _corner_radiance(frame, scene, tri_map < 0, casters, reach)
    world = scene.world
    if world.texture is None:
        cube = np.zeros(1, np.float32)
        cube_size = 0
    else:
        cube_size = 32
        cube = with_border(world_cube(world, cube_size)).reshape(-1).astype(np.float32)
    color = np.asarray(world.color, np.float32).reshape(-1)[:3].copy()
    gathering = Gathering(texels, reach, tris, order, bounds, links, tri_map, tri_uv, corner,
                          map_base, map_width, map_height, cube, cube_size, color)
    runner = runner or Here(job)
    indirect = [np.zeros((len(tx.at), 3), np.float32) for tx in texels]
    sh = [np.zeros((len(tx.at), 4, 3), np.float32) for tx in texels]
    variance = [np.zeros(len(tx.at), np.float32) for tx in texels]
    bounces = max(1, int(settings.bounces))
    # the bounces before the last gather with a quarter of the rays: their noise is averaged
    # by the last gather, whose own noise is what the lightmap keeps
    counts = [max(8, int(settings.rays) // 4)] * (bounces - 1) + [int(settings.rays)]
    # the work, in rays per texel: the gathers, and each pass of the filter (``_clean``)
    filtering = (bounces - 1 + bool(settings.denoise)) * DENOISE_RAYS
    total_work = max(texel_count * (sum(counts) + filtering), 1)
    done = [0]
    threads = job.threads

    def at(work: float) -> float:
        poll()
        return 0.1 + 0.89 * min(work / total_work, 1.0)

    def filtered(k: int, values, var):
        """Target k's ``values`` through ``_clean``, its progress counted."""
        size = len(texels[k].at) * DENOISE_RAYS
        out = yield from _scaled(_clean(texels[k], targets[k], values, var, threads=threads),
                                 lambda f: at(done[0] + f * size))
        done[0] += size
        return out

    history: list[list[np.ndarray]] = []  # each gather's filtered irradiance, per target
    for bounce, rays in enumerate(counts):
        if bounce:  # the last gather's noise, filtered before it is gathered again
            history.append([])
            for k in range(len(texels)):
                history[-1].append((yield from filtered(k, indirect[k], variance[k])))
        current = history[-1] if history else indirect
        if bounce == len(counts) - 1 and len(history) >= 2:
            current = _converged(history[-2], history[-1],
                                 history[-3] if len(history) >= 3 else None)
        # the radiance every lightmapped surface leaves, from the last gather
        radiance = np.zeros((int(sizes.sum()), 3), np.float32)
        for k, (tx, target) in enumerate(zip(texels, targets, strict=True)):
            e = current[k]
            image = np.zeros((target.height * target.width, 3), np.float32)
            image[tx.at] = emission[k] + albedo[k] * (direct[k] + e) / np.float32(np.pi)
            valid = np.zeros(target.height * target.width, bool)
            valid[tx.at] = True
            image = dilate(image.reshape(target.height, target.width, 3),
                           valid.reshape(target.height, target.width), passes=4)
            radiance[map_base[k]:map_base[k] + sizes[k]] = image.reshape(-1, 3)
        jobs = []
        for k, tx in enumerate(texels):
            for lo in range(0, len(tx.at), GATHER_CHUNK):
                jobs.append((k, lo, min(lo + GATHER_CHUNK, len(tx.at))))
        base = done[0]
        found = yield from _scaled(runner.gathers(gathering, jobs, rays, radiance),
                                   lambda work, base=base: at(base + work))
        done[0] = base + sum(hi - lo for _, lo, hi in jobs) * rays
        indirect = [np.zeros_like(a) for a in indirect]
        sh = [np.zeros_like(a) for a in sh]
        variance = [np.zeros_like(a) for a in variance]
        for (k, lo, hi), (e, s_, v) in zip(jobs, found, strict=True):
            indirect[k][lo:hi], sh[k][lo:hi], variance[k][lo:hi] = e, s_, v
    out = []
    for k, (tx, target) in enumerate(zip(texels, targets, strict=True)):
        values = _lightmap_values(tx, indirect[k], sh[k], settings)
        if settings.denoise:
            values = yield from filtered(k, values, variance[k])
        out.append(_finish(scene, target, tx, values, settings))
        yield at(done[0])
    results.extend(out)
    yield 1.0


GATHER_CHUNK = 2048  # texels a gather job takes


@dataclass
class Gathering:
    """What a bounce's gathers read besides the radiance of the lightmapped surfaces
    (``gather``): each target's texels, the rays' reach, the scene's triangles and BVH, each
    triangle's lightmap and UVs (-1: none), the radiance of the others' corners, the
    lightmaps' places in the radiance atlas and the world's cube map or colour."""

    texels: list
    reach: float
    tris: np.ndarray
    order: np.ndarray
    bounds: np.ndarray
    links: np.ndarray
    tri_map: np.ndarray
    tri_uv: np.ndarray
    corner: np.ndarray
    map_base: np.ndarray
    map_width: np.ndarray
    map_height: np.ndarray
    cube: np.ndarray
    cube_size: int
    color: np.ndarray


def gather(g: Gathering, k: int, lo: int, hi: int, rays: int, radiance: np.ndarray):
    """Texels ``lo:hi`` of target ``k`` gathering ``rays`` rays each from the lightmapped
    surfaces' ``radiance`` (their atlas, (texels, 3) float32): (irradiance (n, 3), its SH
    (n, 4, 3), its variance (n,)) float32."""
    from ..kernels import lightmap as kernels

    tx = g.texels[k]
    e = np.empty((hi - lo, 3), np.float32)
    s = np.empty((hi - lo, 4, 3), np.float32)
    b = np.empty(hi - lo, np.float32)
    v = np.empty(hi - lo, np.float32)
    kernels.gather(tx.p[lo:hi], tx.n[lo:hi], tx.geo[lo:hi], tx.offset[lo:hi], rays, g.reach,
                   g.tris, g.order, g.bounds, g.links, g.tri_map, g.tri_uv, g.corner,
                   g.map_base, g.map_width, g.map_height, radiance, g.cube, g.cube_size,
                   g.color, _FACES, e, s, b, v)
    return e, s, v


class Here:
    """A lightmap bake's gathers on the job's threads (``steps``' runner). Another runner
    (a cluster's) has the same generator."""

    def __init__(self, job: RenderJob):
        self.job = job

    def gathers(self, g: Gathering, jobs: list, rays: int, radiance: np.ndarray
                ) -> Iterator[int]:
        """``gather`` of each of ``jobs`` ((target, lo, hi) each): yields the rays traced so
        far, returns their results in order."""
        lock, stop, traced = threading.Lock(), threading.Event(), [0]

        def work(k, lo, hi):
            def run():
                if stop.is_set():
                    raise Cancelled()
                out = gather(g, k, lo, hi, rays, radiance)
                with lock:
                    traced[0] += (hi - lo) * rays
                return out
            return run

        found = []
        for result in self.job.ordered([work(*j) for j in jobs], stop):
            found.append(result)
            yield traced[0]
        return found


BAKE_BYTES = 340  # per texel of the lightmaps, while baking (``tools/bench_lightmap_bake.py``)
BAKE_BYTES_DIRECTIONAL = 440


def bake_bytes(targets: list[Target], settings: Settings) -> int:
    """Bytes a bake of ``targets`` holds at its peak, about: per texel of their images, the
    texels' points and surfaces, each gather's results and the filter's images."""
    texels = sum(int(t.width) * int(t.height) for t in targets)
    return texels * (BAKE_BYTES_DIRECTIONAL if settings.directional else BAKE_BYTES)


DENOISE_RAYS = 16  # a texel's pass of the filter costs about as much as this many rays
CHUNK = 1 << 18  # texels whose surface and direct light are worked out between two steps


def _scaled(steps, at):
    """Run the generator ``steps``, yielding ``at(fraction)`` for each fraction it yields;
    returns what it returns."""
    while True:
        try:
            fraction = next(steps)
        except StopIteration as done:
            return done.value
        yield at(fraction)


def _converged(previous: list[np.ndarray], last: list[np.ndarray],
               before: list[np.ndarray] | None) -> list[np.ndarray]:
    """The irradiance after every bounce, from the last gathers' (per target, (M, 3)): the
    last increment continued by its geometric series (``series``; the ratio of the last two
    increments' sums per channel). With only two gathers, the ratio is the second's to the
    first's."""
    d_last = [a - b for a, b in zip(last, previous, strict=True)]
    d_prev = ([b - c for b, c in zip(previous, before, strict=True)] if before is not None
              else previous)
    k = series.tail_factor(sum(d.sum(0, dtype=np.float64) for d in d_last),
                           sum(d.sum(0, dtype=np.float64) for d in d_prev))
    return [e + np.maximum(d, 0.0) * k.astype(np.float32)
            for e, d in zip(last, d_last, strict=True)]


def _clean(tx: _Texels, target: Target, values: np.ndarray, variance: np.ndarray,
           threads: int | None = None):
    """One target's texel values (M, C) through ``lightmap.denoise_steps``: a generator of
    its progress fractions that returns (M, C)."""
    h, w = target.height, target.width
    c = values.shape[1]
    image = np.zeros((h * w, c), np.float32)
    image[tx.at] = values
    pos = np.zeros((h * w, 3), np.float32)
    nor = np.zeros((h * w, 3), np.float32)
    var = np.zeros(h * w, np.float32)
    pos[tx.at], nor[tx.at], var[tx.at] = tx.p, tx.n, variance
    out = yield from denoise_steps(image.reshape(h, w, c), tx.chart, pos.reshape(h, w, 3),
                                   nor.reshape(h, w, 3), var.reshape(h, w), tx.texel,
                                   threads=threads)
    return out.reshape(-1, c)[tx.at]


def _lightmap_values(tx: _Texels, irradiance, sh, settings: Settings) -> np.ndarray:
    """What one target's lightmap stores per texel, (M, 3) irradiance or (M, 12) L1 SH."""
    if not settings.directional:
        return irradiance
    # Y00 set so the irradiance at the texel's normal is the gathered one
    l1 = np.einsum("nk,nkc->nc", tx.n[:, [1, 2, 0]], sh[:, 1:4]) * (SH_SCALE_C1 * 2.0 / 3.0
                                                                      * np.pi)
    sh = sh.copy()
    sh[:, 0] = (irradiance - l1) / (np.pi * SH_SCALE_C0)
    return sh.reshape(-1, 12)


def _finish(scene: Scene, target: Target, tx: _Texels, values: np.ndarray,
            settings: Settings) -> Lightmap:
    """One target's texel values (``_lightmap_values``, filtered) made an image: dilated,
    stitched."""
    h, w = target.height, target.width
    c = values.shape[1]
    image = np.zeros((h * w, c), np.float32)
    image[tx.at] = values
    valid = np.zeros(h * w, bool)
    valid[tx.at] = True
    image, valid = image.reshape(h, w, c), valid.reshape(h, w)
    image = dilate(image, valid, passes=max(8, settings.padding * 2))
    mesh = scene.meshes[target.mesh]
    image = stitch(image, seams(mesh.positions, target.uvs))
    if not settings.directional:
        image = np.maximum(image, 0.0)
    return Lightmap(np.ascontiguousarray(image, np.float32),
                    np.ascontiguousarray(target.uvs, np.float32))


# ---------------------------------------------------------------------------------------------
# Keys


_digests: dict[int, tuple] = {}  # id(positions) -> (weak reference to it, its digest)


def geometry_key(positions: np.ndarray) -> str:
    """A digest of an object's triangles ``positions`` (T, 3, 3), world space, to 0.1 mm: its
    lightmap was baked for these, 16 hex digits. Remembered per array while it lives (a
    viewport extracts the same batches' arrays at every update)."""
    held = _digests.get(id(positions))
    if held is not None and held[0]() is positions:
        return held[1]
    q = np.round(np.asarray(positions, np.float64) * 1e4).astype(np.int64)
    digest = hashlib.sha256(q.tobytes()).hexdigest()[:16]
    try:
        _digests[id(positions)] = (weakref.ref(positions), digest)
    except TypeError:  # not an object a weak reference can follow
        pass
    for key in [k for k, (ref, _) in _digests.items() if ref() is None]:
        del _digests[key]
    return digest


def light_key(scene: Scene) -> str:
    """A digest of what lights the lightmaps: every triangle's place, the lights, the world's
    colour and strength (any change makes the scene's lightmaps stale), 16 hex digits."""
    h = hashlib.sha256()
    for m in scene.meshes:
        h.update(geometry_key(m.positions).encode())
        h.update(np.asarray(m.material, np.int32).tobytes())
    h.update(repr(sorted({m.name for m in scene.materials})).encode())
    for light in scene.lights:
        h.update(repr((light.kind, np.round(np.asarray(light.color, np.float64), 5).tolist(),
                       np.round(np.asarray(light.position, np.float64), 4).tolist(),
                       np.round(np.asarray(light.direction, np.float64), 4).tolist(),
                       round(light.radius, 5), round(light.spot_size, 5), light.shadow,
                       light.receivers, light.blockers)).encode())
    if any(linking.linked(scene.lights)):
        h.update(repr([(m.light_sets, m.shadow_sets) for m in scene.meshes]).encode())
    w = scene.world
    h.update(repr((np.round(np.asarray(w.color, np.float64), 5).tolist(), round(w.strength, 5),
                   None if w.texture is None else w.texture.name)).encode())
    return h.hexdigest()[:16]
