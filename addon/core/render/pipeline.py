"""One frame: raster -> materials -> shadows -> direct light -> passes, tile by tile.

- Anti-aliasing as Cycles does it: every sample position is drawn from the pixel filter
  (Blackman-Harris of width 1.5 px by default, whose window Cycles spreads over twice the width;
  filter importance sampling, Ernst et al. 2006) and contributes to its own pixel only, so a
  plain average of the samples is the filtered pixel. Sample positions follow the R2
  low-discrepancy sequence (Roberts 2018) mapped through the filter's inverse CDF,
  independently in x and y as in Cycles' filter table.
- Tiles: the frame is cut into square tiles; each tile is rasterized with a projection that maps
  the tile to the whole viewport, so memory depends on the tile size, not the resolution.
- Deferred: only visible points are shaded, once per pixel and triangle (see ``_render_tile``).
- Threads: tiles (and the lights' shadow maps) are rendered on ``settings.threads`` threads at
  once; the compiled kernels (``kernels``) and NumPy's loops release Python's lock, so they run
  on separate cores.

Passes: the table of ``passes.py``. Depth and IndexMA come from one sample, the one nearest the
pixel centre, as Cycles writes them from one sample; the others are averaged over every sample,
the background counting as 0 in all but Combined, as Cycles accumulates them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor, wait
from dataclasses import dataclass

import numpy as np

from ..formulas import affine, occlusion, sh, texture
from ..lighting import lightmap as lightmap_light
from ..lighting import probes, shade, world_sun
from ..scene import Material, Scene, material
from . import raster, shadows
from . import sky as sky_light
from .passes import EMPTY_DEPTH, SAMPLED, SAMPLED_WIDTH


class Cancelled(Exception):
    """The host asked the render to stop."""


def thread_count(settings) -> int:
    """Threads a render uses: ``settings.threads``, or one per CPU core when that is 0."""
    return max(1, int(settings.threads) or os.cpu_count() or 1)


def _ordered(jobs: Iterable[Callable[[], object]], threads: int, poll: Callable[[], None],
             stop: threading.Event) -> Iterator:
    """Run ``jobs`` on ``threads`` threads, at most two per thread queued, and yield their
    results in order. ``poll`` runs on the calling thread at least ten times a second while it
    waits and may raise (e.g. ``Cancelled``); on any exit ``stop`` is set, the queued jobs are
    dropped and the running ones are waited for (jobs should return soon once it is set)."""
    if threads <= 1:
        try:
            for job in jobs:
                poll()
                yield job()
        finally:
            stop.set()
        return
    jobs = iter(jobs)
    pending: deque = deque()
    with ThreadPoolExecutor(threads, thread_name_prefix="bo2-render") as pool:
        try:
            while True:
                while len(pending) < 2 * threads and (job := next(jobs, None)) is not None:
                    pending.append(pool.submit(job))
                if not pending:
                    return
                poll()
                while not wait([pending[0]], timeout=0.1).done:
                    poll()
                yield pending.popleft().result()
        finally:
            stop.set()
            for future in pending:
                future.cancel()


def _blackman_harris(x: np.ndarray, width: float) -> np.ndarray:
    """Blackman-Harris window over [-width/2, width/2] (the form Cycles' filter table uses)."""
    t = 2.0 * np.pi * (x / width + 0.5)
    return 0.35875 - 0.48829 * np.cos(t) + 0.14128 * np.cos(2 * t) - 0.01168 * np.cos(3 * t)


def sample_offsets(count: int, filter_width: float = 1.5) -> np.ndarray:
    """(count, 2) float64 sample positions relative to the pixel's top-left corner.

    Distributed as Cycles' Blackman-Harris pixel filter of ``filter_width`` pixels centred on
    the pixel. Cycles evaluates that window over twice the width (so the samples reach
    0.5 - width .. 0.5 + width); rendering a hard edge in both engines confirms it
    (tests/blender). A single sample sits at the centre.
    """
    if count == 1:
        return np.array([[0.5, 0.5]])
    g = 1.32471795724474602596  # plastic number: root of x^3 = x + 1
    u = (0.5 + np.array([1.0 / g, 1.0 / (g * g)]) * np.arange(count)[:, None]) % 1.0
    if filter_width <= 0.01:
        return np.full((count, 2), 0.5)
    support = 2.0 * filter_width  # Cycles widens the Blackman-Harris window to twice the width
    xs = np.linspace(-support / 2, support / 2, 1025)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (_blackman_harris(xs[1:], support)
                                                  + _blackman_harris(xs[:-1], support)))])
    cdf /= cdf[-1]
    return 0.5 + np.interp(u, cdf, xs)


@dataclass
class Frame:
    """A scene prepared for rendering: all triangles concatenated, tables, shadow maps."""

    scene: Scene
    positions: np.ndarray   # (T, 3, 3) float32
    normals: np.ndarray     # (T, 3, 3) float32
    uvs: np.ndarray         # (T, 3, 2) float32 (zeros where has_uv is False), or (0, 3, 2)
    #                         when no triangle has UVs (they read 0)
    has_uv: np.ndarray      # (T,) bool
    holdout: np.ndarray     # (T,) bool
    material: np.ndarray    # (T,) int32
    clip: np.ndarray        # (T, 3, 4) float32 clip-space corners of the whole frame (or
    #                         their raster.Projection: for very many triangles, or for a view
    #                         drawn as one tile, ``with_camera``'s ``once``)
    cull: np.ndarray | None
    shadow_maps: list
    tables: dict            # constant material parameters per material: name -> array
    attributes: dict        # key -> (T, 3, k) float32 corner values (MeshBatch.attributes)
    obj: np.ndarray         # (T,) int32 index of the triangle's object instance
    world_to_object: np.ndarray  # (B, 4, 4) float64 per object instance
    texspace: np.ndarray    # (B, 2, 3) float32 per object instance
    fades: np.ndarray       # (T,) bool: the triangle's material may be transparent
    # Per-tile culled triangles (and ``raster.rasterize``'s set-ups, where it draws) kept across
    # renders of this very frame (the viewport), or None:
    # (tile, margin) -> (``_margin``'s tuple, ``raster.rasterize``'s ``keep`` dict)
    tiles: dict | None = None
    seen: np.ndarray | None = None   # (T,) bool: the camera sees the triangle (None: all)
    casts: np.ndarray | None = None  # (T,) bool: the triangle casts shadows (None: all)
    # lightmaps (``MeshBatch.lightmap``): per triangle the index of its lightmap in
    # ``lightmaps`` (T,) int32, -1 none, and its lightmap UVs (T, 3, 2); None without any
    lightmap: np.ndarray | None = None
    lightmap_uvs: np.ndarray | None = None
    lightmaps: list | None = None

    @property
    def sky(self) -> sky_light.Sky | None:
        """The world's dome of shadow maps (``sky``): the maps after the lights' ones."""
        extra = self.shadow_maps[len(self.scene.lights):]
        return sky_light.Sky(extra) if any(m is not None for m in extra) else None


def shadow_map_count(scene: Scene, sky: bool | None = None) -> int:
    """Shadow maps a frame of ``scene`` holds: one per light, then the sky's dome
    (``settings.sky_directions``) when ``sky`` (None: when the scene has indirect light) and
    there is geometry."""
    sky = scene.probes is not None if sky is None else sky
    dome = scene.settings.sky_directions if sky and scene.meshes else 0
    return len(scene.lights) + max(0, int(dome))


