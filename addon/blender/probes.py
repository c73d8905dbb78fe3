"""Blender's light probe objects as BO2 probes: where their bakes live, loading them, baking them.

Sphere light probes are reflection probes (influence distance and falloff); Volume light probes
are irradiance volumes (their x/y/z resolution; the object's box, with the influence distance
around it); the World is the fallback of both. Each probe object's bake is one OpenEXR file,
``<bake folder>/<object name>.exr`` (``core.probe_file``); the bake folder is
``scene.bo2.bake_folder``, ``//bo2_bake/`` (next to the .blend) by default.

``bake_steps`` is the whole bake as a generator of progress fractions, so that the modal
operator runs it a step per timer tick (Esc stops it between steps) and ``bo2 bake`` runs it in
a loop. Nothing is written until every probe is done: a cancelled or failed bake leaves the
previous files untouched, and each file is replaced atomically.
"""

from __future__ import annotations

import dataclasses
import re
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

from ..core import capture, cubemap, probe_file, sh
from ..core import probes as cp
from ..core.scene import World

KINDS = {"SPHERE": "reflection", "VOLUME": "irradiance"}


class BakeError(Exception):
    """A bake that cannot start or finish; one-line message."""


def _version() -> str:
    import tomllib

    manifest = Path(__file__).resolve().parents[2] / "blender_manifest.toml"
    with open(manifest, "rb") as fh:
        return str(tomllib.load(fh)["version"])


def bake_folder(scene) -> Path:
    """Absolute bake folder of ``scene`` (``scene.bo2.bake_folder``, relative to the .blend)."""
    folder = scene.bo2.bake_folder or "//bo2_bake/"
    if folder.startswith("//") and not bpy.data.filepath:
        raise BakeError("Save the .blend file first (the bake folder is relative to it), "
                        "or set an absolute Bake Folder")
    return Path(bpy.path.abspath(folder))


def probe_path(folder: Path, name: str) -> Path:
    """The bake file of probe object ``name``: unsafe file name characters become '_'."""
    return folder / (re.sub(r"[^\w\-. ]", "_", name).strip() + ".exr")


def probe_objects(scene, selected_only: bool = False) -> list:
    """Sphere and Volume light probe objects that render, in name order."""
    objs = [o for o in scene.objects if o.type == "LIGHT_PROBE" and o.data.type in KINDS
            and not o.hide_render and (not selected_only or o.select_get())]
    return sorted(objs, key=lambda o: o.name)


def _matrix(obj) -> np.ndarray:
    return np.array(obj.matrix_world, np.float64)


def _describe(obj) -> dict:
    """What a bake of ``obj`` depends on, as stored in its file's metadata."""
    data = obj.data
    meta = {"probe": obj.name, "kind": KINDS[data.type], "matrix": _matrix(obj).tolist(),
            "clip_start": float(data.clip_start)}
    if data.type == "VOLUME":
        meta["resolution"] = [int(data.resolution_x), int(data.resolution_y),
                              int(data.resolution_z)]
    return meta


# --------------------------------------------------------------------------------------------
# the world probe

_world_cache: dict = {}


def world_probe(world: World, size: int = 64) -> tuple[np.ndarray, dict]:
    """(SH (9, 3), chains) of the world, cached while the world stays the same."""
    key = (id(world.texture), tuple(np.asarray(world.color, np.float32).ravel()),
           float(world.strength), np.asarray(world.rotation, np.float64).tobytes(), size)
    if _world_cache.get("key") != key:
        _world_cache.clear()
        _world_cache["key"] = key
        _world_cache["value"] = capture.filtered(capture.world_cube(world, size))
    return _world_cache["value"]


def world_probes(world: World) -> cp.Probes:
    """Probes of the world alone (the fallback of every probe)."""
    world_sh, world_mips = world_probe(world)
    color = None if world.texture is not None else np.asarray(world.color, np.float32)[:3]
    return cp.Probes(world_sh=world_sh, world_mips=world_mips, world_color=color)


# --------------------------------------------------------------------------------------------
# loading baked probes for a render


