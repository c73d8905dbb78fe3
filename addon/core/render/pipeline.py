"""One frame: the short script that orders the stages, tile by tile.

prepare (``buffers``) -> shadow maps (``shadow_maps``) -> per tile: what each sample sees
(``visibility``), contact occlusion (``contact_occlusion``), materials (``surfaces``), shading
(``shading``) -> passes (``passes``). Every stage takes the ``RenderJob`` (scene, settings,
threads, progress, stop, warnings) or plain arrays and dataclasses, so another backend can
implement a stage and be tested against this one stage by stage.

- Deferred: only visible points are shaded, once per pixel and triangle (see ``render_tile``).
- Threads: tiles (and the lights' shadow maps) are rendered on the job's threads at once; the
  compiled kernels (``kernels``) and NumPy's loops release Python's lock, so they run on
  separate cores.

Passes: the table of ``passes.py``. Depth and IndexMA come from one sample, the one nearest the
pixel centre, as Cycles writes them from one sample; the others are averaged over every sample,
the background counting as 0 in all but Combined, as Cycles accumulates them.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Iterator

import numpy as np

from . import cryptomatte, depth_of_field, motion_blur, projection, transparency
from .buffers import Frame, prepare_buffers, with_camera
from .contact_occlusion import tile_ambient
from .job import Cancelled, RenderJob
from .passes import (
    EMPTY_DEPTH,
    SAMPLED,
    Film,
    extras,
    film_width,
    group_columns,
    tile_passes,
)
from .shading import background_radiance, has_indirect, shade_points
from .shadow_filter import pixel_seeds
from .shadow_maps import (
    build_shadow_maps,
    drawn_on_gpu,
    moving_casters,
    shadow_map_count,
    shutter_maps,
)
from .visibility import (
    blend_sample,
    dither_sample,
    draw_samples,
    reprojected,
    sample_offsets,
    sample_raster,
    tile_margin,
    tile_matrix,
    tiles,
)

SHADE_BLOCK = 1 << 16  # points shaded at once (bounds the shading's temporaries)
SAMPLE_BATCH = 4  # samples of a tile drawn at once (``raster.nearest``; bounds its buffers)


def render_tile(frame: Frame, tile, offsets, tick, first_sample: int = 0):
    """All samples of one tile, averaged: the passes of ``SAMPLED`` and of the light groups
    side by side (npx, ``film_width``), Depth (npx,) and IndexMA (npx,), float32, and the
    Cryptomatte passes the settings ask for, {name: (npx, 4) float32} (``cryptomatte.ranks``
    of what each sample sees).

    The shadow filter turns its taps by the pixel, triangle and sample of each point shaded
    (``shadow_filter.pixel_seeds``). Shading is done once per pixel and triangle, as in
    multisample anti-aliasing: every
    sample position is rasterized, but a sample that sees the same triangle as the pixel's
    first sample reuses that sample's shading (weighted by the number of samples that do);
    only samples that see another triangle (edges) are shaded on their own. The points of all
    samples are shaded together, in blocks of ``SHADE_BLOCK``.
    ``settings.shade_every_sample`` shades every sample instead. With motion blur a sample is
    shaded in the frame of its share of the shutter (``Frame.at_times``): the reuse is then
    per share where shadows move, and none for moving triangles or under a moving camera.
    A sample that sees a blended
    surface shades each layer of its stack (``visibility.blend_sample``), weighted by its
    share. Last, the number of pixel samples whose blended stack was cut
    (``transparency.BLEND_LAYERS``).
    """
    from ..kernels import shading

    scene = frame.scene
    x0, y0, x1, y1 = tile
    npx = (x1 - x0) * (y1 - y0)
    groups = scene.settings.light_groups
    acc = np.zeros((npx, film_width(extras(scene.settings))), np.float32)
    world_group = (group_columns(groups.index(scene.world.group))
                   if scene.world.group in groups else None)
    central = int(np.argmin(np.abs(np.asarray(offsets) - 0.5).sum(-1)))  # Depth and IndexMA
    depth_acc = index_acc = None
    empty = np.zeros(npx, np.float32)  # samples that see no surface (the Shadow Catcher's 1)
    miss_count = np.zeros(npx, np.float32)  # samples that see a constant-colour background
    constant_world = scene.world.texture is None
    rgba = SAMPLED["Combined"]
    points = []  # per sample: (tri, bary, sx, sy, pixel, sample, share) of the points it shades
    layered, layered_weight = [], []  # the same of blended stacks' surfaces, and their shares
    deep = 0
    seen_by = []  # per sample, with Cryptomatte: the triangle it sees, -1 none
    margin = tile_margin(frame, tile)
    m, clip, _, cull, keep = margin
    cam = scene.camera
    lens = cam.aperture is not None and not cam.orthographic
    moving = frame.motion_reach > 0
    alone = lens or moving  # each sample its lens point or time: its own view, drawn alone
    if alone:
        numbers = first_sample + np.arange(len(offsets))
        lens_at = depth_of_field.lens_points(cam.aperture, numbers) if lens else None
        # the triangles are gathered over the lens's and the shutter's reach (m), drawn over
        # the filter's (mf)
        mf = m - frame.lens_reach - frame.motion_reach
        from_tile = np.linalg.inv(tile_matrix(cam.width, cam.height,
                                              (x0 - m, y0 - m, x1 + m, y1 + m)))
        to_tile = tile_matrix(cam.width, cam.height, (x0 - mf, y0 - mf, x1 + mf, y1 + mf))
    if moving:
        times = motion_blur.shutter_times(numbers, scene.settings.shutter_curve)
        if scene.settings.rolling_shutter is not None:  # the tile is a band of rows
            times = motion_blur.rolling(times, (y0 + y1 - 1) / 2.0, cam.height,
                                        scene.settings.rolling_shutter)
        corners = frame.positions[margin[2]]
        rows = np.full(len(corners), -1, np.int32) if frame.motion_row is None else \
            frame.motion_row[margin[2]]
        hidden = None if frame.seen is None else ~frame.seen[margin[2]]
    # a sample is shaded in the frame of its share of the shutter; a pixel's samples that see
    # the same still triangle through a still camera reuse a shading (one per share where the
    # shadows move); moving triangles, or all under a moving camera, are shaded per sample
    timed = moving and frame.at_times is not None
    parts = len(frame.at_times) if timed else 1
    share = (motion_blur.shares(times, parts) if timed else np.zeros(len(offsets), np.int64))
    groups = parts if frame.shadows_move else 1
    per_sample = scene.settings.shade_every_sample or (timed and cam.motion is not None)
    still = frame.motion_row < 0 if timed and frame.motion_row is not None else None
    first_tri = [None] * groups
    reuse_count = np.zeros((groups, npx), np.float32)  # samples reusing a group's first shading
    leaders = [None] * groups  # the sample whose shading a group's later samples reuse
    drawn = []

    def background(pixels, weight, sx, sy, shift) -> None:  # the world seen behind ``pixels``
        if scene.settings.film_transparent:  # transparent film: background alpha 0, RGB 0
            return
        if constant_world:
            miss_count[pixels] += weight
            return
        seen = background_radiance(scene, sx[pixels] - shift[0], sy[pixels] - shift[1])
        seen *= weight[:, None]
        acc[pixels, rgba.start:rgba.start + 3] += seen
        acc[pixels, rgba.start + 3] += weight * np.float32(scene.world.background_alpha)
        if world_group is not None:
            acc[pixels, world_group] += seen

    for k, offset in enumerate(offsets):
        tick()
        sample_margin, shift = margin, (0.0, 0.0)
        if alone:
            view = (depth_of_field.clip_transform(cam, lens_at[k]) if lens else np.eye(4))
            if moving:
                seen_clip = _moved_clip(frame, corners, rows, hidden, times[k],
                                        to_tile @ view)
            else:
                seen_clip = reprojected(clip, to_tile @ view @ from_tile)
            sample_margin = (mf, seen_clip, margin[2], cull, None)
            drawn = draw_samples(cam, seen_clip, x1 - x0 + 2 * mf, y1 - y0 + 2 * mf, cull,
                                 offsets[k:k + 1], None, frame.fades.any())
            if lens:
                shift = depth_of_field.background_shift(cam, lens_at[k])
        elif k % SAMPLE_BATCH == 0:  # the next samples' fragments, drawn together
            drawn = draw_samples(cam, clip, x1 - x0 + 2 * m, y1 - y0 + 2 * m, cull,
                          offsets[k:k + SAMPLE_BATCH], keep, frame.fades.any())
        layer0 = sample_raster(frame, tile, sample_margin, offset,
                               frags=drawn[0 if alone else k % SAMPLE_BATCH])
        if frame.fades.any():
            tri, bary, depth, sx, sy = dither_sample(frame, tile, sample_margin, offset,
                                                     first_sample + k, layer0)
        else:
            tri, bary, depth, sx, sy, _ = layer0
        covered = tri >= 0
        hit = covered.copy()
        if frame.holdout.any():  # holdout objects: nothing at all (alpha 0), hiding what is behind
            hit[covered] = ~frame.holdout[tri[covered]]
        empty += ~hit
        if not covered.all():
            miss = np.flatnonzero(~covered)
            background(miss, np.ones(len(miss), np.float32), sx, sy, shift)
        if frame.crypto:
            seen_by.append(np.where(hit, tri, -1))
        solid = hit  # pixels whose surface is shaded as the sample's own (not a blended stack)
        if frame.blends is not None:
            front = hit & frame.blends[np.maximum(tri, 0)]
            if front.any():
                solid = hit & ~front
                (at, t, b, w), (bg, bg_weight), cut = blend_sample(
                    frame, tile, sample_margin, offset, first_sample + k,
                    (tri, bary, depth, sx, sy, layer0[5]), np.flatnonzero(front))
                background(bg, bg_weight, sx, sy, shift)
                empty[bg] += bg_weight  # (the share that sees no surface)
                if frame.holdout.any():  # a holdout behind the stack: nothing there
                    shown = ~frame.holdout[t]
                    np.add.at(empty, at[~shown], w[~shown])
                    at, t, b, w = at[shown], t[shown], b[shown], w[shown]
                layered.append((t, b, sx[at], sy[at], at,
                                np.full(len(at), first_sample + k, np.uint32),
                                np.full(len(at), share[k], np.int64)))
                layered_weight.append(w)
                deep += cut
        g = int(share[k]) if groups > 1 else 0
        if first_tri[g] is None:
            first_tri[g], fresh, leaders[g] = tri, solid, k
            reuse_count[g] += solid
        elif per_sample:
            fresh = solid
        else:
            reuse = solid & (tri == first_tri[g])
            if still is not None:
                reuse &= still[np.maximum(tri, 0)]
            reuse_count[g] += reuse
            fresh = solid & ~reuse
        pixel = np.flatnonzero(fresh)
        points.append((tri[pixel], bary[pixel], sx[pixel], sy[pixel], pixel,
                       np.full(len(pixel), first_sample + k, np.uint32),
                       np.full(len(pixel), share[k], np.int64)))
        if k == central:
            depth_acc = np.where(hit, depth, np.float32(EMPTY_DEPTH))
            index_acc = np.zeros(npx, np.float32)
            index_acc[hit] = frame.tables["pass_index"][frame.material[tri[hit]]]
    # the other samples' own points first, the blended stacks' next, then the groups' first
    # samples', weighted by their reuses
    lead = [k for k in leaders if k is not None]
    others = [p for k, p in enumerate(points) if k not in lead]
    weight = [np.ones(len(p[4]), np.float32) for p in others] + layered_weight + [
        reuse_count[g][points[k][4]] for g, k in enumerate(leaders) if k is not None]
    points = others + layered + [points[k] for k in leaders if k is not None]
    tri, bary, sx, sy, pixel, sample, share = (np.concatenate(a)
                                               for a in zip(*points, strict=True))
    width = x1 - x0
    seeds = pixel_seeds(x0 + pixel % width, y0 + pixel // width, tri, sample)
    weight = np.concatenate(weight).astype(np.float32)
    count = len(pixel)
    if not count:
        tick()
    s = scene.settings
    ao_tile = ((tile_ambient(frame, tile), x0, y0) if count and scene.probes is not None
               and s.ambient_occlusion and s.ao_distance > 0.0
               and (s.ao_pass or has_indirect(frame)) else None)
    eyes = (np.array([depth_of_field.eye(cam, p) for p in lens_at], np.float32)[
        sample - np.uint32(first_sample)] if lens and count else None)
    for g in range(parts):
        mine = np.flatnonzero(share == g) if timed else None  # (None: every point)
        todo = count if mine is None else len(mine)
        shown = frame.at_times[g] if timed else frame
        seen_from = eyes
        if moving and eyes is None and todo and not cam.orthographic:
            # a moved point is seen from the camera of its time, not along the ray of the
            # pixel it moved to
            seen_from = np.broadcast_to(shown.scene.camera.position.astype(np.float32),
                                        (count, 3))
        for lo in range(0, todo, SHADE_BLOCK):
            block = slice(lo, lo + SHADE_BLOCK) if mine is None else mine[lo:lo + SHADE_BLOCK]
            tick(len(pixel[block]) / count)
            shading.splat(acc, pixel[block], weight[block],
                          shade_points(shown, tri[block], bary[block], sx[block], sy[block],
                                       tick, ao_tile, seeds[block],
                                       None if seen_from is None else seen_from[block]))
    if constant_world and miss_count.any():
        color = np.append(np.asarray(scene.world.color, np.float32), np.float32(1.0))
        acc[:, rgba] += miss_count[:, None] * color
        if world_group is not None:
            acc[:, world_group] += miss_count[:, None] * color[:3]
    acc[:, SAMPLED["Shadow Catcher"]] += empty[:, None]
    acc *= np.float32(1.0 / len(offsets))
    return acc, depth_acc, index_acc, crypto_passes(frame, seen_by), deep


def _moved_clip(frame: Frame, corners, rows, hidden, t: float, view: np.ndarray) -> np.ndarray:
    """Clip coordinates (K, 3, 4) of a tile's triangles (``corners`` (K, 3, 3) at the frame's
    own time, ``rows`` their ``Frame.motion_row``, ``hidden`` those the camera does not see)
    at shutter time ``t``, through the camera then ``view`` (the tile's and lens's clip-space
    matrix)."""
    cam = frame.scene.camera
    moved = corners
    live = rows >= 0
    if live.any():
        moved = corners.copy()
        moved[live] = motion_blur.at_time(frame.motion[:, rows[live]], t)
    clip = projection.project(moved, view @ np.asarray(cam.projection, np.float64)
                              @ motion_blur.view_at(cam, t))
    if hidden is not None:
        clip[hidden] = (0.0, 0.0, 0.0, -1.0)
    return clip


def crypto_passes(frame: Frame, seen_by: list) -> dict:
    """The Cryptomatte passes of pixels whose samples see triangles ``seen_by`` (S arrays
    (N,), -1 where none): {name: (N, 4) float32} (``cryptomatte.ranks``)."""
    out = {}
    if not frame.crypto or not seen_by:
        return out
    tri = np.stack(seen_by)
    levels = frame.scene.settings.cryptomatte_levels
    for kind, ids in frame.crypto.items():
        ranked = cryptomatte.ranks(np.where(tri >= 0, ids[np.maximum(tri, 0)] if len(ids)
                                            else cryptomatte.NONE, cryptomatte.NONE), levels)
        for k, name in enumerate(cryptomatte.passes(kind, levels)):
            out[name] = ranked[:, 4 * k:4 * k + 4]
    return out


def prepare(job: RenderJob, *, shadow_maps: list | None = None,
            fit_shadows: bool = True, on_gpu: bool = False) -> Frame:
    """The job's scene prepared: its buffers (``buffers.prepare_buffers``) and every light's
    shadow map (``shadow_maps.build_shadow_maps``).

    shadow_maps: reuse these (``shadow_map_count``, from an earlier ``prepare`` of the same
                 geometry and lights) instead of building them
    fit_shadows: fit sun cascades to this camera's view; False covers every caster with one
                 cascade (for views in every direction, e.g. a probe's six faces)
    on_gpu:      leave the maps' depths to a GPU (``shadows.ShadowMap.on_gpu``); ``cpu_maps``
                 builds them here if the GPU does not draw the frame after all
    """
    if shadow_maps is not None:
        frame = prepare_buffers(job, shadow_maps=shadow_maps)
    else:
        frame = prepare_buffers(job, shadow_maps=[None] * shadow_map_count(job.scene))
        frame.shadow_maps = build_shadow_maps(job, frame, fit_shadows=fit_shadows,
                                              on_gpu=on_gpu)
    return _over_the_shutter(job, frame, fit_shadows=fit_shadows, on_gpu=on_gpu)


def _over_the_shutter(job: RenderJob, frame: Frame, **kwargs) -> Frame:
    """``frame`` with its ``at_times`` when something moves over the shutter: per share of the
    shutter (``motion_blur.shares``) the moving triangles' corners and normals at its middle,
    the camera there and the shadow maps they cast there (``shadow_maps.shutter_maps`` of
    ``kwargs``)."""
    cam = frame.scene.camera
    if frame.motion is None and cam.motion is None:
        return frame
    rows = normals = None
    if frame.motion is not None:
        rows = np.flatnonzero(frame.motion_row >= 0)  # in the order of their motion rows
        normals = motion_blur.moved_normals(frame.positions[rows], frame.normals[rows],
                                            frame.motion)
    frame.shadows_move = moving_casters(frame)
    frames = []
    for k in range(motion_blur.SHUTTER_TIMES):
        job.poll()
        t = motion_blur.share_time(k, motion_blur.SHUTTER_TIMES)
        moved = dataclasses.replace(frame, at_times=None, scene=dataclasses.replace(
            frame.scene, camera=dataclasses.replace(
                cam, world_to_camera=motion_blur.view_at(cam, t))))
        if rows is not None:
            moved.positions = frame.positions.copy()
            moved.positions[rows] = motion_blur.at_time(frame.motion, t)
            moved.normals = frame.normals.copy()
            n = motion_blur.at_time(normals, t)
            moved.normals[rows] = n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True),
                                                 np.float32(1e-20))
        if frame.shadows_move:
            moved.shadow_maps = shutter_maps(job, frame, moved, **kwargs)
        frames.append(moved)
    frame.at_times = frames
    return frame


def cpu_maps(job: RenderJob, frame: Frame, *, fit_shadows: bool = True) -> Frame:
    """``frame`` with its shadow maps' depths built here where ``prepare`` left them to a GPU
    (the same frame when none was)."""
    if drawn_on_gpu(frame.shadow_maps):
        frame.shadow_maps = build_shadow_maps(job, frame, fit_shadows=fit_shadows)
        if frame.at_times is not None:
            frame.at_times = None
            frame = _over_the_shutter(job, frame, fit_shadows=fit_shadows)
    return frame


def _tile_results(job: RenderJob, frame: Frame | None, cameras=None, offsets=None,
                  first_sample: int = 0):
    """``render_tiles``'s work: yields (view, tile, ``render_tile``'s arrays) in order (its
    count of cut blended stacks left out: one warning at the end), the
    views being ``frame`` through each of ``cameras`` (all the same size), or through its own
    camera when ``cameras`` is None. Every view's tiles share the job's threads; a view's
    projection is done once, on the thread of its first tile. ``offsets`` (S, 2) replaces the
    settings' sample positions (a progressive render takes them a few at a time, the first
    being sample ``first_sample`` of the whole)."""
    scene, progress = job.scene, job.progress
    if frame is None:
        frame = prepare(job)
    if offsets is None:
        offsets = sample_offsets(max(1, int(scene.settings.samples)),
                                 scene.settings.filter_width)
    views = [frame] if cameras is None else [None] * len(cameras)
    view_locks = [threading.Lock() for _ in views]
    todo = [(k, tile) for k in range(len(views)) for tile in frame_tiles(frame)]
    total = len(todo) * (len(offsets) + 1)  # per tile: its samples' rasters, then the shading
    done = [0.0, 0.0]  # work finished over all tiles; that amount when progress was last called
    lock, stop, caller = threading.Lock(), threading.Event(), threading.get_ident()

    def poll() -> None:  # on the calling thread only: the host's callbacks are not thread-safe
        job.poll()
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
                views[k] = with_camera(frame, cameras[k], once=len(todo) == len(views))
            return views[k]

    def work(k, tile):
        return lambda: render_tile(view(k), tile, offsets, tick, first_sample)

    results = job.ordered([work(k, tile) for k, tile in todo], stop, poll)
    deep = 0
    try:
        for (k, tile), arrays in zip(todo, results, strict=True):
            deep += arrays[-1]
            yield k, tile, arrays[:-1]
    finally:
        results.close()  # a caller that stops early stops the threads too
    if deep:
        job.warn(transparency.cut_warning(deep))
    if progress is not None:
        progress(1.0)


def frame_tiles(frame: Frame) -> list[tuple[int, int, int, int]]:
    """The tiles ``frame`` is rendered in (``visibility.tiles``): through a rolling shutter
    bands of rows that share a time (``motion_blur.band_rows``) when something moves."""
    settings = frame.scene.settings
    rows = (motion_blur.band_rows(frame.motion_reach, frame.scene.camera.height,
                                  settings.rolling_shutter)
            if settings.rolling_shutter is not None and frame.motion_reach else 0)
    return tiles(frame.scene, rows)


def render_tiles(job: RenderJob, *, frame: Frame | None = None
                 ) -> Iterator[tuple[tuple[int, int, int, int], dict[str, np.ndarray]]]:
    """Render the job's scene tile by tile.

    frame:  ``prepare(job)`` done already (its shadow maps reused), or None
    yields: ((x0, y0, x1, y1), {pass name: (y1 - y0, x1 - x0, C) float32}), row 0 at the top,
            for every tile of ``frame_tiles``
    """
    for _, tile, arrays in _tile_results(job, frame):
        yield tile, tile_passes(tile, *arrays, extra=extras(job.scene.settings))


def render_frame(job: RenderJob, *, frame: Frame | None = None, offsets=None,
                 first_sample: int = 0) -> dict:
    """Render the whole frame: {pass name: (H, W, C) float32}, row 0 at the top; the averaged
    passes are views of one (H, W, SAMPLED_WIDTH) film.

    Outside the render border the passes are 0 (Depth: 1e10). ``frame`` as ``render_tiles``;
    ``offsets`` (S, 2): these sample positions (``sample_offsets``) instead of the settings',
    the first being sample number ``first_sample`` of a progressive render (its dither).
    """
    return render_views(job, None, frame=frame, offsets=offsets, first_sample=first_sample)[0]


def render_views(job: RenderJob, cameras, *, frame: Frame | None = None, offsets=None,
                 first_sample: int = 0) -> list[dict]:
    """``render_frame`` of the job's scene through each of ``cameras`` (a list of ``Camera`` of
    the scene camera's size, or None for the scene camera alone), their tiles rendered side by
    side on the job's threads (probe captures: six small faces at once), the scene prepared
    once: [{pass name: (H, W, C) float32}] in camera order. Arguments as ``render_frame``."""
    cam = job.scene.camera
    film = Film(1 if cameras is None else len(cameras), cam.height, cam.width,
                extras(job.scene.settings))
    for k, tile, arrays in _tile_results(job, frame, cameras, offsets, first_sample):
        film.add(k, tile, *arrays)
    return film.passes()