def _constant_tables(materials: list[Material]) -> dict:
    """Per-material constants of the materials whose program is constant, and which vary."""
    n = len(materials)
    table = {k: np.zeros((n, c), np.float32) for k, c in
             (("albedo", 3), ("rf0", 3), ("emission", 3), ("gloss", 1), ("alpha", 1))}
    varying = np.array([not m.program.constant for m in materials], bool)
    table["occlusion"] = np.ones((n, 1), np.float32)
    for i, m in enumerate(materials):
        if not varying[i]:
            p = material.evaluate(m.program, _constant_points())
            for k in table:
                value = getattr(p, k)
                if value is not None:
                    table[k][i] = np.asarray(value, np.float32).reshape(-1)[:table[k].shape[1]]
    table["varying"] = varying
    table["fades"] = np.array([m.program.fades and (varying[i] or table["alpha"][i, 0] < 1.0)
                               for i, m in enumerate(materials)], bool)
    table["pass_index"] = np.array([m.pass_index for m in materials], np.float32)
    return table


def _constant_points() -> material.Points:
    """One point for constant programs (which read nothing of it)."""
    up = np.array([[0.0, 0.0, 1.0]], np.float32)
    fields = {"position": np.zeros((1, 3), np.float32), "normal": up, "geo": up, "view": up,
              "backfacing": np.zeros((1, 1), np.float32), "world_to_object": np.eye(4)[None],
              "texspace": np.array([[[0.0] * 3, [1.0] * 3]], np.float32),
              "window": np.zeros((1, 2), np.float32), "world_to_camera": np.eye(4)}
    return material.Points(1, np.array([[1.0, 0.0, 0.0]], np.float32), fields,
                           lambda key, bary: None)


def _broken(positions) -> tuple[np.ndarray, int, int]:
    """Triangles to keep (finite corners and non-zero area), and the counts of the others."""
    finite = np.empty(len(positions), bool)
    area2 = np.empty(len(positions), positions.dtype)
    for lo in range(0, len(positions), 1 << 20):  # bounded temporaries (a million instances)
        part = positions[lo:lo + (1 << 20)]
        finite[lo:lo + len(part)] = np.isfinite(part).all(axis=(1, 2))
        with np.errstate(invalid="ignore", over="ignore"):
            cross = np.cross(part[:, 1] - part[:, 0], part[:, 2] - part[:, 0])
            area2[lo:lo + len(part)] = np.einsum("tc,tc->t", cross, cross)
    flat = finite & ~(area2 > 0.0)
    return finite & ~flat, int((~finite).sum()), int(flat.sum())


def _concat_attributes(meshes) -> dict:
    """Every mesh batch's corner attributes, concatenated; zeros where a batch lacks one."""
    widths = {}
    for m in meshes:
        for key, a in m.attributes.items():
            widths.setdefault(key, a.shape[2])
    return {key: np.concatenate([
        np.asarray(m.attributes[key], np.float32) if key in m.attributes
        else np.zeros((len(m.positions), 3, w), np.float32) for m in meshes])
        for key, w in widths.items()}


