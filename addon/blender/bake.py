"""Baking Blender's light probes: the scene extracted once, ``core.bake`` run with a capture by
the engine's pipeline or by Cycles, the files written when every probe is done.

``bake_steps`` is the whole bake as a generator of progress fractions, so that the modal
operator runs it a step per timer tick (Esc stops it between steps) and ``bo2 bake`` runs it in
a loop. Nothing is written until every probe is done: a cancelled or failed bake leaves the
previous files untouched, and each file is replaced atomically.
"""

from __future__ import annotations

import dataclasses
import shutil
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

from .. import version
from ..core import bake, capture, cubemap, probe_file
from . import extract, images, interrupt, probes, worlds
from .probes import BakeError


def cycles_cube(scene, position, size: int, near: float, far: float,
                kind: str = "reflection") -> np.ndarray:
    """(6, size, size, 3) radiance at ``position`` rendered by Cycles (full global
    illumination): one square 90-degree render per face of ``cubemap.FACES``. The objects
    hidden from probes of ``kind`` (Object > Visibility > Light Probes) are hidden from its
    camera rays, as from the BO2 capture."""
    from mathutils import Matrix

    flag = "hide_probe_sphere" if kind == "reflection" else "hide_probe_volume"
    hidden = [o for o in scene.objects if getattr(o, flag, False) and o.visible_camera]

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
        for obj in hidden:
            obj.visible_camera = False
        scene.cycles.samples = int(scene.bo2.bake_cycles_samples)
        r.resolution_x = r.resolution_y = size
        r.resolution_percentage, r.use_border, r.film_transparent = 100, False, False
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "face.exr"
            for face in range(6):
                forward, right, up = cubemap.FACES[face]
                m = np.eye(4)
                m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, up, -np.asarray(forward), position
                cam.matrix_world = Matrix(m.tolist())
                bpy.ops.render.render()
                images.save_render_result(scene, path, "OPEN_EXR", "32")
                out[face] = images.read_file(path)[..., :3]
    finally:
        (scene.camera, r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage,
         r.use_border, r.film_transparent, scene.cycles.samples) = saved
        for obj in hidden:
            obj.visible_camera = True
        bpy.data.objects.remove(cam)
        bpy.data.cameras.remove(cam_data)
    return out


_AXES = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0),
         (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))


def enclosing_objects(scene, depsgraph, position) -> list[str]:
    """The names of the objects ``position`` may be inside of: every ray along the six axes
    meets the back of a surface first (the first surface met along each axis), or []. Rays
    see what the viewport shows."""
    from mathutils import Vector

    names = set()
    for axis in _AXES:
        hit, _, normal, _, obj, _ = scene.ray_cast(depsgraph, Vector(position), Vector(axis))
        if not hit or normal.dot(Vector(axis)) <= 0.0:  # nothing, or a front face
            return []
        names.add(obj.name)
    return sorted(names)


def _warn(report, message: str) -> None:
    if report is not None:
        report(message)


