"""Evaluated depsgraph -> ``core.scene.Scene``: camera, meshes, materials, lights, world.

Meshes are read in bulk with ``foreach_get`` (loop triangles, positions, corner normals,
material indices) from the evaluated object of every instance, so modifiers, collection
instances and geometry-nodes instances all arrive with their world matrices. Depth of field is
ignored; panoramic cameras are refused with a clear error.
"""

from __future__ import annotations

import collections
import dataclasses
import hashlib
from collections.abc import Callable

import bpy
import numpy as np

from ..core import scene as cs
from ..core.lighting import world_sun
from ..core.render import memory
from ..core.render.job import Cancelled, Warnings
from . import lightmaps as baked_lightmaps
from . import linking, worlds
from . import settings as settings_of
from .images import load_image
from .lights import blender_light, euler_xyz
from .materials import convert_material
from .meshes import read_mesh, to_world
from .probes import load_probes

_GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}


class SceneError(Exception):
    """The scene cannot be rendered; the message is shown to the user as is."""


def _matrix(m) -> np.ndarray:
    return np.array([list(row) for row in m], np.float64)


def aperture(cam, warnings: Warnings | None) -> cs.Aperture | None:
    """The depth of field of evaluated camera object ``cam`` as Cycles reads it (the radius
    the focal length over twice the f-stop; the focus object's distance along the view axis,
    or the Focus Distance), or None when it has none."""
    dof = cam.data.dof
    if not dof.use_dof:
        return None
    if cam.data.type != "PERSP":
        if warnings is not None:
            warnings.add(f"Camera '{cam.name}': BO2 Lighting renders depth of field with "
                         "perspective cameras only")
        return None
    focus = float(dof.focus_distance)
    target = dof.focus_object
    if target is not None:
        where = np.asarray(target.matrix_world.translation, np.float64)
        bone = getattr(dof, "focus_subtarget", "")
        if bone and target.pose is not None and bone in target.pose.bones:
            where = np.asarray(target.matrix_world @ target.pose.bones[bone].head, np.float64)
        world = _matrix(cam.matrix_world)
        along = float((where - world[:3, 3]) @ -world[:3, 2] / np.linalg.norm(world[:3, 2]))
        if along < 0.0 and warnings is not None:
            warnings.add(f"Camera '{cam.name}': its focus object '{target.name}' is behind it; "
                         "it focuses at that distance ahead, as Cycles does")
        focus = abs(along)
    fstop = max(float(dof.aperture_fstop), 1e-5)
    blades = int(dof.aperture_blades)
    return cs.Aperture(radius=float(cam.data.lens) * 1e-3 / (2.0 * fstop),
                       focus=max(focus, 1e-5), blades=blades if blades >= 3 else 0,
                       rotation=float(dof.aperture_rotation),
                       ratio=max(float(dof.aperture_ratio), 1e-6))


def extract_camera(depsgraph, warnings: Warnings | None = None) -> cs.Camera:
    """The scene camera with Blender's sensor fit, shift, clipping and depth of field."""
    scene = depsgraph.scene
    if scene.camera is None:
        raise SceneError("The scene has no active camera: add one and set it as the scene camera")
    cam = scene.camera.evaluated_get(depsgraph)
    if cam.type != "CAMERA":
        raise SceneError(f"The scene camera '{cam.name}' is not a camera object")
    if cam.data.type == "PANO":
        raise SceneError(f"Camera '{cam.name}' is panoramic: BO2 Lighting renders "
                         "perspective and orthographic cameras only")
    w, h = settings_of.resolution(scene)
    r = scene.render
    proj = cam.calc_matrix_camera(depsgraph, x=w, y=h,
                                  scale_x=r.pixel_aspect_x, scale_y=r.pixel_aspect_y)
    return cs.Camera(
        world_to_camera=np.linalg.inv(_matrix(cam.matrix_world)),
        projection=_matrix(proj),
        width=w,
        height=h,
        orthographic=cam.data.type == "ORTHO",
        aperture=aperture(cam, warnings),
    )