def prepare(scene: Scene, warn: Callable[[str], None] | None = None,
            should_stop: Callable[[], bool] | None = None, shadow_maps: list | None = None,
            fit_shadows: bool = True) -> Frame:
    """Concatenate the meshes, project them, and build every light's shadow map.

    shadow_maps: reuse these (one per light, then the sky's: ``shadow_map_count``, from an
                 earlier ``prepare`` of the same geometry and lights) instead of building them
    fit_shadows: fit sun cascades to this camera's view; False covers every caster with one
                 cascade (for views in every direction, e.g. a probe's six faces)
    """
    meshes = scene.meshes

    def joined(parts, dtype):  # one batch's array is used as it is (a million instances)
        return (parts[0] if len(parts) == 1 else np.concatenate(parts)).astype(dtype, copy=False)

    # per batch instance (a batch of I instances has I): its world_to_object and texspace
    per_instance = [np.eye(4)[None] if m.world_to_object is None else
                    np.asarray(m.world_to_object, np.float64).reshape(-1, 4, 4) for m in meshes]
    if meshes:
        positions = joined([m.positions for m in meshes], np.float32)
        normals = joined([m.normals for m in meshes], np.float32)
        mat_index = joined([m.material for m in meshes], np.int32)
        uvs = (joined([m.uvs if m.uvs is not None else
                       np.zeros((len(m.positions), 3, 2), np.float32) for m in meshes],
                      np.float32) if any(m.uvs is not None for m in meshes)
               else np.zeros((0, 3, 2), np.float32))  # none: no zeros held for every corner
        has_uv = joined([np.full(len(m.positions), m.uvs is not None) for m in meshes], bool)
        holdout = joined([np.full(len(m.positions), m.holdout) for m in meshes], bool)
        seen = (joined([np.full(len(m.positions), m.camera) for m in meshes], bool)
                if not all(m.camera for m in meshes) else None)
        casts = (joined([np.full(len(m.positions), m.shadow) for m in meshes], bool)
                 if not all(m.shadow for m in meshes) else None)
        first = np.cumsum([0] + [len(w) for w in per_instance]).astype(np.int32)
        obj = joined([np.repeat(np.arange(first[k], first[k + 1], dtype=np.int32),
                                len(m.positions) // len(w))
                      for k, (m, w) in enumerate(zip(meshes, per_instance, strict=True))],
                     np.int32)
    else:
        positions = normals = np.zeros((0, 3, 3), np.float32)
        uvs = np.zeros((0, 3, 2), np.float32)
        mat_index = obj = np.zeros(0, np.int32)
        has_uv = holdout = np.zeros(0, bool)
        seen = casts = None
    lit: dict[int, int] = {}  # batch -> its lightmap's index in Frame.lightmaps
    if scene.settings.lightmaps:
        for k, m in enumerate(meshes):
            if m.lightmap is not None:
                lit[k] = len(lit)
    lightmap = lightmap_uvs = None
    if lit:
        lightmap = joined([np.full(len(m.positions), lit.get(k, -1), np.int32)
                           for k, m in enumerate(meshes)], np.int32)
        lightmap_uvs = joined([m.lightmap.uvs if k in lit else
                               np.zeros((len(m.positions), 3, 2), np.float32)
                               for k, m in enumerate(meshes)], np.float32)
    attributes = _concat_attributes(meshes)
    world_to_object = joined(per_instance, np.float64) if meshes else np.eye(4)[None]
    texspace = np.concatenate([
        np.broadcast_to(np.asarray([[0.0] * 3, [1.0] * 3] if m.texspace is None else m.texspace,
                                   np.float32), (len(w), 2, 3))
        for m, w in zip(meshes, per_instance, strict=True)]) if meshes else np.array(
        [[[0.0] * 3, [1.0] * 3]], np.float32)
    mats = scene.materials or [Material()]
    if len(mat_index) and (mat_index.max() >= len(mats) or mat_index.min() < 0):
        raise ValueError("a triangle refers to a material index outside Scene.materials")
    cut = np.array([m.program.holdout for m in mats], bool)
    if cut.any():  # a material whose surface is a Holdout node cuts a hole like an object
        holdout = holdout | cut[mat_index]
    keep, nonfinite, flat = _broken(positions)
    if not keep.all():
        if warn is not None:
            warn(f"Skipped {nonfinite} triangles with NaN or infinite vertices and "
                 f"{flat} with zero area")
        positions, mat_index, has_uv, holdout, obj = (
            a[keep] for a in (positions, mat_index, has_uv, holdout, obj))
        seen, casts, lightmap, lightmap_uvs = (None if a is None else a[keep] for a in (
            seen, casts, lightmap, lightmap_uvs))
        normals = np.nan_to_num(normals[keep])
        uvs = np.nan_to_num(uvs[keep]) if len(uvs) else uvs
        attributes = {k: a[keep] for k, a in attributes.items()}
    uvs = uvs.astype(np.float32, copy=False)
    # attribute values are data from the mesh (Geometry Nodes can make NaN): finite
    attributes = {k: a if np.isfinite(a).all() else np.nan_to_num(a, posinf=0.0, neginf=0.0)
                  for k, a in attributes.items()}

    cam = scene.camera
    clip = _clip(positions, cam, seen)
    cull_t = np.array([m.backface_culling for m in mats], bool)
    cull = cull_t[mat_index] if cull_t.any() else None

    tables = _constant_tables(mats)
    fades = tables["fades"][mat_index]
    frame = Frame(scene, positions, normals, uvs, has_uv, holdout, mat_index, clip, cull,
                  [None] * shadow_map_count(scene) if shadow_maps is None else shadow_maps,
                  tables, attributes, obj, world_to_object, texspace, fades, seen=seen,
                  casts=casts, lightmap=lightmap, lightmap_uvs=lightmap_uvs,
                  lightmaps=[meshes[k].lightmap for k in lit] or None)
    if shadow_maps is None:
        frame.shadow_maps = build_shadow_maps(frame, should_stop, fit_shadows)
    return frame


def mesh_flags(frame: Frame, values) -> np.ndarray | None:
    """(T,) bool per triangle of ``frame``: ``values[k]`` of ``frame.scene.meshes[k]``, the
    batch it came from; None when every value is True."""
    if all(values):
        return None
    counts = [1 if m.world_to_object is None else len(np.reshape(m.world_to_object, (-1, 16)))
              for m in frame.scene.meshes]  # instances per batch, as ``frame.obj`` counts them
    batch = np.searchsorted(np.cumsum(counts), frame.obj, side="right")
    return np.asarray(values, bool)[batch]


def _clip(positions: np.ndarray, camera, seen: np.ndarray | None = None
          ) -> np.ndarray | raster.Projection:
    """(T, 3, 4) float32 clip coordinates of the triangles through ``camera``; for more
    triangles than a raster keeps at once, their ``raster.Projection`` (computed a chunk at a
    time when drawn: a million instances never hold them all). Triangles the camera does not
    see (``seen`` False) are left out: behind the camera, or out of the projection's index."""
    matrix = camera.projection @ camera.world_to_camera
    if len(positions) > raster.SETUP_TRIANGLES:
        index = None if seen is None else np.flatnonzero(seen)
        return raster.Projection(positions, matrix, np.float32, index)
    clip = raster.project(positions, matrix)
    if seen is not None:
        clip[~seen] = (0.0, 0.0, 0.0, -1.0)
    return clip


def dome_lit(scene: Scene, count: int, world_sh: np.ndarray | None = None) -> np.ndarray:
    """(count,) bool: the dome directions whose shadow maps are built, those the world sends
    light from (``sky.radiance_weights`` of ``world_sh``, by default the scene's probes'; every
    direction when neither is known)."""
    if world_sh is None and scene.probes is not None:
        world_sh = scene.probes.world_sh
    if world_sh is None:
        return np.ones(count, bool)
    return sky_light.radiance_weights(world_sh, count) > 0.0


def build_shadow_maps(frame: Frame, should_stop: Callable[[], bool] | None = None,
                      fit_shadows: bool = True, sky: bool | None = None,
                      world_sh: np.ndarray | None = None, every_direction: bool = False,
                      focus: tuple | None = None) -> list:
    """Every light's shadow map of ``frame``'s geometry (None for a light without shadows),
    then the sky's dome (``sky.dome_lights``: suns of ``settings.sky_resolution`` texels,
    fitted as the lights' are; None towards directions the world sends no light from,
    ``dome_lit``, unless ``every_direction``: for a world that may change, as a viewport's):
    ``shadow_map_count`` maps, every face and cascade rendered at once on the render's
    threads. Arguments as ``prepare``, ``shadow_map_count`` and ``dome_lit``; ``focus``:
    without ``fit_shadows``, the world box whose shadows matter (``shadows.shadow_map_jobs``)."""
    scene = frame.scene
    count = shadow_map_count(scene, sky)
    if not len(frame.positions):
        return [None] * count

    def poll() -> None:
        if should_stop is not None and should_stop():
            raise Cancelled()

    positions, fades, index = frame.positions, frame.fades, None
    if frame.casts is not None:  # objects that cast no shadow are not in the maps
        index = np.flatnonzero(frame.casts)
        positions, fades = positions[index], fades[index]
        if not len(positions):
            return [None] * count
    cutout = ((fades, lambda t, b: _caster_alpha(frame, t if index is None else index[t], b))
              if fades.any() else None)
    s = scene.settings
    view = scene.camera if fit_shadows else None
    plans = []
    for light in scene.lights:
        poll()
        plans.append(shadows.shadow_map_jobs(light, positions, view, focus=focus,
                                             resolution=s.shadow_resolution, cutout=cutout))
    dome = count - len(scene.lights)
    lit = np.ones(dome, bool) if every_direction else dome_lit(scene, dome, world_sh)
    key = None if cutout is not None or not lit.any() else _dome_key(
        positions, view, focus, s.sky_resolution, lit)
    with _domes_lock:
        kept = _domes.get(key) if key is not None else None
    if kept is None:
        view_range = (shadows.camera_depth_range(view, positions)
                      if view is not None and lit.any() else None)  # the same for every sun
        for light, on in zip(sky_light.dome_lights(dome), lit, strict=True):
            poll()
            plans.append(shadows.shadow_map_jobs(
                light, positions, view, resolution=s.sky_resolution, cutout=cutout,
                max_filter=sky_light.MAX_FILTER, view_range=view_range, focus=focus)
                if on else ([], lambda done: None))
    done = iter(list(_ordered([job for jobs, _ in plans for job in jobs],
                              thread_count(s), poll, threading.Event())))
    maps = [finish([next(done) for _ in jobs]) for jobs, finish in plans]
    if kept is not None:
        return maps + kept
    if key is not None:
        with _domes_lock:
            _domes[key] = maps[len(scene.lights):]
            while len(_domes) > DOMES_KEPT:
                _domes.pop(next(iter(_domes)))
    return maps


DOMES_KEPT = 2  # the dome's maps of the last geometries and views, reused while they stay
_domes: dict = {}
_domes_lock = threading.Lock()


def _dome_key(positions: np.ndarray, view, focus, resolution: int, lit: np.ndarray) -> tuple:
    """What the dome's maps depend on: the casters' triangles, the view they are fitted to
    (None: all casters, or ``focus``), their resolution and the lit directions."""
    digest = hashlib.blake2b(np.ascontiguousarray(positions).view(np.uint8), digest_size=16)
    camera = None if view is None else (
        np.asarray(view.world_to_camera, np.float64).tobytes(),
        np.asarray(view.projection, np.float64).tobytes(), view.width, view.height)
    where = None if focus is None else np.asarray(focus, np.float64).tobytes()
    return (digest.hexdigest(), camera, where, int(resolution), lit.tobytes())


def _caster_alpha(frame: Frame, tri, bary) -> np.ndarray:
    """(N,) alpha of shadow casters at shadow-map texels (triangles ``tri``, weights ``bary``)."""
    q = frame.positions[tri]
    p = np.einsum("nk,nkc->nc", bary, q).astype(np.float32)
    n = material._unit(np.einsum("nk,nkc->nc", bary, frame.normals[tri]))
    geo = material._unit(np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]))
    zero = np.zeros(len(tri), np.float32)
    return _materials(frame, tri, bary, p, n, geo, geo, zero, zero, shifts=False).alpha


