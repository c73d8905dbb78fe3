"""Lightmaps of a Blender scene: which objects are static, their layouts, the bake, the files.

A mesh object is static when its Lightmap setting says so (``object.bo2.lightmap_mode``), or,
on Auto, when neither it nor a parent is animated and no armature deforms it. Its lightmap UVs
are its own UV map chosen in the panel (or named ``LightmapUV``) when that map's charts do not
overlap, else a layout the bake makes (``core.lighting.lightmap.layout``), stored in the lightmap's
file: the object's UV maps are never touched. Each lightmap is one OpenEXR file
(``core.files.lightmap_file``) in ``lightmaps/`` of the .blend's bake folder, or packed into the
.blend, declared by the object's image datablock (``bake_files``), written when every lightmap
is done, all or nothing. At render time (``attach``) each static object takes its
lightmap; one that no longer fits its mesh is left out and one baked before the scene changed
is used and reported stale.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..core import scene as cs
from ..core.bakes import lightmap_bake
from ..core.files import bake_file, lightmap_file
from ..core.lighting import lightmap
from ..core.render.job import Warnings
from . import bake_files, probes
from . import settings as settings_of

UV_NAME = "LightmapUV"


def _animated(obj) -> bool:
    data = obj.animation_data
    if data is not None and (data.action is not None or len(data.drivers)
                             or len(data.nla_tracks)):
        return True
    keys = getattr(obj.data, "shape_keys", None)
    return keys is not None and keys.animation_data is not None and (
        keys.animation_data.action is not None or len(keys.animation_data.drivers))


def is_static(obj) -> bool:
    """Whether ``obj`` gets a lightmap: its Lightmap setting, or on Auto no animation (of it,
    its shape keys or a parent) and no armature."""
    mode = obj.bo2.lightmap_mode
    if mode != "AUTO":
        return mode == "STATIC"
    if any(m.type == "ARMATURE" for m in obj.modifiers):
        return False
    o = obj
    while o is not None:
        if _animated(o) or o.type == "ARMATURE":
            return False
        o = o.parent
    return True


def lightmap_objects(scene, selected_only: bool = False) -> list:
    """Static mesh objects that render, in name order."""
    objs = [o for o in scene.objects if o.type == "MESH" and not o.hide_render
            and is_static(o) and (not selected_only or o.select_get())]
    return sorted(objs, key=lambda o: o.name)


def density(obj, scene) -> float:
    """Texels per metre of ``obj``'s lightmap: its own, else the scene's."""
    return float(obj.bo2.lightmap_density or scene.bo2.lightmaps.density)


def uv_map(obj) -> str | None:
    """The name of ``obj``'s own lightmap UV map (the one chosen, else ``UV_NAME``), or None."""
    layers = obj.data.uv_layers
    name = obj.bo2.lightmap_uv or (UV_NAME if UV_NAME in layers else "")
    return name if name and name in layers else None


def _surface_area(obj) -> float:
    """The object's surface area, m^2 (its mesh's faces scaled by its matrix, roughly)."""
    mesh = obj.data
    area = np.empty(len(mesh.polygons), np.float32)
    mesh.polygons.foreach_get("area", area)
    scale = np.abs(np.linalg.det(np.array(obj.matrix_world, np.float64)[:3, :3])) ** (2.0 / 3.0)
    return float(area.sum() * scale)


def estimate(scene, objs) -> tuple[int, int]:
    """(texels, bytes) that the lightmaps of ``objs`` will take in a frame, estimated from
    their surface area, density and padding, before any layout is made."""
    s = settings_of.lightmap_settings(scene)
    texels = 0
    for obj in objs:
        side = min(np.sqrt(_surface_area(obj) * 1.4) * density(obj, scene) + 2 * s.padding,
                   s.max_resolution)
        texels += int(side * side)
    return texels, texels * (12 if s.directional else 3) * 4


def artist_uvs(obj, depsgraph, name: str, count: int) -> np.ndarray | None:
    """(T, 3, 2) the evaluated mesh's UV map ``name`` per triangle (``extract``'s order), or
    None when it has no such map or another triangle count."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        if mesh is None or name not in mesh.uv_layers:
            return None
        mesh.calc_loop_triangles()
        tris = mesh.loop_triangles
        if len(tris) != count:
            return None
        loops = np.empty(len(tris) * 3, np.int32)
        tris.foreach_get("loops", loops)
        flat = np.empty(len(mesh.loops) * 2, np.float32)
        mesh.uv_layers[name].uv.foreach_get("vector", flat)
        return flat.reshape(-1, 2)[loops].reshape(-1, 3, 2)
    finally:
        evaluated.to_mesh_clear()


def batch_index(core_scene: cs.Scene, name: str) -> int | None:
    """The index of object ``name``'s own batch (not instanced) in ``core_scene.meshes``."""
    for k, m in enumerate(core_scene.meshes):
        if m.name == name and (m.world_to_object is None or np.ndim(m.world_to_object) == 2):
            return k
    return None


