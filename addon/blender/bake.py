"""Baking Blender's light probes and lightmaps: the scene extracted once, ``core.bakes.bake`` run
with a capture by the engine's pipeline or by Cycles (``core.bakes.lightmap_bake`` for lightmaps),
the files written when every probe (lightmap) is done.

``bake_steps`` (``lightmap_steps``) is the whole bake as a generator of progress fractions,
so that the modal operator runs it a step per timer tick (Esc stops it between steps) and
``bo2 bake`` runs it in a loop. Nothing is written until every probe is done: a cancelled or
failed bake leaves the previous files untouched, and each file is replaced atomically.
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
from ..core import kernels
from ..core.bakes import bake, capture, lightmap_bake
from ..core.files import bake_file, lightmap_file, probe_file
from ..core.formulas import cubemap
from ..core.lighting import lightmap as core_lightmap
from ..core.render.job import RenderJob, Warnings
from ..core.system import machine
from . import bake_files, extract, images, interrupt, lightmaps, probes, render_graph, worlds
from . import settings as settings_of
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
        scene.cycles.samples = settings_of.bake_settings(scene, "CYCLES").cycles_samples
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
    see what ``depsgraph`` evaluates."""
    from mathutils import Vector

    names = set()
    for axis in _AXES:
        hit, _, normal, _, obj, _ = scene.ray_cast(depsgraph, Vector(position), Vector(axis))
        if not hit or normal.dot(Vector(axis)) <= 0.0:  # nothing, or a front face
            return []
        names.add(obj.name)
    return sorted(names)


def kernels_ready(modules):
    """A bake's first steps: 0.0 while the kernels ``modules`` compile in the background
    (``kernels.prepare``: the UI stays live), then their load."""
    while kernels.status() and not kernels.loaded(modules):
        yield 0.0
    kernels.load(None, modules)


