"""The prepare stage: a scene made into the buffers every other stage reads (``Frame``): all
triangles concatenated, projected through the camera, their material tables; the frame seen
through another camera or with other materials.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..scene import Material, Scene, linking, material
from . import cryptomatte, depth_of_field, motion_blur, projection, raster
from . import sky as sky_light
from .job import RenderJob


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
    #                         their projection.Projection: for very many triangles, or for a view
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
    # (tile, margin) -> (``tile_margin``'s tuple, ``raster.rasterize``'s ``keep`` dict)
    tiles: dict | None = None
    seen: np.ndarray | None = None   # (T,) bool: the camera sees the triangle (None: all)
    casts: np.ndarray | None = None  # (T,) bool: the triangle casts shadows (None: all)
    # lightmaps (``MeshBatch.lightmap``): per triangle the index of its lightmap in
    # ``lightmaps`` (T,) int32, -1 none, and its lightmap UVs (T, 3, 2); None without any
    lightmap: np.ndarray | None = None
    lightmap_uvs: np.ndarray | None = None
    lightmaps: list | None = None
    # light and shadow linking: per triangle its mesh's ``MeshBatch.light_sets`` and
    # ``shadow_sets`` (T,) uint64, each None when no light has a set of that kind
    receives: np.ndarray | None = None
    blocks: np.ndarray | None = None
    # Cryptomatte: per kind wanted (``RenderSettings.cryptomatte``) each triangle's id (T,)
    # uint64 (``cryptomatte.triangle_ids``)
    crypto: dict | None = None
    # light groups: per triangle the index in ``RenderSettings.light_groups`` of its mesh's
    # group (its emission's) (T,) int32, -1 none; None without light groups
    group: np.ndarray | None = None
    # shadow catchers (``MeshBatch.shadow_catcher``): (T,) bool, None without any
    catcher: np.ndarray | None = None
    # depth of field: pixels by which a lens point may move a triangle
    # (``depth_of_field.reach``), 0 for a pinhole
    lens_reach: int = 0
    # blended transparency (``Material.blended``): (T,) bool, the triangle's surface may be
    # transparent and is composited (``transparency.blend``), None without any; with the
    # object-origin order (``RenderSettings.blend_sort``) each triangle's rank in it (T,)
    # int64; where the material shows one layer per object (``Material.transparency_overlap``
    # off) the triangle's object instance (T,) int64, -1 elsewhere
    blends: np.ndarray | None = None
    blend_rank: np.ndarray | None = None
    blend_solo: np.ndarray | None = None
    # motion blur (``MeshBatch.motion``): per triangle its row in ``motion`` (T,) int32, -1 for
    # a still one, and the moving triangles' corners over the shutter (S, M, 3, 3) float32;
    # pixels by which a sample's time may move a triangle (``motion_blur.reach``)
    motion_row: np.ndarray | None = None
    motion: np.ndarray | None = None
    motion_reach: int = 0
    # the frame as each share of the shutter sees it (``motion_blur.SHUTTER_TIMES`` frames:
    # the moving triangles' corners and normals, the camera and the shadow maps at the share's
    # middle; ``pipeline.prepare``), None when nothing moves; whether a moving triangle casts
    # shadows (then a still surface's shadows change over the shutter too)
    at_times: list | None = None
    shadows_move: bool = False

    @property
    def dithers(self) -> np.ndarray:
        """(T,) bool: triangles whose surface may be transparent and is dithered."""
        return self.fades if self.blends is None else self.fades & ~self.blends

    @property
    def sky(self) -> sky_light.Sky | None:
        """The world's dome of shadow maps (``sky``): the maps after the lights' ones."""
        extra = self.shadow_maps[len(self.scene.lights):]
        return sky_light.Sky(extra) if any(m is not None for m in extra) else None


def _constant_tables(materials: list[Material]) -> dict:
    """Per-material constants of the materials whose program is constant, and which vary."""
    n = len(materials)
    table = {k: np.zeros((n, c), np.float32) for k, c in
             (("albedo", 3), ("rf0", 3), ("emission", 3), ("gloss", 1), ("alpha", 1),
              ("layer", 1), ("layer_f0", 1), ("shadow_alpha", 1))}
    varying = np.array([not m.program.constant for m in materials], bool)
    table["occlusion"] = np.ones((n, 1), np.float32)
    for i, m in enumerate(materials):
        if not varying[i]:
            p = material.evaluate(m.program, _constant_points())
            if p.shadow_alpha is None:
                p.shadow_alpha = p.alpha
            for k in table:
                value = getattr(p, k)
                if value is not None:
                    table[k][i] = np.asarray(value, np.float32).reshape(-1)[:table[k].shape[1]]
    table["varying"] = varying
    table["fades"] = np.array([m.program.fades and (varying[i] or table["alpha"][i, 0] < 1.0)
                               for i, m in enumerate(materials)], bool)
    table["pass_index"] = np.array([m.pass_index for m in materials], np.float32)
    table["blended"] = np.array([m.blended for m in materials], bool) & table["fades"]
    table["overlap"] = np.array([m.transparency_overlap for m in materials], bool)
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


def broken_triangles(positions) -> tuple[np.ndarray, int, int]:
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


def prepare_buffers(job: RenderJob, *, shadow_maps: list) -> Frame:
    """The job's scene as buffers: the meshes concatenated (broken triangles dropped, with one
    warning), projected through the camera, their material tables.

    shadow_maps: the frame's shadow maps (``shadow_maps.shadow_map_count`` of them; ``None``
                 items until ``shadow_maps.build_shadow_maps`` builds them)
    """
    scene = job.scene
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
        catcher = (joined([np.full(len(m.positions), m.shadow_catcher) for m in meshes], bool)
                   if any(m.shadow_catcher for m in meshes) else None)
        receivers, blockers = linking.linked(scene.lights)
        receives, blocks = (
            joined([np.full(len(m.positions), getattr(m, sets), np.uint64) for m in meshes],
                   np.uint64) if wanted else None
            for wanted, sets in ((receivers, "light_sets"), (blockers, "shadow_sets")))
        groups = scene.settings.light_groups
        batch = (joined([np.full(len(m.positions), k, np.int32) for k, m in enumerate(meshes)],
                        np.int32) if scene.settings.cryptomatte or groups else None)
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
        seen = casts = receives = blocks = batch = catcher = None
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
    moving = (joined([np.full(len(m.positions), m.motion is not None) for m in meshes], bool)
              if any(m.motion is not None for m in meshes) else None)
    moves = moving
    keep, nonfinite, flat = broken_triangles(positions)
    if not keep.all():
        job.warn(f"Skipped {nonfinite} triangles with NaN or infinite vertices and {flat} "
                 "with zero area")
        positions, mat_index, has_uv, holdout, obj = (
            a[keep] for a in (positions, mat_index, has_uv, holdout, obj))
        seen, casts, lightmap, lightmap_uvs, receives, blocks, batch, catcher, moves = (
            None if a is None else a[keep] for a in (seen, casts, lightmap, lightmap_uvs,
                                                     receives, blocks, batch, catcher, moves))
        normals = np.nan_to_num(normals[keep])
        uvs = np.nan_to_num(uvs[keep]) if len(uvs) else uvs
        attributes = {k: a[keep] for k, a in attributes.items()}
    uvs = uvs.astype(np.float32, copy=False)
    # attribute values are data from the mesh (Geometry Nodes can make NaN): finite
    attributes = {k: a if np.isfinite(a).all() else np.nan_to_num(a, posinf=0.0, neginf=0.0)
                  for k, a in attributes.items()}

    cam = scene.camera
    clip = clip_coordinates(positions, cam, seen)
    cull_t = np.array([m.backface_culling for m in mats], bool)
    cull = cull_t[mat_index] if cull_t.any() else None

    tables = _constant_tables(mats)
    fades = tables["fades"][mat_index]
    crypto = {kind: cryptomatte.triangle_ids(
        cryptomatte.names_of(meshes, mats, kind), mat_index if kind == "Material" else
        (batch if batch is not None else np.zeros(0, np.int32)))
        for kind in scene.settings.cryptomatte} or None
    groups = scene.settings.light_groups
    group = None
    if groups and batch is not None:
        of_mesh = np.array([groups.index(m.group) if m.group in groups else -1
                            for m in meshes], np.int32)
        group = of_mesh[batch]
    blends, blend_rank, blend_solo = _blending(scene, tables, mat_index, holdout, obj,
                                               world_to_object)
    motion_row = motion = None
    if moves is not None:
        # the moving batches' steps, their broken triangles left out as above
        motion = np.concatenate([np.asarray(m.motion, np.float32) for m in meshes
                                 if m.motion is not None], axis=1)
        motion = motion[:, keep[moving]]
        motion_row = np.full(len(positions), -1, np.int32)
        motion_row[moves] = np.arange(int(moves.sum()), dtype=np.int32)
    return Frame(scene, positions, normals, uvs, has_uv, holdout, mat_index, clip, cull,
                 shadow_maps, tables, attributes, obj, world_to_object, texspace, fades,
                 seen=seen, casts=casts, lightmap=lightmap, lightmap_uvs=lightmap_uvs,
                 lightmaps=[meshes[k].lightmap for k in lit] or None, receives=receives,
                 blocks=blocks, crypto=crypto, group=group, catcher=catcher,
                 lens_reach=depth_of_field.reach(cam, positions if seen is None
                                                 else positions[seen]),
                 blends=blends, blend_rank=blend_rank, blend_solo=blend_solo,
                 motion_row=motion_row, motion=motion,
                 motion_reach=motion_blur.reach(cam, positions, motion_row, motion))


def _blending(scene: Scene, tables: dict, mat_index, holdout, obj, world_to_object):
    """``Frame.blends``, ``blend_rank`` and ``blend_solo`` (each None when not needed)."""
    blends = tables["blended"][mat_index] & ~holdout
    if not blends.any():
        return None, None, None
    solo = None
    lone = ~tables["overlap"][mat_index] & blends
    if lone.any():
        solo = np.where(lone, obj, -1).astype(np.int64)
    return blends, blend_order(scene, obj, world_to_object), solo


def blend_order(scene: Scene, obj: np.ndarray, world_to_object: np.ndarray) -> np.ndarray | None:
    """``Frame.blend_rank`` of triangles of object instances ``obj`` (T,) through the scene's
    camera: EEVEE draws blended objects back to front by their origins' depth along the view
    axis, each object's triangles in their order, so front to back is the reverse; None for
    the per-pixel order."""
    if scene.settings.blend_sort != "object":
        return None
    origin = np.linalg.inv(world_to_object)[:, :3, 3]
    row = np.asarray(scene.camera.world_to_camera, np.float64)[2]
    far = -(origin @ row[:3] + row[3])[obj]
    rank = np.empty(len(obj), np.int64)
    rank[np.lexsort((-np.arange(len(obj)), far))] = np.arange(len(obj))
    return rank


def mesh_flags(frame: Frame, values) -> np.ndarray | None:
    """(T,) bool per triangle of ``frame``: ``values[k]`` of ``frame.scene.meshes[k]``, the
    batch it came from; None when every value is True."""
    if all(values):
        return None
    counts = [1 if m.world_to_object is None else len(np.reshape(m.world_to_object, (-1, 16)))
              for m in frame.scene.meshes]  # instances per batch, as ``frame.obj`` counts them
    batch = np.searchsorted(np.cumsum(counts), frame.obj, side="right")
    return np.asarray(values, bool)[batch]


def clip_coordinates(positions: np.ndarray, camera, seen: np.ndarray | None = None
          ) -> np.ndarray | projection.Projection:
    """(T, 3, 4) float32 clip coordinates of the triangles through ``camera``; for more
    triangles than a raster keeps at once, their ``projection.Projection`` (computed a chunk at a
    time when drawn: a million instances never hold them all). Triangles the camera does not
    see (``seen`` False) are left out: behind the camera, or out of the projection's index."""
    matrix = camera.projection @ camera.world_to_camera
    if len(positions) > raster.SETUP_TRIANGLES:
        index = None if seen is None else np.flatnonzero(seen)
        return projection.Projection(positions, matrix, np.float32, index)
    clip = projection.project(positions, matrix)
    if seen is not None:
        clip[~seen] = (0.0, 0.0, 0.0, -1.0)
    return clip