def with_camera(frame: Frame, camera, once: bool = False) -> Frame:
    """``frame`` seen through another camera: only the projection is redone (same geometry,
    materials and shadow maps). ``once``: the view is drawn as one tile (a probe's face), so
    its projection is left to the tile (``tile_clip``: projected and culled in one pass)."""
    if once:
        clip = raster.Projection(frame.positions, camera.projection @ camera.world_to_camera,
                                 np.float32, None if frame.seen is None else
                                 np.flatnonzero(frame.seen))
    else:
        clip = _clip(frame.positions, camera, frame.seen)
    return dataclasses.replace(frame, scene=dataclasses.replace(frame.scene, camera=camera),
                               clip=clip, tiles=None if frame.tiles is None else {})


def with_materials(frame: Frame, scene: Scene) -> Frame | None:
    """``frame`` with ``scene``'s materials (same geometry, lights and camera): only the
    material tables are built again. None when the shadow maps or the holdout triangles depend
    on the materials (transparent or holdout surfaces, before or after): ``prepare`` instead."""
    mats = scene.materials or [Material()]
    old = frame.scene.materials or [Material()]
    if len(mats) != len(old) or frame.fades.any() or any(
            m.program.holdout or m.program.fades for m in (*mats, *old)):
        return None
    tables = _constant_tables(mats)
    cull_t = np.array([m.backface_culling for m in mats], bool)
    scene = dataclasses.replace(scene, camera=frame.scene.camera)
    cull = cull_t[frame.material] if cull_t.any() else None
    same_cull = (cull is None and frame.cull is None) or (
        cull is not None and frame.cull is not None and np.array_equal(cull, frame.cull))
    return dataclasses.replace(frame, scene=scene, tables=tables,
                               fades=tables["fades"][frame.material], cull=cull,
                               tiles=frame.tiles if same_cull or frame.tiles is None else {})


def tiles(scene: Scene) -> list[tuple[int, int, int, int]]:
    """(x0, y0, x1, y1) tiles covering the render border (or the frame), top-left origin."""
    cam, st = scene.camera, scene.settings
    bx0, by0, bx1, by1 = st.border or (0, 0, cam.width, cam.height)
    size = max(16, int(st.tile_size))
    return [(x, y, min(x + size, bx1), min(y + size, by1))
            for y in range(by0, by1, size) for x in range(bx0, bx1, size)]


def tile_clip(clip: np.ndarray, width: int, height: int, tile) -> tuple[np.ndarray, np.ndarray]:
    """Clip coordinates re-projected so that ``tile`` fills the viewport, of the triangles that
    may touch it (the others lie wholly beyond one plane of its frustum).

    clip: (T, 3, 4) float32 of the whole frame (``Frame.clip``), or its ``raster.Projection``
    returns: (K, 3, 4) float32 clip coordinates and (K,) int64 indices into ``clip``, increasing
             (for a Projection of more triangles than a raster sets up at once: the Projection
             of the tile's triangles, and their indices; a smaller one is projected and culled
             in one pass, ``kernels.raster.project_survivors``)
    """
    from ..kernels import raster as kernels

    x0, y0, x1, y1 = tile
    tw, th = x1 - x0, y1 - y0
    ax, bx = np.float32(width / tw), np.float32((width - 2.0 * x0) / tw - 1.0)
    ay, by = np.float32(height / th), np.float32(1.0 - height / th + 2.0 * y0 / th)
    if isinstance(clip, raster.Projection) and len(clip.positions) <= raster.SETUP_TRIANGLES:
        # a view drawn as one tile (``with_camera``'s ``once``): projected and culled at once
        seen = np.zeros(0, bool)
        if clip.index is not None:
            seen = np.zeros(len(clip.positions), bool)
            seen[clip.index] = True
        out = np.empty((len(clip.positions), 3, 4), np.float32)
        index = np.empty(len(clip.positions), np.int64)
        count = kernels.project_survivors(np.ascontiguousarray(clip.positions, np.float32),
                                          np.ascontiguousarray(clip.matrix, np.float64), seen,
                                          ax, bx, ay, by, out, index)
        return out[:count], index[:count]
    if isinstance(clip, raster.Projection):  # re-projected a chunk at a time when drawn
        m = np.eye(4)
        m[0, 0], m[0, 3] = width / tw, (width - 2.0 * x0) / tw - 1.0
        m[1, 1], m[1, 3] = height / th, 1.0 - height / th + 2.0 * y0 / th
        tile = raster.Projection(clip.positions, m @ clip.matrix, clip.dtype,
                                 clip.index).survivors()
        return tile, tile.index
    clip = np.ascontiguousarray(clip, np.float32)
    out = np.empty_like(clip)
    index = np.empty(len(clip), np.int64)
    count = kernels.tile_survivors(clip, ax, bx, ay, by, out, index)
    return out[:count], index[:count]


def _background(scene: Scene, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """(N, 3) world radiance seen through window positions x, y (N,); a texture's times the
    background's opacity (``World.background_alpha``, a studio light's)."""
    world = scene.world
    if world.texture is None:
        return np.broadcast_to(np.asarray(world.color, np.float32), (len(x), 3))
    _, d = scene.camera.rays(x, y)
    px = texture.sample(world.texture,
                        texture.direction_to_equirect_uv(affine.linear(d, world.rotation)),
                        world.background_lod or None)
    scale = np.float32(world.strength * world.background_alpha)
    out = px[:, :3] * scale
    if world.sun is not None:
        out += world_sun.disc_radiance(world, d) * np.float32(world.background_alpha)
    return out.astype(np.float32)


def _points(frame: Frame, tri, bary, p, n, geo, v, sx, sy, shifts=True) -> material.Points:
    """What a material program reads at the points (``material.Points``): tri (N,), bary
    (N, 3), p, n, geo, v (N, 3) (``_shade_points``), window positions sx, sy (N,)."""
    from ..kernels import shading

    cam = frame.scene.camera
    tri = np.ascontiguousarray(tri, np.int32)

    def interpolate(key, weights):
        corners = frame.uvs if key == ("uv", "") else frame.attributes.get(key)
        if corners is None:
            return None
        if not len(corners):  # no triangle has UVs
            return np.zeros((len(tri), corners.shape[2]), np.float32)
        out = np.empty((len(tri), corners.shape[2]), np.float32)
        shading.interpolate(tri, np.ascontiguousarray(weights, np.float32), corners, out)
        return out

    def window(x, y):
        return np.stack([x / cam.width, 1.0 - y / cam.height], 1).astype(np.float32)

    def moved(axis, step):
        x, y = sx() + step * (axis == 0), sy() + step * (axis == 1)
        origin, direction = cam.rays(x, y)
        b, q = np.empty((len(tri), 3), np.float32), np.empty((len(tri), 3), np.float32)
        # NaN where a ray runs along the plane: steps are then unknown, the coarsest mip level
        # is read and a bump keeps the normal
        shading.plane_hits(tri, frame.positions, origin, direction, b, q)
        return b, {"position": q, "window": lambda: window(x, y)}

    def part(a):  # the points' rows of a (N, ...) array, gathered when first read
        return a if callable(a) else (lambda: a)

    p, n, geo, v, sx, sy = (part(a) for a in (p, n, geo, v, sx, sy))
    fields = {
        "position": p, "normal": n, "geo": geo, "view": v,
        "backfacing": lambda: (np.einsum("nc,nc->n", geo(), _face_normals(frame, tri))
                               < 0.0)[:, None].astype(np.float32),
        "world_to_object": lambda: frame.world_to_object[frame.obj[tri]],
        "texspace": lambda: frame.texspace[frame.obj[tri]],
        "window": lambda: window(sx(), sy()),
        "world_to_camera": cam.world_to_camera,
    }
    return material.Points(len(tri), bary, fields, interpolate, moved if shifts else None)


def _face_normals(frame: Frame, tri) -> np.ndarray:
    """(N, 3) unnormalized front-face normals of triangles ``tri`` (counter-clockwise)."""
    q = frame.positions[tri]
    return np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])