def bake_steps(scene, depsgraph, objs, backend: str = "BO2", report=None):
    """Bake ``objs`` (light probe objects); a generator of progress fractions in [0, 1].

    backend: "BO2" (the engine's pipeline, ``scene.bo2.bake_bounces`` bounces) or "CYCLES"
             (one Cycles render per face, full global illumination: one bounce)
    report:  ``report(message)`` receives warnings
    Closing the generator early (cancel) writes nothing.
    """
    settings = scene.bo2
    if not objs:
        raise BakeError("No Sphere or Volume light probes to bake")
    folder = probes.writable_folder(scene)
    files: dict[str, str] = {}
    for obj in probes.probe_objects(scene):  # case-insensitive file systems too
        other = files.setdefault(probes.probe_path(folder, obj.name).name.lower(), obj.name)
        if other != obj.name:
            raise BakeError(f"Light probes '{other}' and '{obj.name}' would share a bake file "
                            "(their names differ only in case); rename one")
    start = time.perf_counter()
    rs = dataclasses.replace(extract.render_settings(scene), border=None,
                             film_transparent=False, samples=int(settings.bake_samples))
    worlds.ensure(scene)  # a world of any nodes: rendered by Cycles first
    core_scene, warnings = extract.extract_scene(depsgraph, rs, camera=False,
                                                 should_stop=interrupt.requested)
    for obj in objs:
        if obj.data.type != "SPHERE":
            continue
        # an enclosing object smaller than the probe's reach is a prop it sits in; a larger one
        # is the room around it (walls modelled with outward normals)
        reach = 2.0 * float(obj.data.influence_distance)
        inside = [name for name in enclosing_objects(scene, depsgraph,
                                                     obj.matrix_world.translation)
                  if scene.objects[name].dimensions.length < reach
                  and not scene.objects[name].hide_probe_sphere]  # not in its captures
        if inside:
            warnings.append(f"Light probe '{obj.name}' seems to be inside object "
                            f"{', '.join(repr(n) for n in inside)}: its captures see the "
                            "inside; move the probe out, or raise its Clip Start past the "
                            "surface")
    specs, odd = bake.check([probes.spec(o) for o in objs])
    if not specs:  # every probe was refused: the refusals are the error
        raise BakeError(f"No light probe can be baked: {'; '.join(odd)}")
    for w in warnings + odd:
        _warn(report, w)
    face_size = int(settings.bake_face_size)
    _check_room(folder, sum(probe_file.size_bound(len(s.points), face_size if s.kind ==
                                                  "reflection" else None) for s in specs))
    # the volumes' surroundings too, with either backend; Ctrl-C of the bo2 command stops it
    captures = capture.Capture(core_scene, should_stop=interrupt.requested)
    if backend == "BO2":
        grab = captures.cube
    else:
        def grab(position, size, near, far, _probes, kind):
            return cycles_cube(scene, position, size, near, far, kind)
    job = bake.Bake(specs, core_scene.world, grab,
                    bounces=1 if backend == "CYCLES" else max(1, int(settings.bake_bounces)),
                    face_size=face_size,
                    volume_face_size=int(settings.bake_volume_face_size),
                    surfaces=captures.surfaces)
    yield from job.steps()
    for baked in job.results:
        if baked.validity is not None and not baked.validity.all():
            count = int((baked.validity == 0).sum())
            _warn(report, f"Light probe '{baked.spec.name}': {count} of {len(baked.validity)} "
                  "samples are inside geometry with no valid neighbour; they are left out "
                  "(raise Dilation Radius or Escape Bias, or move the volume)")
    stamp = time.strftime("%Y-%m-%d %H:%M:%S")
    interrupt.check()  # Ctrl-C during the last capture: nothing is written
    try:
        with interrupt.writing():
            probe_file.write_all([
                (probes.probe_path(folder, b.spec.name),
                 bake.metadata(b, backend, job.bounces, stamp, time.perf_counter() - start,
                               version()), b.coeffs, b.chains) for b in job.results])
    except (OSError, probe_file.ProbeFileError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise BakeError(f"Could not write the bake into {folder} ({reason}); the previous "
                        "bake files are as they were") from None
    yield 1.0


def _check_room(folder: Path, size: int) -> None:
    """BakeError unless the disk of ``folder`` (or of its nearest existing parent) has room
    for ``size`` bytes of new files beside the old ones."""
    existing = folder
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    free = shutil.disk_usage(existing).free
    if free < size:
        raise BakeError(f"Bake folder {folder}: {free / 2**20:.1f} MiB free, the bake needs up "
                        f"to {size / 2**20:.1f} MiB; free some space or choose another folder")


def clear(scene, objs) -> int:
    """Delete the bake files of ``objs``; returns how many existed."""
    folder = probes.bake_folder(scene)
    count = 0
    for obj in objs:
        path = probes.probe_path(folder, obj.name)
        if path.exists():
            path.unlink()
            count += 1
    return count