def bake_steps(scene, objs, backend: str = "BO2", warnings: Warnings | None = None,
               cluster=None):
    """Bake ``objs`` (light probe objects); a generator of progress fractions in [0, 1] that
    returns the number of probes written.

    backend: "BO2" (the engine's pipeline, ``scene.bo2.probes.bounces`` bounces) or "CYCLES"
             (one Cycles render per face, full global illumination: one bounce)
    warnings: the sink of the bake's warnings (``core.render.job.Warnings``)
    cluster: None to capture here, or a cluster whose ``probe_runner(backend, focus)`` runs
             the captures on its workers (``cluster.session``), each from this file as
             ``capture_scene`` and ``grabbers`` read it there
    The scene is read as a final render evaluates it (``render_graph``). Closing the
    generator early (cancel) writes nothing.
    """
    warnings = Warnings() if warnings is None else warnings
    if not objs:
        raise BakeError("No Sphere or Volume light probes to bake")
    yield from kernels_ready(kernels.FRAME_MODULES)
    folder = probes.writable_folder(scene)
    start = time.perf_counter()
    said = Warnings()  # the scene's, said once the probes are known to bake

    def inside(depsgraph):
        for obj in objs:
            if obj.data.type != "SPHERE":
                continue
            # an enclosing object smaller than the probe's reach is a prop it sits in; a larger
            # one is the room around it (walls modelled with outward normals)
            reach = 2.0 * float(obj.data.influence_distance)
            names = [name for name in enclosing_objects(scene, depsgraph,
                                                        obj.matrix_world.translation)
                     if scene.objects[name].dimensions.length < reach
                     and not scene.objects[name].hide_probe_sphere]  # not in its captures
            if names:
                said.add(f"Light probe '{obj.name}' seems to be inside object "
                         f"{', '.join(repr(n) for n in names)}: its captures see the "
                         "inside; move the probe out, or raise its Clip Start past the "
                         "surface")

    core_scene = capture_scene(scene, said, inside)
    odd = Warnings()
    specs = bake.check([probes.spec(o) for o in objs], odd)
    if not specs:  # every probe was refused: the refusals are the error
        raise BakeError(f"No light probe can be baked: {'; '.join(odd.texts())}")
    warnings.extend(said)
    warnings.extend(odd)
    b = settings_of.bake_settings(scene, backend)
    face_size = b.face_size
    _check_room(folder, sum(probe_file.size_bound(len(s.points), face_size if s.kind ==
                                                  "reflection" else None) for s in specs))
    focus = bake.capture_region(specs)
    if cluster is None:
        grab, surfaces = grabbers(scene, core_scene, focus, backend)
        runner = None
    else:
        grab = surfaces = None
        runner = cluster.probe_runner(backend, focus)
    job = bake.Bake(specs, core_scene.world, grab,
                    bounces=b.bounces,
                    converge=b.converge,
                    face_size=face_size,
                    volume_face_size=b.volume_face_size,
                    surfaces=surfaces, runner=runner)
    yield from job.steps()
    for baked in job.results:
        if baked.validity is not None and not baked.validity.all():
            count = int((baked.validity == 0).sum())
            warnings.add(f"Light probe '{baked.spec.name}': {count} of {len(baked.validity)} "
                         "samples are inside geometry with no valid neighbour; they are left "
                         "out (raise Dilation Radius or Escape Bias, or move the volume)")
    stamp = time.strftime("%Y-%m-%d %H:%M:%S")
    interrupt.check()  # Ctrl-C during the last capture: nothing is written
    targets = [(scene.objects[b.spec.name], bake_files.target(scene, scene.objects[b.spec.name]))
               for b in job.results]
    try:
        with interrupt.writing():
            probe_file.write_all([
                (path, bake.metadata(b, backend, job.bounces, stamp,
                                     time.perf_counter() - start, version(), job.converged),
                 b.coeffs, b.chains if b.moments is None else {probe_file.DEPTH: [b.moments]})
                for b, (_, path) in zip(job.results, targets, strict=True)])
    except (OSError, bake_file.BakeFileError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise BakeError(f"Could not write the bake into {bake_files.file_folder(scene)} "
                        f"({reason}); the previous bake files are as they were") from None
    _declare(scene, targets)
    yield 1.0
    return len(targets)


def capture_scene(scene, warnings: Warnings | None = None, check=None):
    """The core scene the probe captures of ``scene`` see (its Light Probe Bake settings; a
    world of any nodes rendered by Cycles first), read as a final render evaluates it;
    ``check(depsgraph)`` looks at that evaluation too. BakeError when Blender cannot render."""
    rs = settings_of.render_settings(scene, "PROBE_BAKE")
    worlds.ensure(scene)

    def read(depsgraph):
        core_scene, _ = extract.extract_scene(depsgraph, rs, camera=False,
                                              should_stop=interrupt.requested,
                                              warnings=warnings)
        if check is not None:
            check(depsgraph)
        return core_scene

    return _read_for_render(scene, read)


def grabbers(scene, core_scene, focus, backend: str):
    """(the capture, the surroundings' look) of a probe bake of ``core_scene``
    (``capture_scene``) by ``backend``, "BO2" or "CYCLES" (``bake.CaptureFn``,
    ``bake.SurfacesFn``); the suns' shadows sharp over ``focus``
    (``bake.capture_region``). The volumes' look at their surroundings is the engine's with
    either backend; Ctrl-C of the bo2 command stops a capture."""
    captures = capture.Capture(RenderJob(core_scene, should_stop=interrupt.requested),
                               focus=focus)
    if backend == "BO2":
        return captures.cube, captures.surfaces

    def grab(position, size, near, far, _probes, kind):
        return cycles_cube(scene, position, size, near, far, kind)

    return grab, captures.surfaces


def _read_for_render(scene, read):
    """``render_graph.evaluate(scene, read)``; BakeError when Blender cannot render."""
    try:
        return render_graph.evaluate(scene, read)
    except RuntimeError as exc:
        raise BakeError(str(exc)) from None


# --------------------------------------------------------------------------------------------
# lightmaps


def lightmap_plan(scene, depsgraph, core_scene, objs, warnings: Warnings
                  ) -> tuple[list, list[dict]]:
    """The bake's ``core_lightmap.Target`` per object of ``objs`` that can have one, and per target
    what its file records (UV map, density); into ``warnings``, one for each object left out or
    laid out anew. Raises BakeError when none can, or when they would take more memory than
    the cap."""
    s = settings_of.lightmap_settings(scene)
    targets, notes = [], []
    for obj in objs:
        k = lightmaps.batch_index(core_scene, obj.name)
        if k is None:
            warnings.add(f"Object '{obj.name}' has no faces that render: no lightmap")
            continue
        positions = core_scene.meshes[k].positions
        finite = np.isfinite(positions).all(axis=(1, 2))
        area = 0.5 * np.linalg.norm(np.cross(positions[finite, 1] - positions[finite, 0],
                                             positions[finite, 2] - positions[finite, 0]),
                                    axis=1).sum()
        if not area > 1e-10:
            warnings.add(f"Object '{obj.name}' has no surface area: no lightmap")
            continue
        if not finite.all():
            warnings.add(f"Object '{obj.name}': {int((~finite).sum())} triangles with NaN or "
                         "infinite vertices are left out of its lightmap")
        d = lightmaps.density(obj, scene)
        name = lightmaps.uv_map(obj)
        chosen = obj.bo2.lightmap_uv
        if chosen and name is None:
            warnings.add(f"Object '{obj.name}': its Lightmap UV map '{chosen}' is not one of "
                         "its UV maps; a layout is made for its lightmap instead")
        uvs = None if name is None else lightmaps.artist_uvs(obj, depsgraph, name, len(positions))
        if name is not None and uvs is None:
            warnings.add(f"Object '{obj.name}': its modifiers leave no UV map '{name}'; a "
                         "layout is made for its lightmap instead")
        if uvs is not None:
            width, height = core_lightmap.size_for(uvs[finite], positions[finite], d,
                                              s.max_resolution)
            bad = core_lightmap.overlaps(uvs, width, height)
            outside = (uvs < 0.0).any() or (uvs > 1.0).any()
            if bad or outside or not np.isfinite(uvs).all():
                why = (f"{bad} texels where charts overlap" if bad else
                       "coordinates outside 0..1")
                warnings.add(f"Object '{obj.name}': UV map '{name}' has {why}; a layout is "
                             "made for its lightmap instead")
                uvs = None
        if uvs is None:
            safe = np.where(finite[:, None, None], positions, 0.0)
            uvs, width, height, d = core_lightmap.layout(safe, d, s.padding, s.max_resolution)
            name = ""
        targets.append(core_lightmap.Target(obj.name, k, uvs, width, height))
        notes.append({"uv_map": name, "texels_per_metre": round(d, 4)})
    if not targets:
        raise BakeError("No static mesh object can have a lightmap")
    need = sum(core_lightmap.memory_bytes(t.width, t.height, s.directional) for t in targets)
    if need > s.memory_cap:
        raise BakeError(f"The lightmaps would take {need / 2**20:.0f} MiB, more than the "
                        f"{s.memory_cap / 2**20:.0f} MiB cap: lower Texels per Metre or Max "
                        "Resolution")
    baking, have = lightmap_bake.bake_bytes(targets, s), machine.physical()
    texels = sum(t.width * t.height for t in targets) / 1e6
    if have is not None and baking > 0.8 * have:
        raise BakeError(f"Baking these lightmaps ({texels:.1f} M texels) would take about "
                        f"{machine.size(baking)} of memory, more than this machine's "
                        f"{machine.size(have)} allow: lower Texels per Metre or Max Resolution")
    if baking > BAKE_NOTE:
        warnings.add(f"Baking these lightmaps ({texels:.1f} M texels) takes about "
                     f"{machine.size(baking)} of memory")
    return targets, notes


BAKE_NOTE = 2 << 30  # bytes: a lightmap bake that takes more says so up front


def render_mesh(obj, depsgraph):
    """A new mesh datablock of ``obj`` as ``depsgraph`` evaluates it (its modifiers applied):
    the stand-in a Cycles lightmap bake renders (``cycles_lightmap``); the caller removes it."""
    return bpy.data.meshes.new_from_object(obj.evaluated_get(depsgraph),
                                           preserve_all_data_layers=True, depsgraph=depsgraph)


def cycles_lightmap(scene, obj, mesh, target, uv_map: str | None) -> np.ndarray:
    """(H, W, 3) irradiance, W/m^2, row 0 at v = 1, of ``obj``'s surface baked by Cycles in the
    layout ``target`` (``core.lighting.lightmap.Target``): its indirect light and the world's direct
    light (Bake > Diffuse without colour gives E / pi; the lamps' direct light, which the
    render adds live, is left out by baking the direct pass with the lamps hidden).

    ``mesh`` (``render_mesh``: the object as renders evaluate it, the triangles the layout
    was made for) stands in the object's place during its bake, with the layout as a UV map
    (or the object's own map ``uv_map``) and a temporary Image Texture node in each material;
    all of it but ``mesh`` is removed afterwards and nothing of the object is left changed."""
    stand_in = bpy.data.objects.new("BO2 Lightmap Bake", mesh)
    stand_in.matrix_world = obj.matrix_world
    image = bpy.data.images.new("BO2 Lightmap Bake", target.width, target.height, alpha=False,
                                float_buffer=True)
    layer = bpy.context.view_layer
    saved = (layer.objects.active, [o for o in scene.objects if o.select_get()],
             scene.render.engine, scene.cycles.samples, obj.hide_render)
    lamps = [o for o in scene.objects if o.type == "LIGHT" and not o.hide_render]
    nodes, added_material = [], None
    try:
        mesh.calc_loop_triangles()
        if len(mesh.loop_triangles) != len(target.uvs):
            raise BakeError(f"Object '{obj.name}' changed while it was baked; bake again")
        if uv_map is None:
            loops = np.empty(len(mesh.loop_triangles) * 3, np.int32)
            mesh.loop_triangles.foreach_get("loops", loops)
            uv = np.zeros((len(mesh.loops), 2), np.float32)
            uv[loops] = np.asarray(target.uvs, np.float32).reshape(-1, 2)
            while len(mesh.uv_layers) >= 8:  # Blender's limit: the copy's own maps can go
                mesh.uv_layers.remove(mesh.uv_layers[0])
            layout = mesh.uv_layers.new(name="BO2 Lightmap Bake", do_init=False)
            layout.uv.foreach_set("vector", uv.reshape(-1))
            uv_map = layout.name
        scene.collection.objects.link(stand_in)
        if not any(m is not None for m in mesh.materials):
            added_material = bpy.data.materials.new("BO2 Lightmap Bake")
            added_material.use_nodes = True
            mesh.materials.append(added_material)
        for mat in {m for m in mesh.materials if m is not None and m.node_tree is not None}:
            node = mat.node_tree.nodes.new("ShaderNodeTexImage")
            node.image = image
            mat.node_tree.nodes.active = node
            nodes.append((mat, node))
        for o in saved[1]:
            o.select_set(False)
        obj.hide_render = True  # the stand-in is the object now
        stand_in.select_set(True)
        layer.objects.active = stand_in
        scene.render.engine = "CYCLES"
        scene.cycles.samples = settings_of.bake_settings(scene, "CYCLES").cycles_samples
        total = np.zeros((target.height, target.width, 3), np.float32)
        for passes in ({"INDIRECT"}, {"DIRECT"}):
            for lamp in lamps:
                lamp.hide_render = passes == {"DIRECT"}
            bpy.ops.object.bake(type="DIFFUSE", pass_filter=passes, uv_layer=uv_map,
                                margin=settings_of.lightmap_settings(scene).padding,
                                use_clear=True)
            pixels = np.empty(target.width * target.height * 4, np.float32)
            image.pixels.foreach_get(pixels)
            total += pixels.reshape(target.height, target.width, 4)[::-1, :, :3]
        return total * np.float32(np.pi)
    finally:
        for lamp in lamps:
            lamp.hide_render = False
        for mat, node in nodes:
            mat.node_tree.nodes.remove(node)
        bpy.data.objects.remove(stand_in)
        if added_material is not None:
            mesh.materials.clear()
            bpy.data.materials.remove(added_material)
        bpy.data.images.remove(image)
        for o in saved[1]:
            o.select_set(True)
        layer.objects.active = saved[0]
        scene.render.engine, scene.cycles.samples, obj.hide_render = saved[2:]


def lightmap_steps(scene, objs, warnings: Warnings | None = None, backend: str = "BO2",
                   cluster=None):
    """Bake the lightmaps of ``objs``: a generator of progress fractions in [0, 1] that
    returns the number of lightmaps written; the files are written at the end, all or
    nothing (closing it early writes nothing); ``warnings``: the sink of its warnings.
    backend: "BO2" (``core.bakes.lightmap_bake``) or "CYCLES" (``cycles_lightmap``, one object at
    a time; irradiance only).
    cluster: None to bake here, or a cluster whose ``lightmap_runner()`` runs the BO2
    backend's gathers on its workers (``cluster.session``).

    The objects are baked as a final render evaluates them (``render_graph``: Render levels,
    render-only modifiers), which is what F12 draws. Where the viewport's mesh of an object
    differs, its files also record the viewport's triangles and keys, so that the viewport
    says why it lights that object with the probes rather than calling it stale."""
    warnings = Warnings() if warnings is None else warnings
    if not objs:
        raise BakeError("No static mesh objects to bake lightmaps for")
    yield from kernels_ready(kernels.MODULES)
    probes.writable_folder(scene)
    start = time.perf_counter()
    rs = settings_of.render_settings(scene, "LIGHTMAP_BAKE")
    worlds.ensure(scene)
    cycles = backend == "CYCLES"

    def read(depsgraph):
        # the probes light the dynamic objects that the texels see
        core_scene, _ = extract.extract_scene(depsgraph, rs, camera=False, indirect=True,
                                              lightmaps=False, should_stop=interrupt.requested,
                                              warnings=warnings)
        targets, notes = lightmap_plan(scene, depsgraph, core_scene, objs, warnings)
        meshes = {}
        try:
            for t in targets if cycles else ():
                meshes[t.name] = render_mesh(scene.objects[t.name], depsgraph)
        except BaseException:
            bpy.data.batch_remove(list(meshes.values()))
            raise
        return core_scene, targets, notes, meshes

    core_scene, targets, notes, meshes = _read_for_render(scene, read)
    try:
        viewport = _viewport_keys(scene, [t.name for t in targets])
        s = settings_of.lightmap_settings(scene)
        results: list = []
        if cycles:
            if s.directional:
                warnings.add("The Cycles backend bakes irradiance only: these lightmaps are "
                             "not directional")
                s = dataclasses.replace(s, directional=False)
            for k, (target, note) in enumerate(zip(targets, notes, strict=True)):
                image = cycles_lightmap(scene, scene.objects[target.name], meshes[target.name],
                                        target, note["uv_map"] or None)
                results.append(core_lightmap.Lightmap(np.ascontiguousarray(image), target.uvs))
                interrupt.check()
                yield (k + 1) / (len(targets) + 1)
        else:
            job = RenderJob(core_scene, should_stop=interrupt.requested, warnings=warnings)
            yield from lightmap_bake.steps(job, targets, s, results,
                                           cluster and cluster.lightmap_runner())
    finally:
        bpy.data.batch_remove(list(meshes.values()))
    stamp = time.strftime("%Y-%m-%d %H:%M:%S")
    light = lightmap_bake.light_key(core_scene)
    files = []
    for target, note, result in zip(targets, notes, results, strict=True):
        meta = {"object": target.name, **note, "width": target.width, "height": target.height,
                "rays": s.rays, "bounces": s.bounces, "directional": s.directional,
                "denoise": s.denoise, "backend": backend,
                "geometry_key": lightmap_bake.geometry_key(
                    core_scene.meshes[target.mesh].positions),
                "light_key": light, **viewport.get(target.name, {}), "bake_time": stamp,
                "seconds": round(time.perf_counter() - start, 3), "version": version()}
        obj = scene.objects[target.name]
        files.append((bake_files.target(scene, obj, bake_files.LIGHTMAPS), meta, result, obj))
    interrupt.check()
    try:
        with interrupt.writing():
            lightmap_file.write_all([f[:3] for f in files])
    except (OSError, bake_file.BakeFileError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        where = bake_files.file_folder(scene) / bake_files.LIGHTMAPS
        raise BakeError(f"Could not write the lightmaps into {where} ({reason}); the previous "
                        "lightmaps are as they were") from None
    _declare(scene, [(obj, path) for path, _, _, obj in files])
    yield 1.0
    return len(files)


def _viewport_keys(scene, names: list[str]) -> dict[str, dict]:
    """Per object of ``names``, what the viewport's evaluation of the scene gives (its
    modifiers' viewport settings; ``lightmaps.attach`` reads it in the viewport):
    ``viewport_triangles``, ``viewport_geometry_key`` and ``viewport_light_key``."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    core_scene, _ = extract.extract_scene(depsgraph, settings_of.render_settings(scene),
                                          camera=False, should_stop=interrupt.requested)
    light = lightmap_bake.light_key(core_scene)
    out = {}
    for name in names:
        k = lightmaps.batch_index(core_scene, name)
        if k is None:
            continue
        positions = core_scene.meshes[k].positions
        out[name] = {"viewport_triangles": len(positions),
                     "viewport_geometry_key": lightmap_bake.geometry_key(positions),
                     "viewport_light_key": light}
    return out


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
    """Delete the bakes of ``objs`` (light probes or lightmaps: their datablocks, and their
    files in this .blend's folder); returns how many there were."""
    return sum(bake_files.forget(scene, obj) for obj in objs)


def _declare(scene, written: list[tuple]) -> None:
    """Declare each (object, file) just written (``bake_files.declare``); BakeError when
    Blender refuses (the files are written: a bake of the same objects declares them)."""
    for obj, path in written:
        try:
            bake_files.declare(obj, path, pack=scene.bo2.bake_pack)
        except (RuntimeError, ValueError, AttributeError) as exc:
            raise BakeError(f"'{obj.name}': its bake is written to {path}, but the .blend "
                            f"could not declare it ({exc}); bake it again") from None