def nearest_faces(frame: Frame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the camera of ``frame`` sees first at each pixel centre (no shading): the
    triangle (H W,) int32, -1 where none, its view depth (H W,) float32 (``raster``), and the
    unnormalized front-face normals (M, 3) of the M pixels that see one, row-major."""
    cam = frame.scene.camera
    tile = (0, 0, cam.width, cam.height)
    tri, _, depth, *_ = _raster(frame, tile, _margin(frame, tile), (0.5, 0.5))
    return tri, depth, _face_normals(frame, tri[tri >= 0])


def _materials(frame: Frame, tri, bary, p, n, geo, v, sx, sy,
               shifts=True) -> material.SurfaceParams:
    """The talk's parameters at the points on triangles ``tri`` (N,): constants from the
    tables, programs evaluated per material over its points. The normal is the shading
    normal ``n`` unless a program changes it."""
    mid = frame.material[tri]
    t = frame.tables
    mats = frame.scene.materials or [Material()]
    varying = np.flatnonzero(t["varying"])
    if len(varying) and len(mid) and (mid == mid[0]).all() and t["varying"][mid[0]]:
        # one textured material over the whole block: its program alone, nothing gathered
        s = material.evaluate(mats[mid[0]].program,
                              _points(frame, tri, bary, p, n, geo, v, sx, sy, shifts))
        return s if s.normal is not None else dataclasses.replace(s, normal=n)
    albedo, rf0 = t["albedo"][mid], t["rf0"][mid]
    emission, gloss, alpha = t["emission"][mid], t["gloss"][mid, 0], t["alpha"][mid, 0]
    normal = n
    occlusion = t["occlusion"][mid, 0] if (t["occlusion"] < 1.0).any() else None
    for m in varying:
        sel = np.flatnonzero(mid == m)
        if not len(sel):
            continue
        rows = [lambda a=a, sel=sel: a[sel] for a in (p, n, geo, v, sx, sy)]
        pts = _points(frame, tri[sel], bary[sel], *rows, shifts)
        s = material.evaluate(mats[m].program, pts)
        albedo[sel], rf0[sel], emission[sel] = s.albedo, s.rf0, s.emission
        gloss[sel], alpha[sel] = s.gloss, s.alpha
        if s.normal is not None:
            normal = normal.copy() if normal is n else normal
            normal[sel] = s.normal
        if s.occlusion is not None:
            occlusion = np.ones(len(tri), np.float32) if occlusion is None else occlusion
            occlusion[sel] = s.occlusion
    return material.SurfaceParams(albedo, rf0, gloss, emission, alpha, normal, occlusion)


def _margin(frame: Frame, tile):
    """The tile grown by the filter's reach (samples drawn from the pixel filter land up to its
    width beyond their pixel, so triangles next to the tile must not be rejected): the margin
    m, pixels, ``tile_clip`` of the grown tile with the culling flags of its triangles, and the
    raster's ``keep`` dict (None unless the frame keeps its tiles: ``Frame.tiles``)."""
    cam = frame.scene.camera
    x0, y0, x1, y1 = tile
    m = int(np.ceil(frame.scene.settings.filter_width))
    key = (tuple(tile), m)
    if frame.tiles is not None and key in frame.tiles:
        return frame.tiles[key]
    clip, index = tile_clip(frame.clip, cam.width, cam.height, (x0 - m, y0 - m, x1 + m, y1 + m))
    cull = None if frame.cull is None else frame.cull[index]
    margin = (m, clip, index, cull, None if frame.tiles is None else {})
    if frame.tiles is not None:
        frame.tiles[key] = margin
    return margin


def _draw(cam, clip, width: int, height: int, cull, offsets, keep=None, keys: bool = False,
          behind=None) -> list[raster.Fragments]:
    """The camera ``cam``'s clip coordinates rasterized at each sample offset of ``offsets``
    (S, 2): for a perspective camera, when the raster's ``keys`` are not wanted nor the layer
    ``behind`` them (depth peeling), by ``raster.nearest`` (no set-up), else by
    ``raster.rasterize`` sample by sample (its set-up in ``keep``, or kept for the last
    input)."""
    proj = np.asarray(cam.projection, np.float64)
    plane = None if cam.orthographic else (proj[2, 2], proj[2, 3])
    if plane is not None and not keys and behind is None and isinstance(clip, np.ndarray):
        return raster.nearest(clip, width, height, cull=cull, sample_offsets=offsets,
                              depth_plane=plane)
    return [raster.rasterize(clip, width, height, cull=cull, sample_offset=tuple(offset),
                             behind=behind, keep=keep, depth_plane=plane)
            for offset in offsets]


def _raster(frame: Frame, tile, margin, offset, behind=None, frags=None):
    """One sample position over one tile (``margin``: ``_margin`` of the tile): (tri, bary,
    depth) per pixel, flattened, the sample's window coordinates sx, sy (npx,) in the whole
    frame, and the raster's keys (``raster.rasterize``; with ``behind``, the next layer).
    ``frags``: the tile's fragments at this sample when drawn already (``_draw``)."""
    cam = frame.scene.camera
    x0, y0, x1, y1 = tile
    tw, th = x1 - x0, y1 - y0
    m, clip, index, cull, keep = margin
    if frags is None:
        frags = _draw(cam, clip, tw + 2 * m, th + 2 * m, cull, [offset], keep,
                      frame.fades.any(), behind)[0]
    inner = (slice(m, m + th), slice(m, m + tw))
    tri = np.ascontiguousarray(frags.tri[inner]).reshape(-1)
    if len(index):  # the subset's triangles -> the frame's
        tri = np.where(tri >= 0, index.take(tri, mode="clip"), -1).astype(np.int32)
    bary = frags.bary[inner].reshape(-1, 3)
    depth = frags.depth[inner].reshape(-1)
    if cam.orthographic:  # clip w is 1: the view-axis distance comes from the corners' view z
        hit = np.flatnonzero(tri >= 0)
        row = np.asarray(cam.world_to_camera, np.float64)[2]
        z = affine.linear(frame.positions[tri[hit]], row[None, :3])[..., 0] + np.float32(row[3])
        depth = depth.copy()
        depth[hit] = -np.einsum("nk,nk->n", bary[hit], z)
    rows, cols = np.divmod(np.arange(tw * th), tw)
    return tri, bary, depth, x0 + cols + offset[0], y0 + rows + offset[1], frags.keys


def _alpha(frame: Frame, tri, bary, sx, sy) -> np.ndarray:
    """(N,) the surfaces' alpha at the points on triangles ``tri``."""
    from ..kernels import shading

    m = len(tri)
    p, n, geo = (np.empty((m, 3), np.float32) for _ in range(3))
    uv = np.empty((m, 2), np.float32)
    _, d = frame.scene.camera.rays(sx, sy)
    shading.surface(np.ascontiguousarray(tri, np.int32), np.ascontiguousarray(bary, np.float32),
                    frame.positions, frame.normals, frame.uvs, -d, p, n, geo, uv)
    return _materials(frame, tri, bary, p, n, geo, -d, sx, sy).alpha


