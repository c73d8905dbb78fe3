"""The shadow-map stage: every light's shadow map (``shadows``) and the world's dome of them
(``sky``), built on the job's threads; the dome's maps kept while the casters and the view stay
the same.
"""

from __future__ import annotations

import hashlib
import threading

import numpy as np

from ..scene import Scene, linking
from ..system.cache import Cache
from . import shadows
from . import sky as sky_light
from .buffers import Frame
from .job import RenderJob
from .surfaces import caster_alpha


def shadow_map_count(scene: Scene, sky: bool | None = None) -> int:
    """Shadow maps a frame of ``scene`` holds: one per light, then the sky's dome
    (``settings.sky_directions``) when ``sky`` (None: when the scene has indirect light) and
    there is geometry."""
    sky = scene.probes is not None if sky is None else sky
    dome = scene.settings.sky_directions if sky and scene.meshes else 0
    return len(scene.lights) + max(0, int(dome))


def drawn_on_gpu(maps: list) -> bool:
    """Whether any of ``maps`` leaves its depths to a GPU (``shadows.ShadowMap.on_gpu``)."""
    return any(m is not None and m.on_gpu for m in maps)


def dome_lit(scene: Scene, count: int, world_sh: np.ndarray | None = None) -> np.ndarray:
    """(count,) bool: the dome directions whose shadow maps are built, those the world sends
    light from (``sky.radiance_weights`` of ``world_sh``, by default the scene's probes'; every
    direction when neither is known)."""
    if world_sh is None and scene.probes is not None:
        world_sh = scene.probes.world_sh
    if world_sh is None:
        return np.ones(count, bool)
    return sky_light.radiance_weights(world_sh, count) > 0.0


def build_shadow_maps(job: RenderJob, frame: Frame, *, fit_shadows: bool = True,
                      sky: bool | None = None, world_sh: np.ndarray | None = None,
                      every_direction: bool = False, focus: tuple | None = None,
                      on_gpu: bool = False, kept: dict | None = None) -> list:
    """Every light's shadow map of ``frame``'s geometry (None for a light without shadows),
    then the sky's dome (``sky.dome_lights``: suns of ``settings.sky_resolution`` texels,
    fitted as the lights' are; None towards directions the world sends no light from,
    ``dome_lit``, unless ``every_direction``: for a world that may change, as a viewport's):
    ``shadow_map_count`` maps, every face and cascade rendered at once on the job's threads.

    fit_shadows: fit sun cascades to the frame's camera; False covers every caster with one
                 cascade (for views in every direction, e.g. a probe's six faces)
    focus:       without ``fit_shadows``, the world box whose shadows matter
                 (``shadows.shadow_map_jobs``)
    sky, world_sh: as ``shadow_map_count`` and ``dome_lit``
    on_gpu:      leave the depths to a GPU (``shadows.ShadowMap.on_gpu``): only the maps'
                 frames, fits and constants are computed here
    kept:        {index: map} taken as they are instead of built (``shutter_maps``; the
                 dome's all or none)
    """
    scene = frame.scene
    kept = kept or {}
    count = shadow_map_count(scene, sky)
    if not len(frame.positions):
        return [None] * count

    positions, cutout = casters(frame)
    if not len(positions):
        return [None] * count
    s = scene.settings
    view = scene.camera if fit_shadows else None
    plans = []
    for i, light in enumerate(scene.lights):
        job.poll()
        if i in kept:
            plans.append(([], lambda done, m=kept[i]: m))
            continue
        mine, own_cutout = (positions, cutout) if not light.blockers else casters(
            frame, light.blockers)  # a shadow-linked light: its blockers alone
        plans.append(shadows.shadow_map_jobs(light, mine, view, focus=focus,
                                             resolution=s.shadow_resolution, cutout=own_cutout,
                                             on_gpu=on_gpu) if len(mine) else
                     ([], lambda done: None))
    dome = count - len(scene.lights)
    lit = np.ones(dome, bool) if every_direction else dome_lit(scene, dome, world_sh)
    if len(scene.lights) in kept:
        key, cached = None, [kept[len(scene.lights) + k] for k in range(dome)]
    else:
        key = None if cutout is not None or not lit.any() else _dome_key(
            positions, view, focus, s.sky_resolution, lit, on_gpu)
        cached = _domes.get(key) if key is not None else None
    if cached is None:
        view_range = (shadows.camera_depth_range(view, positions)
                      if view is not None and lit.any() else None)  # the same for every sun
        for light, on in zip(sky_light.dome_lights(dome), lit, strict=True):
            job.poll()
            plans.append(shadows.shadow_map_jobs(
                light, positions, view, resolution=s.sky_resolution, cutout=cutout,
                max_filter=sky_light.MAX_FILTER, view_range=view_range, focus=focus,
                on_gpu=on_gpu) if on else ([], lambda done: None))
    done = iter(list(job.ordered([work for works, _ in plans for work in works],
                                 threading.Event())))
    maps = [finish([next(done) for _ in works]) for works, finish in plans]
    if cached is not None:
        return maps + cached
    if key is not None:
        _domes.put(key, maps[len(scene.lights):])
    return maps