def _probe_from_file(obj, path: Path, warnings: list[str]):
    """The core probe of ``obj`` from its file, or None with one warning."""
    where = f"Light probe '{obj.name}'"
    try:
        meta, coeffs, chains = probe_file.read(path)
    except probe_file.ProbeFileError as exc:
        warnings.append(f"{where}: {exc}; the world lights it instead")
        return None
    current = _describe(obj)
    if meta.get("kind") != current["kind"] or (
            not np.allclose(meta.get("matrix", 0), current["matrix"], atol=1e-4)
            or meta.get("resolution") != current.get("resolution")):
        warnings.append(f"{where}: the bake is stale (the probe moved or changed since "
                        f"{meta.get('bake_time', 'it was baked')}); re-bake. The world lights "
                        "it instead")
        return None
    data = obj.data
    if current["kind"] == "reflection":
        if set(chains) != set(cp.PREFILTERS):
            warnings.append(f"{where}: the bake has no prefiltered cube maps; re-bake")
            return None
        return cp.ReflectionProbe(name=obj.name, position=_matrix(obj)[:3, 3],
                                  radius=float(data.influence_distance),
                                  falloff=float(data.falloff), mips=chains, sh=coeffs[0])
    res = tuple(current["resolution"])
    return cp.IrradianceVolume(name=obj.name, local_to_world=_matrix(obj), resolution=res,
                               sh=coeffs.reshape(*res, 9, 3),
                               influence=float(data.influence_distance))


def load_probes(scene, world: World, warnings: list[str]) -> cp.Probes:
    """The world fallback and every baked probe of ``scene`` (missing, stale or corrupt
    bakes: one warning each, and the world instead)."""
    result = world_probes(world)
    objs = probe_objects(scene)
    if not objs:
        return result
    try:
        folder = bake_folder(scene)
    except BakeError as exc:
        warnings.append(f"Light probes not loaded: {exc}")
        return result
    for obj in objs:
        probe = _probe_from_file(obj, probe_path(folder, obj.name), warnings)
        if isinstance(probe, cp.ReflectionProbe):
            result.reflection.append(probe)
        elif probe is not None:
            result.volumes.append(probe)
    return result


# --------------------------------------------------------------------------------------------
# baking


def _cycles_cube(scene, position, size: int, near: float, far: float) -> np.ndarray:
    """(6, size, size, 3) radiance at ``position`` rendered by Cycles (full global
    illumination): one square 90-degree render per face of ``cubemap.FACES``."""
    from mathutils import Matrix

    cam_data = bpy.data.cameras.new("BO2 Probe Capture")
    cam_data.angle = np.pi / 2
    cam_data.sensor_fit = "AUTO"
    cam_data.clip_start, cam_data.clip_end = near, far
    cam = bpy.data.objects.new("BO2 Probe Capture", cam_data)
    scene.collection.objects.link(cam)
    r = scene.render
    saved = (scene.camera, r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage,
             r.use_border, r.film_transparent, scene.cycles.samples)
    out = np.empty((6, size, size, 3), np.float32)
    try:
        scene.camera, r.engine = cam, "CYCLES"
        scene.cycles.samples = int(scene.bo2.bake_cycles_samples)
        r.resolution_x = r.resolution_y = size
        r.resolution_percentage, r.use_border, r.film_transparent = 100, False, False
        with tempfile.TemporaryDirectory() as tmp:
            path = str(Path(tmp) / "face.exr")
            for face in range(6):
                forward, right, up = cubemap.FACES[face]
                m = np.eye(4)
                m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, up, -np.asarray(forward), position
                cam.matrix_world = Matrix(m.tolist())
                bpy.ops.render.render()
                _save_linear(scene, path)
                img = bpy.data.images.load(path)
                try:
                    px = np.empty(size * size * 4, np.float32)
                    img.pixels.foreach_get(px)
                finally:
                    bpy.data.images.remove(img)
                out[face] = px.reshape(size, size, 4)[::-1, :, :3]
    finally:
        (scene.camera, r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage,
         r.use_border, r.film_transparent, scene.cycles.samples) = saved
        bpy.data.objects.remove(cam)
        bpy.data.cameras.remove(cam_data)
    return out


def _save_linear(scene, path: str) -> None:
    settings = scene.render.image_settings
    saved = (settings.file_format, settings.color_depth)
    if hasattr(settings, "media_type"):
        settings.media_type = "IMAGE"
    settings.file_format, settings.color_depth = "OPEN_EXR", "32"
    try:
        bpy.data.images["Render Result"].save_render(filepath=path, scene=scene)
    finally:
        settings.file_format, settings.color_depth = saved


def _first_bounce(world: World, objs) -> cp.Probes:
    """Indirect light of the first bounce's captures: the world lights surfaces outside the
    probes' regions (an open scene's ground), nothing lights those inside them (a closed room
    must not be lit by a sky it cannot see); later bounces fill them in."""
    probes = world_probes(world)
    black = [np.zeros((6, 1, 1, 3), np.float32)]
    for obj in objs:
        m, data = _matrix(obj), obj.data
        if data.type == "SPHERE":
            probes.reflection.append(cp.ReflectionProbe(
                obj.name, m[:3, 3], float(data.influence_distance), float(data.falloff),
                {"bo2": black, "bo1": black}, np.zeros((9, 3), np.float32)))
        else:
            probes.volumes.append(cp.IrradianceVolume(
                obj.name, m, (1, 1, 1), np.zeros((1, 1, 1, 9, 3), np.float32),
                float(data.influence_distance)))
    return probes