def _dither(frame: Frame, tile, margin, offset, sample: int, layer0):
    """Stochastic transparency of one sample (Blender's "Dithered" render method,
    ``raster.dither``): over the samples a pixel is covered by a fraction alpha of each
    surface. layer0: ``_raster``'s result, updated."""
    tri, bary, depth, sx, sy, keys = layer0
    x0, y0, x1, y1 = tile
    m = margin[0]
    tw = x1 - x0
    rows, cols = np.divmod(np.arange(len(tri)), tw)

    def alpha(pixels, t, b):
        return _alpha(frame, t, b, sx[pixels], sy[pixels])

    def next_layer(floor):
        t, b, d, _, _, k = _raster(frame, tile, margin, offset, behind=floor)
        return t, b, d, k

    def thresholds(pixels, layer):
        return raster.dither_thresholds(x0 + cols[pixels], y0 + rows[pixels], sample, layer)

    raster.dither((tri, bary, depth, keys), (rows + m) * (tw + 2 * m) + cols + m,
                  frame.fades, alpha, thresholds, next_layer)
    return tri, bary, depth, sx, sy


def _indirect(frame: Frame) -> bool:
    """The frame has indirect light that can reach a point: probes that send light
    (``probes.sends_light``) or lightmaps."""
    probes_ = frame.scene.probes
    return probes_ is not None and (frame.lightmaps is not None or probes.sends_light(probes_))


def _shade_points(frame: Frame, tri, bary, sx, sy, tick=None, ao_tile=None) -> np.ndarray:
    """Shade N visible points: tri (N,), bary (N, 3), window positions sx, sy (N,);
    ``tick`` (the tile's) is called with 0 between the long steps, so a stop comes soon;
    ``ao_tile``: the tile's ``_tile_ambient`` and its origin (x, y) in the frame, or None.

    returns: (N, SAMPLED_WIDTH) float32, the averaged passes side by side (columns ``SAMPLED``;
             Combined with alpha 1)
    """
    from ..kernels import shading

    scene, cam = frame.scene, frame.scene.camera
    m = len(tri)
    p, n, geo = (np.empty((m, 3), np.float32) for _ in range(3))
    uv = np.empty((m, 2), np.float32)
    _, d = cam.rays(sx, sy)
    v = -d
    # position, normals (turned towards the camera), UV
    shading.surface(np.ascontiguousarray(tri, np.int32), np.ascontiguousarray(bary, np.float32),
                    frame.positions, frame.normals, frame.uvs, v, p, n, geo, uv)
    mat = _materials(frame, tri, bary, p, n, geo, v, sx, sy)
    n = mat.normal

    diffuse = np.zeros((len(tri), 3), np.float32)
    specular = np.zeros((len(tri), 3), np.float32)
    model = scene.settings.specular_model
    for light, smap in zip(scene.lights, frame.shadow_maps[:len(scene.lights)], strict=True):
        # The geometric normal decides what faces the light (a shading normal may not).
        l_dir, irradiance, lit = shade.light_incidence(light, p, geo)
        if not lit.any():
            continue
        vis = None if smap is None else shadows.shadow_visibility(smap, p, geo, where=lit)
        shade.add_direct(n, v, l_dir, irradiance, mat.albedo, mat.rf0, mat.gloss, model,
                         diffuse, specular, visibility=vis)
    ao = np.ones(len(tri), np.float32)
    if ao_tile is not None:
        image, x0, y0 = ao_tile
        ao = image[np.clip(np.floor(sy).astype(np.int64) - y0, 0, image.shape[0] - 1),
                   np.clip(np.floor(sx).astype(np.int64) - x0, 0, image.shape[1] - 1)]
    baked = None
    if _indirect(frame):
        s = scene.settings
        sky = frame.sky
        rho = (mat.albedo @ sh.LUMINANCE_REC709.astype(np.float32))[:, None]
        if scene.probes.bounce is not None:  # what bounces off the occluders is baked
            rho = rho * (1.0 - scene.probes.bounce.weight(p))[:, None]

        def seen(k):
            """The world's light is occluded by the darker of the dome and the contact
            occlusion (both see the near surfaces: not their product), with what bounces off
            the occluders put back as for the latter (``occlusion.multi_bounce``) unless the
            bounce without probes holds it; divided by the contact occlusion's, which all
            indirect light gets."""
            pk, nk, gk = p[k], n[k], geo[k]
            vis = sky_light.upsampled(
                lambda j: sky_light.visibility(sky, scene.probes.world_sh, pk[j], nk[j], gk[j],
                                               poll=None if tick is None else lambda: tick(0.0)),
                sx[k], sy[k], pk, gk, sky_light.stride(cam.height))
            both = occlusion.multi_bounce(np.minimum(vis, ao[k]), rho[k])[:, 0]
            return both / np.maximum(occlusion.multi_bounce(ao[k], rho[k])[:, 0], 1e-3)

        baked = _lightmap_sh(frame, tri, bary)
        diff_ind, gloss_ind = probes.indirect(scene.probes, p, n, v, mat.albedo, mat.rf0,
                                              mat.gloss, s.normalization, s.prefilter, s.env_brdf,
                                              sky=None if sky is None else seen,
                                              baked=None if baked is None else baked[:2])
        if mat.occlusion is not None:  # the glTF importer's occlusion dims indirect light
            diff_ind *= mat.occlusion[:, None]
            gloss_ind *= mat.occlusion[:, None]
        if ao_tile is not None:
            bounce = occlusion.multi_bounce(ao, mat.albedo)
            if baked is not None:  # a lightmap holds its surface's occlusion already
                bounce[baked[0]] = 1.0
            diff_ind *= bounce
            if s.specular_occlusion:
                n_dot_v = np.einsum("nk,nk->n", n, v)
                gloss_ind *= occlusion.specular(ao, n_dot_v, mat.gloss)[:, None]
    else:
        diff_ind = gloss_ind = np.zeros((len(tri), 3), np.float32)
    out = np.empty((len(tri), SAMPLED_WIDTH), np.float32)
    f32 = np.ascontiguousarray
    cols = np.array([SAMPLED[name].start for name in shading.COMPOSED], np.int64)
    shading.compose(out, cols, n, p, uv, f32(frame.has_uv[tri]), diffuse, specular,
                    f32(diff_ind, np.float32), f32(gloss_ind, np.float32),
                    *(f32(a, np.float32) for a in (mat.emission, mat.albedo, mat.rf0,
                                                   mat.gloss)))
    out[:, SAMPLED["AO"]] = ao[:, None]
    lm, texels = SAMPLED["Lightmap"], SAMPLED["Lightmap Texels"]
    out[:, lm] = 0.0
    out[:, texels] = 0.0
    if baked is not None:
        k, coeffs, checker = baked
        out[k, lm] = np.einsum("nk,nkc->nc", sh.basis(n[k]) * sh.BAND_FACTORS, coeffs)
        out[k, texels] = checker
    return out