def with_camera(frame: Frame, camera, once: bool = False) -> Frame:
    """``frame`` seen through another camera: only the projection is redone (same geometry,
    materials and shadow maps). ``once``: the view is drawn as one tile (a probe's face), so
    its projection is left to the tile (``tile_clip``: projected and culled in one pass)."""
    if once:
        clip = projection.Projection(frame.positions, camera.projection @ camera.world_to_camera,
                                 np.float32, None if frame.seen is None else
                                 np.flatnonzero(frame.seen))
    else:
        clip = clip_coordinates(frame.positions, camera, frame.seen)
    scene = dataclasses.replace(frame.scene, camera=camera)
    return dataclasses.replace(frame, scene=scene, at_times=None, shadows_move=False,
                               clip=clip, tiles=None if frame.tiles is None else {},
                               blend_rank=None if frame.blends is None else blend_order(
                                   scene, frame.obj, frame.world_to_object),
                               lens_reach=depth_of_field.reach(camera, frame.positions),
                               motion_reach=motion_blur.reach(camera, frame.positions,
                                                              frame.motion_row, frame.motion))


def with_materials(frame: Frame, scene: Scene) -> Frame | None:
    """``frame`` with ``scene``'s materials (same geometry, lights and camera): only the
    material tables are built again. None when the shadow maps or the holdout triangles depend
    on the materials (transparent or holdout surfaces, before or after) or the frame moves
    over the shutter (``at_times``): ``prepare`` instead."""
    mats = scene.materials or [Material()]
    old = frame.scene.materials or [Material()]
    if len(mats) != len(old) or frame.fades.any() or frame.at_times is not None or any(
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
