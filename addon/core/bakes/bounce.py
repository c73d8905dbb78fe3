"""The ground's bounce where no volume was placed: an implicit coarse irradiance volume.

An artist's quick look-dev set (objects on a ground under an HDRI, no probes) is lit by the
world (occluded by the dome, ``sky``) and the lamps; what bounces off the ground onto the
objects' undersides came only from baked volumes, so without one they went dark (57% under
Cycles). Here a coarse grid over the scene is baked on demand, as a volume probe is
(``bake.Bake``: the engine's captures, escape and dilation), with the world's background black
in the captures: each sample holds the light that surfaces send it after one bounce, lit by the
lamps and by the world through the dome, not the world itself. The renderer adds it to the
world's light wherever the world's light reaches a point (``probes.Probes.bounce``); placed
volumes hold the bounce already and replace both.

The grid spans the objects' bounding boxes, but those of objects over ``WIDE`` times the
median object's size (a ground reaching to the horizon would spread it thin), grown by
``MARGIN`` of its size, with at most ``MAX_SAMPLES`` samples at equal spacing. It is kept
per content (``key``: geometry, materials, lights, world) for the last two scenes: a
frame of the same scene reuses it. The last ``KEPT_ON_DISK`` volumes are also kept in the
engine's cache folder (``kernels.user_cache``), each under its content and this engine's code
(``code_digest``), so the first frame of the next session reuses the bake too.

Chosen over two others (docs/probes.md): reflective dome maps miss what is nearer than a map's
texel, and a screen-space bounce misses the ground the camera does not see under an object;
one bounce from a coarse volume reaches both, at the price of a bake on the first frame. Where
it reaches, the dome's visibility is not brightened by the multi-bounce fit
(``occlusion.multi_bounce``), which stood in for this very bounce.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import os
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from .. import kernels
from ..formulas.texture import Texture
from ..lighting.probes import IrradianceVolume, sends_light
from ..render.job import Cancelled, RenderJob
from ..scene import Scene, World
from ..system import atomic
from ..system.cache import Cache
from . import bake, capture

__all__ = ["FACE_SIZE", "MAX_SAMPLES", "attach", "key", "spec"]

MAX_SAMPLES = 32  # samples of the grid
MIN_SAMPLES = 3  # along each axis: a point between two layers blends both from its surface
MARGIN = 0.15  # of the geometry's extent, around it
WIDE = 4.0  # an object this many times the median object's size is not spanned (a ground)
MIN_EXTENT = 0.5  # metres: the grid's smallest side
FACE_SIZE = 16  # texels of each capture's cube face (as a volume bake's)
FADE = 0.25  # local units outside the box over which its weight fades
FACING = 1.0  # the look-up's facing bias: samples behind a surface weigh less, none is cut
_volumes = Cache("bounce without probes", kept=2)  # key -> the baked volume
KEPT_ON_DISK = 16  # baked volumes kept in the cache folder, the most recently used


def spec(scene: Scene) -> bake.ProbeSpec | None:
    """The implicit volume of ``scene``'s geometry (``bake.ProbeSpec``), or None without any."""
    boxes = []
    for m in scene.meshes:
        p = np.asarray(m.positions, np.float64).reshape(-1, 3)
        p = p[np.isfinite(p).all(axis=1)]
        if len(p):
            boxes.append((p.min(axis=0), p.max(axis=0)))
    if not boxes:
        return None
    lo, hi = (np.array(b) for b in zip(*boxes, strict=True))
    diagonal = np.linalg.norm(hi - lo, axis=1)
    small = diagonal <= WIDE * np.median(diagonal)  # a ground, a terrain, a sky dome: not
    if small.any():
        lo, hi = lo[small], hi[small]
    lo, hi = lo.min(axis=0), hi.max(axis=0)
    size = np.maximum(hi - lo, MIN_EXTENT) * (1.0 + 2.0 * MARGIN)
    mid = (lo + hi) / 2.0
    step = (np.prod(size) / MAX_SAMPLES) ** (1.0 / 3.0)
    res = np.clip(np.round(size / step), MIN_SAMPLES, MAX_SAMPLES).astype(int)
    while np.prod(res) > MAX_SAMPLES:
        res[np.argmax(np.where(res > MIN_SAMPLES, size / res, 0.0))] -= 1
    m = np.eye(4)
    m[:3, 3] = mid
    m[[0, 1, 2], [0, 1, 2]] = size / 2.0
    return bake.ProbeSpec("Implicit bounce", "irradiance", m, influence=FADE, falloff=1.0,
                          resolution=tuple(int(r) for r in res),
                          volume=bake.VolumeSettings(facing_bias=FACING))


def _digest_value(value) -> object:
    if isinstance(value, Texture):
        return value.digest
    if isinstance(value, np.ndarray):
        return hashlib.blake2b(np.ascontiguousarray(value).tobytes(), digest_size=8).hexdigest()
    if isinstance(value, (tuple, list)):
        return [_digest_value(v) for v in value]
    return repr(value)


def _world_key(world: World) -> object:
    return _digest_value((world.color, world.texture, world.strength, world.rotation))