def shutter_maps(job: RenderJob, frame: Frame, moved: Frame, **kwargs) -> list:
    """The shadow maps of ``moved`` (``frame`` at a time of the shutter, ``Frame.at_times``):
    those of ``frame`` where no moving triangle casts into them (a light none of whose
    blockers move; the dome when no caster moves), the others built anew
    (``build_shadow_maps``'s ``kwargs``)."""
    lights = frame.scene.lights
    kept = {i: m for i, m in enumerate(frame.shadow_maps[:len(lights)])
            if m is None or not moving_casters(frame, lights[i].blockers)}
    if not moving_casters(frame):
        kept.update((len(lights) + k, m) for k, m in enumerate(frame.shadow_maps[len(lights):]))
    return build_shadow_maps(job, moved, kept=kept, **kwargs)


def moving_casters(frame: Frame, blockers: int = 0) -> bool:
    """Whether a triangle that moves over the shutter casts shadows in ``frame`` (among
    those of shadow linking set ``blockers``, as ``casters``)."""
    if frame.motion_row is None:
        return False
    keep = frame.motion_row >= 0
    if frame.casts is not None:
        keep &= frame.casts
    if blockers and frame.blocks is not None:
        keep &= linking.in_set(frame.blocks, blockers)
    return bool(keep.any())


def casters(frame: Frame, blockers: int = 0) -> tuple[np.ndarray, tuple | None]:
    """The triangles that cast shadows in ``frame`` (K, 3, 3) (those of shadow linking set
    ``blockers`` alone, ``linking``), and their cutout for ``shadows.shadow_map_jobs``
    (None when none may be transparent)."""
    keep = frame.casts
    if blockers and frame.blocks is not None:
        mine = linking.in_set(frame.blocks, blockers)
        keep = mine if keep is None else keep & mine
    positions, fades, index = frame.positions, frame.fades, None
    if keep is not None:  # objects that cast no shadow are not in the maps
        index = np.flatnonzero(keep)
        positions, fades = positions[index], fades[index]
    cutout = ((fades, lambda t, b: caster_alpha(frame, t if index is None else index[t], b))
              if fades.any() else None)
    return positions, cutout


# The dome's maps of the last geometries and views (``_dome_key``), reused while they stay
_domes = Cache("dome shadow maps", kept=2)


def _dome_key(positions: np.ndarray, view, focus, resolution: int, lit: np.ndarray,
              on_gpu: bool) -> tuple:
    """What the dome's maps depend on: the casters' triangles, the view they are fitted to
    (None: all casters, or ``focus``), their resolution, the lit directions and who draws
    their depths."""
    digest = hashlib.blake2b(np.ascontiguousarray(positions).view(np.uint8), digest_size=16)
    camera = None if view is None else (
        np.asarray(view.world_to_camera, np.float64).tobytes(),
        np.asarray(view.projection, np.float64).tobytes(), view.width, view.height)
    where = None if focus is None else np.asarray(focus, np.float64).tobytes()
    return (digest.hexdigest(), camera, where, int(resolution), lit.tobytes(), on_gpu)