def _environment(node, world_name: str, warnings: Warnings):
    """(texture, rotation) of an Environment Texture node, or (None, None) with a warning."""
    where = f"World '{world_name}', node '{node.name}'"
    if node.projection != "EQUIRECTANGULAR":
        warnings.add(f"{where}: only the equirectangular projection is supported")
        return None, None
    rotation = np.eye(3)
    vec = node.inputs["Vector"].links
    if vec:
        mapping = vec[0].from_node
        if mapping.type == "MAPPING" and mapping.vector_type in {"POINT", "VECTOR"}:
            rotation = euler_xyz(*mapping.inputs["Rotation"].default_value)
            # The Mapping node rotates the lookup vector: texture = image(R d).
        elif mapping.type != "TEX_COORD":
            warnings.add(f"{where}: node '{mapping.name}' on its vector is not supported")
    tex = load_image(node.image, "REPEAT", node.interpolation, warnings, where)
    return tex, rotation


def _world(scene, warnings: Warnings) -> cs.World:
    """The background: the Background node's colour or equirectangular texture, times strength;
    any other tree, its equirect rendered by Cycles (``worlds``), or its viewport colour with a
    warning when it is not rendered."""
    world = scene.world
    if world is None:
        return cs.World(color=np.zeros(3, np.float32))
    if not worlds.direct(world):
        rendered = worlds.lookup(scene, world)
        if rendered is not None:
            tex = rendered.texture
            return cs.World(color=np.asarray(tex.mips[-1][0, 0, :3], np.float32), texture=tex,
                            sun=rendered.sun)
        reason = worlds.problem(world)
        warnings.add(f"World '{world.name}' cannot be evaluated ({reason}); its viewport "
                     "colour is used" if reason else
                     f"World '{world.name}' has not been evaluated since it changed (its "
                     "nodes are rendered by Cycles before a bake or a render of the bo2 "
                     "command, or with World > Evaluate); its viewport colour is used")
        return cs.World(color=np.array(world.color[:3], np.float32))
    tree = world.node_tree
    # World.use_nodes is deprecated (always on) from Blender 5.0.
    if tree is None or (bpy.app.version < (5, 0, 0) and not world.use_nodes):
        return cs.World(color=np.array(world.color[:3], np.float32))
    out = next((n for n in tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
    links = out.inputs["Surface"].links if out is not None else ()
    node = links[0].from_node if links else None
    if node is None or node.type != "BACKGROUND":
        if node is not None:
            warnings.add(f"World '{world.name}': node '{node.name}' is not supported; "
                         "the world colour is used")
        return cs.World(color=np.array(world.color[:3], np.float32))
    color_in, strength_in = node.inputs["Color"], node.inputs["Strength"]
    strength = float(strength_in.default_value)
    if strength_in.is_linked:
        warnings.add(f"World '{world.name}': a node on Strength is not supported")
    color = np.array(color_in.default_value[:3], np.float32)
    if color_in.is_linked:
        src = color_in.links[0].from_node
        if src.type == "TEX_ENVIRONMENT":
            tex, rotation = _environment(src, world.name, warnings)
            if tex is not None:
                return cs.World(color=color * strength, texture=tex, strength=strength,
                                rotation=rotation)
        else:
            warnings.add(f"World '{world.name}': node '{src.name}' on the background colour "
                         "is not supported; the Background node's own colour is used")
    return cs.World(color=color * strength)


def extract_world(scene, warnings: Warnings) -> cs.World:
    """The background (``_world``) with its sun taken out as a light (``core.lighting.world_sun``):
    EEVEE's World > Sun settings (Threshold, Angle, Shadow) are the world's for both."""
    world = _world(scene, warnings)
    source = scene.world
    if source is None or not source.sun_threshold > 0.0:
        return world
    shadow = bool(source.use_sun_shadow)
    if world.sun is not None:  # a Sky Texture's disc
        return dataclasses.replace(world, sun=dataclasses.replace(world.sun, shadow=shadow))
    return world_sun.split(world, float(source.sun_threshold), float(source.sun_angle), shadow)


def _asset(obj) -> str:
    """The name of ``obj``'s topmost parent ("" when it has none): its Cryptomatte asset."""
    top = obj.original
    while top.parent is not None:
        top = top.parent
    return top.name if top is not obj.original else ""


def _visibility(obj, view_layer) -> tuple[bool, bool, bool, bool, bool]:
    """What the depsgraph does not filter of an object's render visibility: (holdout, seen by
    the camera, casts shadows, seen by Sphere probes, by Volume probes); ``MeshBatch``'s
    fields of the same names."""
    holdout = bool(obj.is_holdout or obj.original.holdout_get(view_layer=view_layer))
    return (holdout, bool(getattr(obj, "visible_camera", True)),
            bool(getattr(obj, "visible_shadow", True)),
            not getattr(obj, "hide_probe_sphere", False),
            not getattr(obj, "hide_probe_volume", False))


def _object_data(obj, cache: SceneCache, warnings, strands: bool = True):
    """Object-space triangles, global material indices (``cache.materials``), corner
    attributes and texture space of an evaluated object (its mesh, and its hair curves and
    points as ``core.scene.strands`` makes them; a mesh object's geometry nodes' curves and
    points only with ``strands``: read one by one, they are instances of their own), or
    None."""
    parts = []
    try:
        mesh = obj.to_mesh()
    except RuntimeError:  # a Curves or Point Cloud object whose nodes make no mesh
        mesh = None
    try:
        if mesh is not None and len(mesh.polygons):
            parts.append(_mesh_data(mesh, [ms.material for ms in obj.material_slots],
                                    obj.name, cache, warnings))
    finally:
        obj.to_mesh_clear()
    if obj.type in _STRAND_TYPES or strands and any(m.type == "NODES" for m in obj.modifiers):
        strand = _strand_data(obj, cache, warnings)
        if strand is not None:
            parts.append(strand)
    if len(parts) < 2:
        return parts[0] if parts else None
    (pos, nrm, uvs, mat, attributes, texspace), (spos, snrm, _, smat, _, _) = parts
    zeros = {key: np.zeros((len(spos), *a.shape[1:]), np.float32)
             for key, a in attributes.items()}
    return (np.concatenate([pos, spos]), np.concatenate([nrm, snrm]),
            None if uvs is None else np.concatenate([uvs, np.zeros((len(spos), 3, 2),
                                                                   np.float32)]),
            np.concatenate([mat, smat]),
            {key: np.concatenate([a, zeros[key]]) for key, a in attributes.items()}, texspace)


_STRAND_TYPES = {"CURVES", "POINTCLOUD"}
DEFAULT_RADIUS = 0.01  # metres: a hair curve's or a point's without a radius attribute
HAIR_SEGMENTS = 2_000_000  # hair segments drawn per object (6 triangles each); beyond, thinned


def _float_attribute(owner, name: str, count: int, default: float) -> np.ndarray:
    attribute = owner.attributes.get(name)
    out = np.full(count, default, np.float32)
    if attribute is not None and attribute.data_type == "FLOAT" and len(attribute.data) == count:
        attribute.data.foreach_get("value", out)
    return out


def _strand_data(obj, cache: SceneCache, warnings):
    """``_object_data`` of evaluated object ``obj``'s hair curves (tubes) and points
    (spheres), each in its first material, or None when it has neither."""
    from ..core.scene import strands

    geometry = _geometry(obj)
    if geometry is None:
        return None
    tris, normals, mats = [], [], []

    def material(component) -> int:  # its first material, as Cycles gives the component
        first = component.materials[0] if len(component.materials) else None
        return cache.material(first, warnings)

    curves = geometry.curves
    if curves is not None and len(curves.points) and len(curves.curves):
        count = len(curves.points)
        points = np.empty(count * 3, np.float32)
        curves.position_data.foreach_get("vector", points)
        offsets = np.empty(len(curves.curves) + 1, np.int32)
        curves.curve_offset_data.foreach_get("value", offsets)
        radii = _float_attribute(curves, "radius", count, DEFAULT_RADIUS)
        points = points.reshape(-1, 3)
        segments = count - len(curves.curves)
        step = max(1, -(-segments // HAIR_SEGMENTS))
        if step > 1:  # every step-th curve, step times as thick: the same coverage
            warnings.add(f"Hair '{obj.name}': {segments:,} segments, more than "
                         f"{HAIR_SEGMENTS:,}: every {step}th curve is drawn, {step} times as "
                         "thick")
            keep = np.arange(0, len(offsets) - 1, step)
            take = np.concatenate([np.arange(offsets[k], offsets[k + 1]) for k in keep])
            offsets = np.concatenate([[0], np.cumsum(np.diff(offsets)[keep])])
            points, radii = points[take], radii[take] * step
        t, n, _ = strands.tubes(points, radii, offsets)
        tris.append(t)
        normals.append(n)
        mats.append(np.full(len(t), material(curves), np.int32))
    cloud = geometry.pointcloud
    if cloud is not None and len(cloud.points):
        count = len(cloud.points)
        points = np.empty(count * 3, np.float32)
        cloud.attributes["position"].data.foreach_get("vector", points)
        t, n = strands.spheres(points.reshape(-1, 3),
                               _float_attribute(cloud, "radius", count, DEFAULT_RADIUS))
        tris.append(t)
        normals.append(n)
        mats.append(np.full(len(t), material(cloud), np.int32))
    if not tris:
        return None
    pos = np.concatenate(tris)
    lo, hi = pos.reshape(-1, 3).min(0), pos.reshape(-1, 3).max(0)
    texspace = np.array([lo, np.maximum(hi - lo, 1e-6)], np.float32)
    return pos, np.concatenate(normals), None, np.concatenate(mats), {}, texspace


def _mesh_data(mesh, slots, owner: str, cache: SceneCache, warnings):
    """``_object_data`` of an evaluated mesh whose material slots hold ``slots`` (materials
    or None), of object ``owner`` (messages)."""
    materials = cache.materials
    slot_ids = [cache.material(m, warnings) for m in slots]
    readers: dict[tuple, list[str]] = {}
    for k in slot_ids:
        for key in materials[k].program.requires():
            readers.setdefault(key, []).append(materials[k].name)

    def missing(key):
        kind, name = key
        what = {"uv": "UV map", "attribute": "attribute", "tangent": "UV map"}[kind]
        label = f"'{name}'" if name else "(the active one)"
        warnings.add(f"Material '{readers[key][0]}' reads {what} {label}, which object "
                     f"'{owner}' does not have; it reads 0")

    def ngons():
        warnings.add(f"Object '{owner}' has n-gons: Blender's tangents need triangles "
                     "and quads, so its normal maps use one tangent per triangle")

    pos, nrm, uvs, slot, attributes = read_mesh(mesh, frozenset(readers), missing, ngons)
    texspace = np.array([np.asarray(mesh.texspace_location) - np.asarray(mesh.texspace_size),
                         2.0 * np.asarray(mesh.texspace_size)], np.float32)
    lut = np.array(slot_ids or [0], np.int32)
    return pos, nrm, uvs, lut[np.clip(slot, 0, len(lut) - 1)], attributes, texspace


def _legacy_instancer(obj) -> bool:
    """Whether ``obj`` instances through its own settings (its vertices or faces, a
    collection) or a particle system: such instances are read one by one."""
    if getattr(obj, "instance_type", "NONE") != "NONE":
        return True
    return any(ps.settings.render_type in {"OBJECT", "COLLECTION"}
               for ps in getattr(obj, "particle_systems", ()))


def _geometry(obj):
    """The evaluated geometry (a GeometrySet) of an evaluated object, or None."""
    get = getattr(obj, "evaluated_geometry", None)
    try:
        return get() if get is not None else None
    except TypeError:  # not a geometry object (a camera, a light)
        return None


_NESTING = 8  # instances of instances followed this deep
# objects that may carry geometry-nodes instances (their own mesh, if any, is read too)
_INSTANCERS = _GEOMETRY_TYPES | {"CURVES", "POINTCLOUD", "VOLUME", "GREASEPENCIL", "GPENCIL"}


def _readable_at_once(obj, depsgraph, geometry=None, depth: int = 0) -> bool:
    """Whether the geometry-nodes instances of ``obj`` (if any) can be read at once: every
    reference, nested ones too, is a mesh or an object that may hold geometry (not a
    collection, a light, a camera)."""
    geometry = _geometry(obj) if geometry is None else geometry
    if geometry is None:
        return True
    cloud = geometry.instances_pointcloud()
    if cloud is None or not len(cloud.points):
        return True
    if depth >= _NESTING:
        return False
    for ref in geometry.instance_references():
        if isinstance(ref, bpy.types.Object):
            if ref.type not in _INSTANCERS or not _readable_at_once(
                    ref.evaluated_get(depsgraph), depsgraph, None, depth + 1):
                return False
        elif isinstance(ref, bpy.types.Collection):
            return False
        elif not _readable_at_once(None, depsgraph, ref, depth + 1):
            return False
    return True


def _compose(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """(I J, 16) float32 column-major products outer_i @ inner_j of (I, 16) and (J, 16)."""
    a = outer.reshape(-1, 4, 4).transpose(0, 2, 1).astype(np.float64)
    b = inner.reshape(-1, 4, 4).transpose(0, 2, 1).astype(np.float64)
    both = np.matmul(a[:, None], b[None])
    return np.ascontiguousarray(both.transpose(0, 1, 3, 2).reshape(-1, 16), np.float32)


def _instance_matrices(geometry, owner, depsgraph, shown: set) -> list[tuple]:
    """[(reference, matrices (N, 16) float32 column-major in ``geometry``'s space, owner)] of
    the instances of a GeometrySet (``_readable_at_once``), nested instances flattened (their
    matrices composed in float64), and the own instances of an instanced object in ``shown``
    (names of the objects the depsgraph shows; Blender leaves out those of a hidden one): a
    reference is an object (its mesh) or a GeometrySet (its mesh); ``owner`` is the object
    whose visibility and holdout apply (the instancer, or the instanced object)."""
    cloud = geometry.instances_pointcloud()
    if cloud is None or not len(cloud.points):
        return []
    count = len(cloud.points)
    flat = np.empty(count * 16, np.float32)
    cloud.attributes["instance_transform"].data.foreach_get("value", flat)
    flat = flat.reshape(count, 16)
    which = np.zeros(count, np.int32)
    if ".reference_index" in cloud.attributes:
        cloud.attributes[".reference_index"].data.foreach_get("value", which)
    out = []
    for k, ref in enumerate(geometry.instance_references()):
        pick = np.flatnonzero(which == k)
        if not len(pick):
            continue
        mats = flat if len(pick) == count else flat[pick]
        if isinstance(ref, bpy.types.Object):
            ref = ref.evaluated_get(depsgraph)
            inner = _geometry(ref) if ref.original.name_full in shown else None
            inner_owner = ref
        else:
            inner, inner_owner = ref, owner
        out.append((ref, mats, inner_owner))
        if inner is not None:
            out += [(r, _compose(mats, m), o)
                    for r, m, o in _instance_matrices(inner, inner_owner, depsgraph, shown)]
    return out


def _instances(obj, depsgraph, cache: SceneCache, warnings, shown: set):
    """The geometry-nodes instances of evaluated object ``obj``, read at once: one
    (key, ``_object_data``, matrices (I, 16) float32, column-major, in ``obj``'s space,
    the object whose visibility and holdout apply) per instanced mesh (``shown``: as
    ``_instance_matrices``)."""
    geometry = _geometry(obj)
    if geometry is None:
        return []
    out = []
    for k, (ref, local, owner) in enumerate(_instance_matrices(geometry, obj, depsgraph,
                                                                shown)):
        # an object's data is keyed as when read one by one (an edit of it forgets it)
        key = ((ref.name_full, ref.data.as_pointer() if ref.data is not None else 0)
               if isinstance(ref, bpy.types.Object) else (obj.name_full, "instances", k))
        if key not in cache.objects:
            if isinstance(ref, bpy.types.Object):
                data = (_object_data(ref, cache, warnings)
                        if ref.type in _GEOMETRY_TYPES | _STRAND_TYPES else None)
            else:
                mesh = ref.mesh
                data = (None if mesh is None or not len(mesh.polygons) else
                        _mesh_data(mesh, list(mesh.materials), obj.name, cache, warnings))
            cache.objects[key] = data
            cache.reads["mesh", key[0]] += 1
        if cache.objects[key] is not None:
            out.append((key, cache.objects[key], local, owner))
    return out


def _instanced_batch(data, local: np.ndarray, parent: np.ndarray, name: str,
                     visibility: tuple) -> cs.MeshBatch:
    """One mesh placed by I instance matrices ``local`` (I, 16) (column-major) in the space of
    ``parent`` (4, 4): a batch of its triangles in world space, instance by instance
    (``core.scene.MeshBatch``, ``kernels.raster.place``); mirrored instances keep
    counter-clockwise fronts, their corners reversed. ``visibility``: ``_visibility``'s
    tuple, then the linking masks (``linking.Sets.of_object``), the asset's name, the light
    group and whether it is a shadow catcher."""
    from ..core.kernels import raster

    pos, nrm, uvs, mat_index, attributes, texspace = data
    count, tris = len(local), len(pos)
    wpos = np.empty((count * tris, 3, 3), np.float32)
    wn = np.empty((count * tris, 3, 3), np.float32)
    inverse = np.empty((count, 4, 4))
    mirrored = np.empty(count, bool)
    raster.place(np.ascontiguousarray(pos, np.float32), np.ascontiguousarray(nrm, np.float32),
                 np.ascontiguousarray(local, np.float32), np.ascontiguousarray(parent), wpos,
                 wn, inverse, mirrored)

    def repeated(a):  # per-corner values of the mesh, for every instance
        a = np.ascontiguousarray(np.broadcast_to(a, (count, *a.shape)).reshape(-1, *a.shape[1:]))
        if mirrored.any():
            flip = np.repeat(mirrored, tris)
            a[flip] = a[flip][:, ::-1]
        return a

    wattr = {}
    for key, a in attributes.items():
        a = repeated(np.asarray(a, np.float32))
        if key[0] == "tangent":  # tangents turn with their instance
            a = a.reshape(count, tris, 3, 4)
            lin = local.reshape(count, 4, 4)[:, :3, :3].transpose(0, 2, 1).astype(np.float64)
            lin = np.matmul(parent[:3, :3], lin).astype(np.float32)
            t = np.einsum("nij,ntkj->ntki", lin, a[..., :3])
            t /= np.maximum(np.linalg.norm(t, axis=-1, keepdims=True), 1e-20)
            a[..., :3] = t
            a[mirrored, ..., 3] *= -1.0
            a = a.reshape(-1, 3, 4)
        wattr[key] = a
    return cs.MeshBatch(wpos, wn, np.tile(np.asarray(mat_index, np.int32), count),
                        uvs=None if uvs is None else repeated(np.asarray(uvs, np.float32)),
                        name=name, holdout=visibility[0], camera=visibility[1],
                        shadow=visibility[2], sphere_probes=visibility[3],
                        volume_probes=visibility[4], attributes=wattr, world_to_object=inverse,
                        texspace=texspace, light_sets=visibility[5], shadow_sets=visibility[6],
                        asset=visibility[7], group=visibility[8],
                        shadow_catcher=visibility[9])


class SceneCache:
    """What an extraction read from Blender, kept for the next one (the viewport): each
    object's object-space data, each instance's world-space batch (by matrix), each compiled
    material (by the material's ``session_uid``, so a rename keeps it). ``forget_*`` drops what
    a depsgraph update made stale; ``reads`` counts what was read from Blender: ("mesh",
    object name) and ("material", material name)."""

    EMPTY_SLOT = -1  # the key of an empty material slot

    def __init__(self) -> None:
        self.objects: dict[tuple, tuple | None] = {}
        self.batches: dict[tuple, cs.MeshBatch] = {}
        self.materials: list[cs.Material] = [cs.Material(name="(no material)")]
        self.keys: list[int | None] = [None]  # the Blender material of each entry
        self.mat_ids: dict[int, int] = {}  # compiled and valid: key -> index
        self.reads: collections.Counter = collections.Counter()

    def forget_object(self, name: str) -> None:
        """Read object ``name``'s geometry (and material slots) again."""
        for table in (self.objects, self.batches):
            for key in [k for k in table if k[0] == name]:
                del table[key]

    def forget_material(self, material) -> None:
        """Compile ``material`` (a Blender material, original or evaluated) again; it keeps
        its index."""
        self.mat_ids.pop(material.original.session_uid, None)

    def forget_materials(self) -> None:
        """Compile every material again (an image or node group they may use changed)."""
        self.mat_ids.clear()

    def refresh(self, warnings: Warnings) -> None:
        """Compile again the forgotten materials that objects in the cache use; an object whose
        material now reads other mesh attributes is read again."""
        stale = {key for key in self.keys[1:] if key not in self.mat_ids}
        if not stale:
            return
        by_uid = {m.session_uid: m for m in bpy.data.materials if m.session_uid in stale}
        for key in stale:
            index = self.keys.index(key)
            before = self.materials[index].program.requires()
            self.material(by_uid.get(key), warnings, key)
            if self.materials[index].program.requires() != before:
                for okey, data in list(self.objects.items()):
                    if data is not None and (data[3] == index).any():
                        self.forget_object(okey[0])

    def material(self, mat, warnings: Warnings, key: int | None = None) -> int:
        """The index of ``mat`` (a Blender material or None) in ``materials``, compiled when
        not valid; ``key`` names a material that may have been deleted (``mat`` None)."""
        if key is None:
            key = mat.original.session_uid if mat is not None else self.EMPTY_SLOT
        if key not in self.mat_ids:
            converted = convert_material(mat, warnings)
            self.reads["material", mat.name_full if mat is not None else ""] += 1
            if key in self.keys:
                index = self.keys.index(key)
                self.materials[index] = converted
            else:
                index = len(self.materials)
                self.materials.append(converted)
                self.keys.append(key)
            self.mat_ids[key] = index
        return self.mat_ids[key]


def _read_objects(depsgraph, cache: SceneCache, warnings: Warnings, triangles: list[int],
                  should_stop: Callable[[], bool] | None = None):
    """``extract_scene``'s walk over the depsgraph's instances: (meshes, lights, object-space
    data and batches by key, for ``cache``); ``triangles[0]`` counts the triangles read, those
    of the batch being made included; ``should_stop`` as ``extract_scene``'s."""
    meshes: list[cs.MeshBatch] = []
    lights: list[cs.Light] = []
    objects: dict[tuple, tuple | None] = {}  # object-space data shared by instances
    batches: dict[tuple, cs.MeshBatch] = {}
    # Geometry-nodes instances are read at once with their instancer (a million instances
    # cost their matrices), unless an object instances otherwise: then one by one.
    at_once = not any(_legacy_instancer(o) or not _readable_at_once(o, depsgraph)
                      for o in depsgraph.objects)

    instancers, shown = [], set()  # (read after the walk, when every shown object is known)
    sets = linking.Sets(warnings)  # every light's linking sets, before any object's
    for obj in depsgraph.objects:
        if obj.type == "LIGHT":
            sets.of_light(obj)
    def poll() -> None:
        if should_stop is not None and should_stop():
            raise Cancelled()

    for inst in depsgraph.object_instances:
        if at_once and inst.is_instance:
            continue
        poll()
        obj = inst.object
        if at_once:
            shown.add(obj.original.name_full)
            if obj.type in _INSTANCERS:
                instancers.append(obj)
        if not inst.show_self:  # an instancer hidden in renders (e.g. a particle emitter)
            continue
        if obj.type == "LIGHT":
            light = blender_light(obj, _matrix(inst.matrix_world))
            light.receivers, light.blockers = sets.of_light(obj)
            light.group = obj.original.lightgroup
            lights.append(light)
            continue
        if obj.type not in _GEOMETRY_TYPES | _STRAND_TYPES:
            continue
        visibility = _visibility(obj, depsgraph.view_layer)
        if not any(visibility[1:]):  # neither seen, nor casting shadows, nor captured
            continue
        visibility += (*sets.of_object(obj), _asset(obj), obj.original.lightgroup,
                       bool(obj.is_shadow_catcher))
        key = (obj.name_full, obj.data.as_pointer() if obj.data is not None else 0, at_once)
        if key not in objects:
            if key not in cache.objects:
                cache.objects[key] = _object_data(obj, cache, warnings, strands=at_once)
                cache.reads["mesh", obj.name_full] += 1
            objects[key] = cache.objects[key]
        data = objects[key]
        if data is None:
            continue
        matrix = _matrix(inst.matrix_world)
        bkey = (*key, matrix.tobytes(), visibility)
        triangles[0] += len(data[0])
        batch = batches.get(bkey) or cache.batches.get(bkey)
        if batch is None:
            pos, nrm, uvs, mat_index, attributes, texspace = data
            wpos, wn, wuv, wattr = to_world(pos, nrm, uvs, attributes, matrix)
            inverse = np.linalg.inv(matrix) if abs(np.linalg.det(matrix)) > 1e-30 else np.eye(4)
            batch = cs.MeshBatch(wpos, wn, mat_index, uvs=wuv, name=obj.name,
                                 holdout=visibility[0], camera=visibility[1],
                                 shadow=visibility[2], sphere_probes=visibility[3],
                                 volume_probes=visibility[4], attributes=wattr,
                                 world_to_object=inverse, texspace=texspace,
                                 light_sets=visibility[5], shadow_sets=visibility[6],
                                 asset=visibility[7], group=visibility[8],
                                 shadow_catcher=visibility[9])
        batches[bkey] = batch
        meshes.append(batch)
    for obj in instancers:
        poll()
        parent = _matrix(obj.matrix_world)
        for key, data, local, owner in _instances(obj, depsgraph, cache, warnings, shown):
            visibility = _visibility(owner, depsgraph.view_layer)
            if not any(visibility[1:]):
                continue
            visibility += (*sets.of_object(owner), _asset(owner), owner.original.lightgroup,
                           bool(owner.is_shadow_catcher))
            objects[key] = data
            digest = hashlib.blake2b(memoryview(np.ascontiguousarray(local)).cast("B"))
            digest.update(parent.tobytes())
            bkey = (*key, digest.digest(), visibility)
            triangles[0] += len(local) * len(data[0])
            batch = batches.get(bkey) or cache.batches.get(bkey)
            if batch is None:
                batch = _instanced_batch(data, local, parent, obj.name, visibility)
            batches[bkey] = batch
            meshes.append(batch)
    return meshes, lights, objects, batches


def read_meshes(depsgraph, should_stop: Callable[[], bool] | None = None
                ) -> list[cs.MeshBatch]:
    """The depsgraph's meshes as ``extract_scene`` reads them, afresh (no cache; lights,
    world and materials left out): what ``motion`` reads at each step of the shutter."""
    return _read_objects(depsgraph, SceneCache(), Warnings(), [0], should_stop)[0]


def _lit_by(world: cs.World) -> bool:
    """Whether ``world`` sends any light."""
    if world.texture is not None:
        return world.strength > 0.0
    return bool(np.any(np.asarray(world.color) > 0.0))


def extract_scene(depsgraph, settings: cs.RenderSettings | None = None, camera: bool = True,
                  indirect: bool = False, cache: SceneCache | None = None,
                  should_stop: Callable[[], bool] | None = None, lightmaps: bool = True,
                  warnings: Warnings | None = None) -> tuple[cs.Scene, Warnings]:
    """Translate the evaluated depsgraph into plain data.

    settings: the engine's settings (``settings.render_settings(scene)`` when None)
    camera:   False for work that brings its own cameras (probe captures, the viewport): the
              scene camera is neither read nor required, and a 1 x 1 placeholder stands in
    indirect: light the scene with its baked probes and the world (``probes.load_probes``);
              False renders direct light only
    cache:    what an earlier extraction read and is still valid (``SceneCache``), updated
    should_stop: polled before each object is read; True raises ``job.Cancelled``
    lightmaps: with ``indirect``, static objects take their baked lightmaps
              (``lightmaps.attach``)
    warnings: the sink of what the user should read (a new one when None)
    returns:  (core.scene.Scene, the sink)
    """
    warnings = Warnings() if warnings is None else warnings
    scene = depsgraph.scene
    viewer = scene.camera if camera else None
    camera = (extract_camera(depsgraph, warnings) if camera else
              cs.Camera(world_to_camera=np.eye(4), projection=np.eye(4), width=1, height=1))
    cache = SceneCache() if cache is None else cache
    cache.refresh(warnings)
    triangles = [0]  # read so far, and those of the batch being made (out of memory)
    try:
        meshes, lights, objects, batches = _read_objects(depsgraph, cache, warnings, triangles,
                                                         should_stop)
    except MemoryError:
        raise memory.OutOfMemory(triangles[0]) from None
    cache.objects, cache.batches = objects, batches  # what is gone from the scene is dropped
    if viewer is not None and viewer.type == "CAMERA" \
            and viewer.data.clip_end <= viewer.data.clip_start:
        warnings.add(f"Camera '{viewer.name}': Clip End is not beyond Clip Start, so it "
                     "sees no geometry (as in Cycles)")
        meshes = []
    world = extract_world(scene, warnings)
    group = scene.world.lightgroup if scene.world is not None else ""
    if group:  # (the world may be a cached one: replaced, not changed)
        world = dataclasses.replace(world, group=group, sun=None if world.sun is None else
                                    dataclasses.replace(world.sun, group=group))
    if world.sun is not None:
        lights.append(world.sun)
    if not lights and not _lit_by(world):
        warnings.add("The scene has no lights and its world is black: only emission is "
                     "visible")
    core = cs.Scene(
        camera=camera,
        meshes=meshes,
        materials=list(cache.materials),
        lights=lights,
        world=world,
        settings=settings or settings_of.render_settings(scene),
        probes=load_probes(scene, world, warnings) if indirect else None,
    )
    if indirect and lightmaps:
        baked_lightmaps.attach(scene, core, warnings, viewport=depsgraph.mode == "VIEWPORT")
    return core, warnings