def _lightmap_sh(frame: Frame, tri, bary) -> tuple | None:
    """The lightmapped points among those on triangles ``tri`` (N,) at weights ``bary``
    (N, 3): their indices (K,), the SH (K, 9, 3) of the light their lightmap holds
    (``lightmap.as_sh``) and their texels' checker colour (K, 3) (the Lightmap Texels pass),
    or None when none is lightmapped."""
    if frame.lightmap is None:
        return None
    which = frame.lightmap[tri]
    k = np.flatnonzero(which >= 0)
    if not k.size:
        return None
    uv = np.einsum("nk,nkc->nc", bary[k], frame.lightmap_uvs[tri[k]])
    out = np.zeros((k.size, 9, 3), np.float32)
    checker = np.zeros((k.size, 3), np.float32)
    for m in np.unique(which[k]):
        sel = np.flatnonzero(which[k] == m)
        image = frame.lightmaps[m].image
        out[sel] = lightmap_light.as_sh(lightmap_light.sample(image, uv[sel]))
        h, w = image.shape[:2]
        cell = (np.floor(uv[sel, 0] * w) + np.floor((1.0 - uv[sel, 1]) * h)) % 2
        hue = np.asarray(LIGHTMAP_HUES[m % len(LIGHTMAP_HUES)], np.float32)
        checker[sel] = hue * (0.45 + 0.55 * cell)[:, None].astype(np.float32)
    return k, out, checker


# The Lightmap Texels pass: one hue per lightmap, its texels a checker of two shades of it
LIGHTMAP_HUES = ((0.9, 0.35, 0.3), (0.3, 0.65, 0.9), (0.4, 0.85, 0.35), (0.95, 0.8, 0.3),
                 (0.75, 0.45, 0.9), (0.3, 0.85, 0.8))


def _tile_ambient(frame: Frame, tile) -> np.ndarray:
    """(h, w) float32 ambient occlusion of a tile's pixels (``occlusion.ambient``), from the
    surfaces drawn at the pixel centres of the tile grown by ``occlusion.REACH`` pixels."""
    cam, s = frame.scene.camera, frame.scene.settings
    x0, y0, x1, y1 = tile
    m, b = occlusion.REACH, occlusion.BLUR
    gw, gh = x1 - x0 + 2 * m, y1 - y0 + 2 * m
    clip, index = tile_clip(frame.clip, cam.width, cam.height, (x0 - m, y0 - m, x1 + m, y1 + m))
    cull = None if frame.cull is None else frame.cull[index]
    proj = np.asarray(cam.projection, np.float64)
    frags = _draw(cam, clip, gw, gh, cull, [(0.5, 0.5)])[0]
    tri = frags.tri
    if len(index):
        tri = np.where(tri >= 0, index.take(np.maximum(tri, 0), mode="clip"), -1)
    if frame.holdout.any():  # holdout objects are holes, not occluders
        tri = np.where((tri >= 0) & frame.holdout[np.maximum(tri, 0)], -1, tri)
    w2c = np.asarray(cam.world_to_camera, np.float64)
    hit = tri >= 0
    depth = np.full((gh, gw), np.nan, np.float32)
    if cam.orthographic:
        world = np.einsum("nk,nkc->nc", frags.bary[hit], frame.positions[tri[hit]])
        depth[hit] = affine.transform(world, w2c)[:, 2]
    else:
        depth[hit] = -frags.depth[hit]
    # the view-space x, y of a buffer pixel from its depth z (the projection undone)
    ux, vx = 2.0 / cam.width, 2.0 * (x0 - m + 0.5) / cam.width - 1.0
    uy, vy = -2.0 / cam.height, 1.0 - 2.0 * (y0 - m + 0.5) / cam.height
    p32, p33 = proj[3, 2], proj[3, 3]
    rec = np.array([p32 * ux / proj[0, 0], (p32 * vx - proj[0, 2]) / proj[0, 0],
                    p33 * ux / proj[0, 0], (p33 * vx - proj[0, 3]) / proj[0, 0],
                    p32 * uy / proj[1, 1], (p32 * vy - proj[1, 2]) / proj[1, 1],
                    p33 * uy / proj[1, 1], (p33 * vy - proj[1, 3]) / proj[1, 1]])
    # the normals of the tile grown by the filter's reach, in view space
    inner = (slice(m - b, gh - m + b), slice(m - b, gw - m + b))
    on = hit[inner]
    n = affine.linear(np.einsum("nk,nkc->nc", frags.bary[inner][on],
                                frame.normals[tri[inner][on]]), w2c[:3, :3])
    normals = np.zeros((*on.shape, 3), np.float32)
    normals[on] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    scale = 0.5 * proj[1, 1] * cam.height  # pixels per metre (at depth 1: perspective)
    return occlusion.ambient(depth, normals, rec, (x0 - m, y0 - m), s.ao_distance, scale,
                             cam.orthographic)


SHADE_BLOCK = 1 << 16  # points shaded at once (bounds the shading's temporaries)
SAMPLE_BATCH = 4  # samples of a tile drawn at once (``raster.nearest``; bounds its buffers)


def _render_tile(frame: Frame, tile, offsets, tick, first_sample: int = 0):
    """All samples of one tile, averaged: the passes of ``SAMPLED`` side by side
    (npx, SAMPLED_WIDTH), Depth (npx,) and IndexMA (npx,), float32.

    Shading is done once per pixel and triangle, as in multisample anti-aliasing: every
    sample position is rasterized, but a sample that sees the same triangle as the pixel's
    first sample reuses that sample's shading (weighted by the number of samples that do);
    only samples that see another triangle (edges) are shaded on their own. The points of all
    samples are shaded together, in blocks of ``SHADE_BLOCK``.
    ``settings.shade_every_sample`` shades every sample instead.
    """
    from ..kernels import shading

    scene = frame.scene
    x0, y0, x1, y1 = tile
    npx = (x1 - x0) * (y1 - y0)
    acc = np.zeros((npx, SAMPLED_WIDTH), np.float32)
    central = int(np.argmin(np.abs(np.asarray(offsets) - 0.5).sum(-1)))  # Depth and IndexMA
    depth_acc = index_acc = None
    first_tri = None
    reuse_count = np.zeros(npx, np.float32)  # samples that reuse the first sample's shading
    miss_count = np.zeros(npx, np.float32)  # samples that see a constant-colour background
    constant_world = scene.world.texture is None
    rgba = SAMPLED["Combined"]
    points = []  # per sample: (tri, bary, sx, sy, pixel) of the points it shades
    margin = _margin(frame, tile)
    m, clip, _, cull, keep = margin
    drawn = []
    for k, offset in enumerate(offsets):
        tick()
        if k % SAMPLE_BATCH == 0:  # the next samples' fragments, drawn together
            drawn = _draw(scene.camera, clip, x1 - x0 + 2 * m, y1 - y0 + 2 * m, cull,
                          offsets[k:k + SAMPLE_BATCH], keep, frame.fades.any())
        layer0 = _raster(frame, tile, margin, offset, frags=drawn[k % SAMPLE_BATCH])
        if frame.fades.any():
            tri, bary, depth, sx, sy = _dither(frame, tile, margin, offset, first_sample + k,
                                               layer0)
        else:
            tri, bary, depth, sx, sy, _ = layer0
        covered = tri >= 0
        hit = covered.copy()
        if frame.holdout.any():  # holdout objects: nothing at all (alpha 0), hiding what is behind
            hit[covered] = ~frame.holdout[tri[covered]]
        if not scene.settings.film_transparent:  # transparent film: background alpha 0, RGB 0
            if constant_world:
                miss_count += ~covered
            elif not covered.all():
                miss = ~covered
                acc[miss, rgba.start:rgba.start + 3] += _background(scene, sx[miss], sy[miss])
                acc[miss, rgba.start + 3] += np.float32(scene.world.background_alpha)
        if first_tri is None:
            first_tri, fresh = tri, hit
            reuse_count += hit
        elif scene.settings.shade_every_sample:
            fresh = hit
        else:
            reuse = hit & (tri == first_tri)
            reuse_count += reuse
            fresh = hit & ~reuse
        pixel = np.flatnonzero(fresh)
        points.append((tri[pixel], bary[pixel], sx[pixel], sy[pixel], pixel))
        if k == central:
            depth_acc = np.where(hit, depth, np.float32(EMPTY_DEPTH))
            index_acc = np.zeros(npx, np.float32)
            index_acc[hit] = frame.tables["pass_index"][frame.material[tri[hit]]]
    # the later samples' own points first, then the first sample's, weighted by its reuses
    points = points[1:] + points[:1]
    tri, bary, sx, sy, pixel = (np.concatenate(a) for a in zip(*points, strict=True))
    weight = np.ones(len(pixel), np.float32)
    first = len(pixel) - len(points[-1][4])
    weight[first:] = reuse_count[pixel[first:]]
    count = len(pixel)
    if not count:
        tick()
    s = scene.settings
    ao_tile = ((_tile_ambient(frame, tile), x0, y0) if count and scene.probes is not None
               and s.ambient_occlusion and s.ao_distance > 0.0
               and (s.ao_pass or _indirect(frame)) else None)
    for lo in range(0, count, SHADE_BLOCK):
        block = slice(lo, lo + SHADE_BLOCK)
        tick(len(pixel[block]) / count)
        shading.splat(acc, pixel[block], weight[block],
                      _shade_points(frame, tri[block], bary[block], sx[block], sy[block],
                                    tick, ao_tile))
    if constant_world and miss_count.any():
        color = np.append(np.asarray(scene.world.color, np.float32), np.float32(1.0))
        acc[:, rgba] += miss_count[:, None] * color
    acc *= np.float32(1.0 / len(offsets))
    return acc, depth_acc, index_acc