# --------------------------------------------------------------------------------------------
# loading lightmaps for a render

def read(p: Path) -> tuple[dict, lightmap.Lightmap]:
    """``lightmap_file.read(p)``, cached while the file stays (``probes.cached_read``)."""
    return probes.cached_read(p, lightmap_file.read)


def state(obj, scene) -> tuple[str, str]:
    """("BAKED", "256 x 256, 0.8 MiB"), ("MISSING", why) or ("DAMAGED", why) of ``obj``'s
    lightmap file (staleness is known at render time: ``attach``)."""
    if bake_files.path(obj) is None:
        return "MISSING", "not baked"
    try:
        p = bake_files.readable(obj)
    except OSError as exc:
        return "DAMAGED", f"its packed lightmap cannot be read ({exc.strerror})"
    if not p.exists():
        return "MISSING", f"{p}: the file is missing"
    try:
        meta, lm = read(p)
    except bake_file.BakeFileError as exc:
        return "DAMAGED", bake_files.failure(obj, p, exc)
    h, w = lm.image.shape[:2]
    kind = "directional, " if lm.directional else ""
    return "BAKED", f"{w} x {h}, {kind}{lm.image.nbytes / 2**20:.1f} MiB"


def attach(scene, core_scene: cs.Scene, warnings: Warnings, viewport: bool = False
           ) -> list[str]:
    """Give each static object of ``core_scene`` (its own batch) its baked lightmap, in place;
    one warning for stale ones (used), one per lightmap that does not fit its mesh or cannot be
    read (left out: the probes light the object). Returns the names of the stale ones.

    Lightmaps are baked for the meshes a final render evaluates; ``viewport``: ``core_scene``
    is the viewport's evaluation, compared with what the bake recorded of it (an object whose
    viewport mesh differs, Levels Viewport below Render, is lit by the probes there)."""
    if not scene.bo2.lightmaps.use:
        return []
    light = None
    stale, render_only = [], []
    for k, batch in enumerate(core_scene.meshes):
        if batch.world_to_object is not None and np.ndim(batch.world_to_object) != 2:
            continue
        obj = scene.objects.get(batch.name)
        if obj is None or obj.type != "MESH" or not obj.bo2.use_lightmap or not is_static(obj):
            continue
        try:
            p = bake_files.readable(obj) if bake_files.path(obj) is not None else None
        except OSError as exc:
            warnings.add(f"Lightmap of '{obj.name}': its packed lightmap cannot be read "
                         f"({exc.strerror}); the probes light it instead")
            continue
        if p is None:
            continue
        if not p.exists():
            warnings.add(f"Lightmap of '{obj.name}': {p} is missing; the probes light it "
                         "instead (bake the lightmaps again)")
            continue
        try:
            meta, lm = read(p)
        except bake_file.BakeFileError as exc:
            warnings.add(f"Lightmap of '{obj.name}': {bake_files.failure(obj, p, exc)}; the "
                         "probes light it instead")
            continue
        prefix = "viewport_" if viewport and "viewport_light_key" in meta else ""
        count = len(batch.positions)
        if len(lm.uvs) != count:
            if prefix and meta.get("viewport_triangles") == count:
                render_only.append(obj.name)
            else:
                warnings.add(f"Lightmap of '{obj.name}' was baked for {len(lm.uvs)} "
                             f"triangles, the object has {count}: re-bake the lightmaps; "
                             "the probes light it until then")
            continue
        if light is None:
            light = lightmap_bake.light_key(core_scene)
        if (meta.get(prefix + "light_key") != light
                or meta.get(prefix + "geometry_key")
                != lightmap_bake.geometry_key(batch.positions)):
            stale.append(obj.name)
        core_scene.meshes[k] = dataclasses.replace(batch, lightmap=lm)
    if stale:
        warnings.add(f"Lightmaps of {_names(stale)} are stale (the scene changed since they "
                     "were baked); re-bake the lightmaps")
    if render_only:
        warnings.add(f"Lightmaps of {_names(render_only)} are baked for the render's "
                     "meshes (their modifiers' Render settings): renders use them, the "
                     "viewport, whose meshes differ, lights these objects with the probes")
    return stale


def _names(names: list[str]) -> str:
    return ", ".join(f"'{n}'" for n in names[:5]) + (" ..." if len(names) > 5 else "")