def key(scene: Scene) -> str:
    """A digest of what the bounce depends on: every triangle's place, normals, texture
    coordinates, attributes, material and linking sets, the materials' programs, the lights
    (their linking too), the world and the settings that change a capture."""
    h = hashlib.sha256()
    for m in scene.meshes:
        h.update(np.ascontiguousarray(m.positions, np.float32).view(np.uint8))
        h.update(np.ascontiguousarray(m.normals, np.float32).view(np.uint8))
        h.update(np.asarray(m.material, np.int32).tobytes())
        h.update(repr((m.shadow, m.volume_probes, m.light_sets, m.shadow_sets,
                       _digest_value(m.uvs),
                       _digest_value(m.world_to_object), _digest_value(m.texspace),
                       sorted((k, _digest_value(v)) for k, v in m.attributes.items()))).encode())
    for mat in scene.materials:
        h.update(repr([(op.kind, op.args, _digest_value(op.param))
                       for op in mat.program.ops]).encode())
    for light in scene.lights:
        h.update(repr(_digest_value([light.kind, light.color, light.position, light.direction,
                                     light.radius, light.spot_size, light.spot_blend,
                                     light.size, light.shadow, light.receivers,
                                     light.blockers])).encode())
    h.update(repr(_world_key(scene.world)).encode())
    s = scene.settings
    h.update(repr((s.sky_directions, s.sky_resolution, s.shadow_resolution,
                   s.specular_model, s.layered_diffuse, s.volume_extrapolation)).encode())
    return h.hexdigest()[:24]


def _bake(scene: Scene, where: bake.ProbeSpec,
          should_stop: Callable[[], bool] | None) -> IrradianceVolume:
    black = dataclasses.replace(scene, world=World(color=np.zeros(3, np.float32)))
    cap = capture.Capture(RenderJob(black, should_stop=should_stop),
                          focus=bake.capture_region([where]))
    job = bake.Bake([where], scene.world, cap.cube, bounces=1, volume_face_size=FACE_SIZE,
                    surfaces=cap.surfaces)
    for _ in job.steps():
        if should_stop is not None and should_stop():
            raise Cancelled()
    result = job.results[0]
    return where.probe(result.coeffs, None, result.validity, result.moments)


def attach(scene: Scene, should_stop: Callable[[], bool] | None = None,
           bake_missing: bool = True) -> Scene:
    """``scene`` with the implicit bounce in its probes (``Probes.bounce``) when they hold no
    volume; unchanged without probes (no indirect light), without geometry, or under a black
    world (a scene lit by its lamps alone keeps its frame time: no bake). The volume is baked
    when this content has none yet, in this session or on disk (``bake_missing``; False:
    only one this session keeps is used, as a viewport's redraws do)."""
    probes = scene.probes
    if probes is None or probes.volumes or not scene.meshes \
            or not scene.settings.implicit_bounce or not sends_light(probes):
        return scene
    where = spec(scene)
    if where is None:
        return scene
    k = key(scene)
    volume = _volumes.get(k)
    if volume is None:
        if not bake_missing:
            return scene
        volume = _load(k)
        if volume is None:
            volume = _bake(scene, where, should_stop)
            _save(k, volume)
        _volumes.put(k, volume)
    return dataclasses.replace(scene, probes=dataclasses.replace(probes, bounce=volume))


@functools.cache
def code_digest() -> str:
    """A digest of the core's Python sources and of the NumPy and numba that run them: a
    volume baked by other code is baked anew."""
    root = Path(__file__).resolve().parents[1]
    h = hashlib.sha256(f"numpy {np.__version__} numba {kernels.NUMBA_VERSION}".encode())
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def _file(k: str) -> Path:
    return kernels.user_cache("bounce") / f"{k}-{code_digest()}.npz"


def _save(k: str, volume: IrradianceVolume) -> None:
    """Keep ``volume`` on disk (written whole; the oldest beyond ``KEPT_ON_DISK`` removed). A
    folder that cannot be written only costs the next session a bake."""
    path = _file(k)
    arrays = {"local_to_world": volume.local_to_world, "resolution": volume.resolution,
              "sh": volume.sh, "params": [volume.influence, volume.normal_bias,
                                          volume.view_bias, volume.falloff,
                                          np.nan if volume.facing_bias is None
                                          else volume.facing_bias]}
    if volume.validity is not None:
        arrays["validity"] = volume.validity
    if volume.moments is not None:
        arrays["moments"] = volume.moments
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic.write_atomically(path, lambda tmp: np.savez(tmp, **arrays))
        kept = sorted(path.parent.glob("*.npz"), key=lambda p: p.stat().st_mtime, reverse=True)
        for old in kept[KEPT_ON_DISK:]:
            old.unlink(missing_ok=True)
    except OSError:
        pass


def _load(k: str) -> IrradianceVolume | None:
    """The volume kept on disk for content ``k``, or None (none, or a file that cannot be
    read: baked anew)."""
    path = _file(k)
    try:
        with np.load(path, allow_pickle=False) as data:
            influence, normal_bias, view_bias, falloff, facing = (float(v)
                                                                  for v in data["params"])
            volume = IrradianceVolume(
                "Implicit bounce", np.array(data["local_to_world"], np.float64),
                tuple(int(r) for r in data["resolution"]), np.array(data["sh"], np.float32),
                influence=influence,
                validity=np.array(data["validity"], np.float32) if "validity" in data else None,
                normal_bias=normal_bias, view_bias=view_bias,
                facing_bias=None if np.isnan(facing) else facing, falloff=falloff,
                moments=np.array(data["moments"], np.float32) if "moments" in data else None)
    except (OSError, KeyError, ValueError, TypeError, EOFError, zipfile.BadZipFile,
            zlib.error):
        return None
    if volume.sh.shape != (*volume.resolution, 9, 3) or not np.isfinite(volume.sh).all():
        return None
    with contextlib.suppress(OSError):  # the most recently used (a read-only cache: as it is)
        os.utime(path)
    return volume