def _tile_results(scene: Scene, progress, should_stop, warn, frame, cameras=None, offsets=None,
                  first_sample=0):
    """``render_tiles``'s work: yields (view, tile, ``_render_tile``'s arrays) in order, the
    views being ``frame`` through each of ``cameras`` (all the same size), or through its own
    camera when ``cameras`` is None. Every view's tiles share the render's threads; a view's
    projection is done once, on the thread of its first tile. ``offsets`` (S, 2) replaces the
    settings' sample positions (a progressive render takes them a few at a time, the first
    being sample ``first_sample`` of the whole)."""
    if frame is None:
        frame = prepare(scene, warn, should_stop)
    if offsets is None:
        offsets = sample_offsets(max(1, int(scene.settings.samples)),
                                 scene.settings.filter_width)
    views = [frame] if cameras is None else [None] * len(cameras)
    view_locks = [threading.Lock() for _ in views]
    todo = [(k, tile) for k in range(len(views)) for tile in tiles(scene)]
    total = len(todo) * (len(offsets) + 1)  # per tile: its samples' rasters, then the shading
    done = [0.0, 0.0]  # work finished over all tiles; that amount when progress was last called
    lock, stop, caller = threading.Lock(), threading.Event(), threading.get_ident()

    def poll() -> None:  # on the calling thread only: the host's callbacks are not thread-safe
        if should_stop is not None and should_stop():
            raise Cancelled()
        if progress is not None and done[0] != done[1]:
            done[1] = done[0]
            progress(done[1] / total)

    def tick(amount: float = 1.0) -> None:  # on the tile's thread, before each step of a tile
        if threading.get_ident() == caller:
            poll()
        elif stop.is_set():
            raise Cancelled()
        with lock:
            done[0] += amount

    def view(k: int) -> Frame:
        with view_locks[k]:
            if views[k] is None:
                views[k] = with_camera(frame, cameras[k], once=len(tiles(scene)) == 1)
            return views[k]

    def job(k, tile):
        return lambda: _render_tile(view(k), tile, offsets, tick, first_sample)

    results = _ordered([job(k, tile) for k, tile in todo], thread_count(scene.settings), poll,
                       stop)
    try:
        for (k, tile), arrays in zip(todo, results, strict=True):
            yield k, tile, arrays
    finally:
        results.close()  # a caller that stops early stops the threads too
    if progress is not None:
        progress(1.0)


def render_tiles(
    scene: Scene,
    progress: Callable[[float], None] | None = None,
    should_stop: Callable[[], bool] | None = None,
    warn: Callable[[str], None] | None = None,
    frame: Frame | None = None,
) -> Iterator[tuple[tuple[int, int, int, int], dict[str, np.ndarray]]]:
    """Render tile by tile.

    progress:    called with the finished fraction in [0, 1]
    should_stop: polled before every sample of every tile; True raises ``Cancelled``
    warn:        called once per distinct problem (skipped triangles)
    frame:       ``prepare(scene, ...)`` done already (its shadow maps reused), or None
    yields:      ((x0, y0, x1, y1), {pass name: (y1 - y0, x1 - x0, C) float32}), row 0 at the
                 top, for every tile of ``tiles(scene)``
    """
    for _, (x0, y0, x1, y1), (acc, depth, index) in _tile_results(scene, progress, should_stop,
                                                                   warn, frame):
        shape = (y1 - y0, x1 - x0)
        image = acc.reshape(*shape, SAMPLED_WIDTH)
        out = {name: image[..., SAMPLED[name]] for name in SAMPLED}
        out["Depth"], out["IndexMA"] = depth.reshape(*shape, 1), index.reshape(*shape, 1)
        yield (x0, y0, x1, y1), out


def render_frame(scene: Scene, progress=None, should_stop=None, warn=None, frame=None,
                 offsets=None, first_sample: int = 0) -> dict:
    """Render the whole frame: {pass name: (H, W, C) float32}, row 0 at the top; the averaged
    passes are views of one (H, W, SAMPLED_WIDTH) film.

    Outside the render border the passes are 0 (Depth: 1e10). Arguments as ``render_tiles``;
    ``offsets`` (S, 2): these sample positions (``sample_offsets``) instead of the settings',
    the first being sample number ``first_sample`` of a progressive render (its dither).
    """
    return render_views(scene, None, progress, should_stop, warn, frame, offsets,
                        first_sample)[0]


def render_views(scene: Scene, cameras, progress=None, should_stop=None, warn=None,
                 frame=None, offsets=None, first_sample: int = 0) -> list[dict]:
    """``render_frame`` of the scene through each of ``cameras`` (a list of ``Camera`` of the
    scene camera's size, or None for the scene camera alone), their tiles rendered side by
    side on the render's threads (probe captures: six small faces at once), the scene prepared
    once: [{pass name: (H, W, C) float32}] in camera order. Arguments as ``render_frame``."""
    cam = scene.camera
    count = 1 if cameras is None else len(cameras)
    film = np.zeros((count, cam.height, cam.width, SAMPLED_WIDTH), np.float32)
    depth = np.full((count, cam.height, cam.width, 1), EMPTY_DEPTH, np.float32)
    index = np.zeros((count, cam.height, cam.width, 1), np.float32)
    for k, (x0, y0, x1, y1), (acc, d, i) in _tile_results(scene, progress, should_stop, warn,
                                                          frame, cameras, offsets,
                                                          first_sample):
        shape = (y1 - y0, x1 - x0)
        film[k, y0:y1, x0:x1] = acc.reshape(*shape, SAMPLED_WIDTH)
        depth[k, y0:y1, x0:x1, 0], index[k, y0:y1, x0:x1, 0] = d.reshape(shape), i.reshape(shape)
    out = []
    for k in range(count):
        passes = {name: film[k, ..., SAMPLED[name]] for name in SAMPLED}
        passes["Depth"], passes["IndexMA"] = depth[k], index[k]
        out.append(passes)
    return out