def bake_steps(context_scene, depsgraph, objs, backend: str = "BO2", report=None):
    """Bake ``objs`` (light probe objects); a generator of progress fractions in [0, 1].

    Every probe's capture points are rendered (BO2: the engine's pipeline, ``bounces`` times:
    the first lit by direct light, emission and the world outside the probes' regions
    (``_first_bounce``), each further one by the previous one's probes; CYCLES: one Cycles
    render per face), then SH and both prefiltered chains are computed, and only then are the
    files written. Closing the generator early (cancel) writes nothing. ``report(message)``
    receives warnings.
    """
    from .engine import render_settings
    from .extract import extract_scene

    scene = context_scene
    settings = scene.bo2
    folder = bake_folder(scene)
    if not objs:
        raise BakeError("No Sphere or Volume light probes to bake")
    start = time.perf_counter()
    rs = dataclasses.replace(render_settings(scene), border=None, film_transparent=False,
                             samples=int(settings.bake_samples))
    core_scene, warnings = extract_scene(depsgraph, rs, camera=False)
    for w in warnings:
        if report is not None:
            report(w)
    core_scene.probes = _first_bounce(core_scene.world, objs)
    size, vol_size = int(settings.bake_face_size), int(settings.bake_volume_face_size)
    points = []  # (object, kind, positions (K, 3), face size)
    for obj in objs:
        if obj.data.type == "SPHERE":
            points.append((obj, "reflection", _matrix(obj)[None, :3, 3], size))
        else:
            res = (obj.data.resolution_x, obj.data.resolution_y, obj.data.resolution_z)
            pos = cp.volume_sample_positions(_matrix(obj), res).reshape(-1, 3)
            points.append((obj, "irradiance", pos, vol_size))
    bounces = 1 if backend == "CYCLES" else max(1, int(settings.bake_bounces))
    total = bounces * sum(len(p[2]) for p in points)
    done = 0
    results: dict[str, tuple] = {}
    for _ in range(bounces):
        grabber = capture.Capture(core_scene) if backend == "BO2" else None
        new = world_probes(core_scene.world)
        for obj, kind, pos, face in points:
            near = max(float(obj.data.clip_start), 1e-3)
            far = float(getattr(obj.data, "clip_end", 1e4))
            coeffs, chains = [], None
            for p in pos:
                if backend == "BO2":
                    grabber.near, grabber.far = near, max(far, 2.0 * near)
                    cube = grabber.cube(p, face)
                else:
                    cube = _cycles_cube(scene, p, face, near, far)
                if kind == "reflection":
                    c, chains = capture.filtered(cube)
                else:
                    c = sh.project(cubemap.texel_directions(face).reshape(-1, 3),
                                   cube.reshape(-1, 3),
                                   np.broadcast_to(cubemap.texel_solid_angles(face),
                                                   (6, face, face)).reshape(-1))
                coeffs.append(np.asarray(c, np.float32))
                done += 1
                yield done / total
            coeffs = np.stack(coeffs)
            results[obj.name] = (obj, coeffs, chains)
            if kind == "reflection":
                new.reflection.append(cp.ReflectionProbe(
                    obj.name, _matrix(obj)[:3, 3], float(obj.data.influence_distance),
                    float(obj.data.falloff), chains, coeffs[0]))
            else:
                res = tuple(int(r) for r in (obj.data.resolution_x, obj.data.resolution_y,
                                             obj.data.resolution_z))
                new.volumes.append(cp.IrradianceVolume(
                    obj.name, _matrix(obj), res, coeffs.reshape(*res, 9, 3),
                    float(obj.data.influence_distance)))
        core_scene = dataclasses.replace(core_scene, probes=new)
    stamp = time.strftime("%Y-%m-%d %H:%M:%S")
    for obj, coeffs, chains in results.values():
        meta = {**_describe(obj), "face_size": size if chains else vol_size,
                "filters": {"bo2": "cosine power", "bo1": "angular gaussian"} if chains else {},
                "backend": backend, "bounces": bounces, "bake_time": stamp,
                "bake_seconds": round(time.perf_counter() - start, 3),
                "version": _version()}
        probe_file.write(probe_path(folder, obj.name), meta, coeffs, chains)
    yield 1.0


def clear(scene, objs) -> int:
    """Delete the bake files of ``objs``; returns how many existed."""
    folder = bake_folder(scene)
    count = 0
    for obj in objs:
        path = probe_path(folder, obj.name)
        if path.exists():
            path.unlink()
            count += 1
    return count
