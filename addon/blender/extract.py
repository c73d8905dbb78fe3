"""Evaluated depsgraph -> ``core.scene.Scene``: camera, meshes, materials, lights, world.

Meshes are read in bulk with ``foreach_get`` (loop triangles, positions, corner normals,
material indices) from the evaluated object of every instance, so modifiers, collection
instances and geometry-nodes instances all arrive with their world matrices. Depth of field is
ignored; panoramic cameras are refused with a clear error.
"""

from __future__ import annotations

import bpy
import numpy as np

from ..core import scene as cs
from .materials import convert_material

_GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}


class SceneError(Exception):
    """The scene cannot be rendered; the message is shown to the user as is."""


def _matrix(m) -> np.ndarray:
    return np.array([list(row) for row in m], np.float64)


def resolution(scene) -> tuple[int, int]:
    """Output (width, height) in pixels after the resolution percentage."""
    r = scene.render
    scale = r.resolution_percentage / 100.0
    return max(1, int(r.resolution_x * scale)), max(1, int(r.resolution_y * scale))


def extract_camera(depsgraph) -> cs.Camera:
    """The scene camera with Blender's sensor fit, shift and clipping."""
    scene = depsgraph.scene
    if scene.camera is None:
        raise SceneError("The scene has no active camera: add one and set it as the scene camera")
    cam = scene.camera.evaluated_get(depsgraph)
    if cam.type != "CAMERA":
        raise SceneError(f"The scene camera '{cam.name}' is not a camera object")
    if cam.data.type == "PANO":
        raise SceneError(f"Camera '{cam.name}' is panoramic: BO2 Lighting renders "
                         "perspective and orthographic cameras only")
    w, h = resolution(scene)
    r = scene.render
    proj = cam.calc_matrix_camera(depsgraph, x=w, y=h,
                                  scale_x=r.pixel_aspect_x, scale_y=r.pixel_aspect_y)
    return cs.Camera(
        world_to_camera=np.linalg.inv(_matrix(cam.matrix_world)),
        projection=_matrix(proj),
        width=w,
        height=h,
        orthographic=cam.data.type == "ORTHO",
    )


def _read_mesh(mesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Object-space triangles of an evaluated mesh.

    returns: positions (T, 3, 3), corner normals (T, 3, 3), material slot (T,)
    """
    mesh.calc_loop_triangles()
    tris = mesh.loop_triangles
    nt = len(tris)
    vert_idx = np.empty(nt * 3, np.int32)
    loop_idx = np.empty(nt * 3, np.int32)
    slot = np.empty(nt, np.int32)
    tris.foreach_get("vertices", vert_idx)
    tris.foreach_get("loops", loop_idx)
    tris.foreach_get("material_index", slot)
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    corner = np.empty(len(mesh.corner_normals) * 3, np.float32)
    mesh.corner_normals.foreach_get("vector", corner)
    pos = co.reshape(-1, 3)[vert_idx].reshape(nt, 3, 3)
    nrm = corner.reshape(-1, 3)[loop_idx].reshape(nt, 3, 3)
    return pos, nrm, slot


def _to_world(pos: np.ndarray, nrm: np.ndarray, matrix: np.ndarray):
    lin = matrix[:3, :3]
    wpos = pos @ lin.T.astype(np.float32) + matrix[:3, 3].astype(np.float32)
    normal_matrix = np.linalg.inv(lin).T if abs(np.linalg.det(lin)) > 1e-20 else lin
    wn = nrm @ normal_matrix.T.astype(np.float32)
    wn /= np.maximum(np.linalg.norm(wn, axis=-1, keepdims=True), 1e-20)
    if np.linalg.det(lin) < 0:  # mirrored: keep counter-clockwise front faces
        wpos, wn = wpos[:, ::-1], wn[:, ::-1]
    return np.ascontiguousarray(wpos, np.float32), np.ascontiguousarray(wn, np.float32)


def _light(obj, matrix: np.ndarray) -> cs.Light:
    data = obj.data
    axis = -matrix[:3, 2]
    axis = axis / max(np.linalg.norm(axis), 1e-20)
    light = cs.Light(
        kind=data.type,
        color=np.array(data.color[:3], np.float32) * float(data.energy),
        position=matrix[:3, 3].copy(),
        direction=axis,
        shadow=bool(data.use_shadow),
        name=obj.name,
    )
    if data.type in {"POINT", "SPOT"}:
        light.radius = float(data.shadow_soft_size)
    if data.type == "SPOT":
        light.spot_size = float(data.spot_size)
        light.spot_blend = float(data.spot_blend)
    elif data.type == "SUN":
        light.radius = float(data.angle)
    elif data.type == "AREA":
        square = data.shape in {"SQUARE", "DISK"}
        light.size = np.array([data.size, data.size if square else data.size_y])
    return light


def extract_world(scene, warnings: list[str]) -> cs.World:
    """The world's background colour times strength (a constant; textures arrive later)."""
    world = scene.world
    if world is None:
        return cs.World(color=np.zeros(3, np.float32))
    tree = world.node_tree
    # World.use_nodes is deprecated (always on) from Blender 5.0.
    if tree is None or (bpy.app.version < (5, 0, 0) and not world.use_nodes):
        return cs.World(color=np.array(world.color[:3], np.float32))
    out = next((n for n in tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
    links = out.inputs["Surface"].links if out is not None else ()
    node = links[0].from_node if links else None
    if node is None or node.type != "BACKGROUND":
        if node is not None:
            warnings.append(f"World '{world.name}': node '{node.name}' is not supported; "
                            "the world colour is used")
        return cs.World(color=np.array(world.color[:3], np.float32))
    color_in, strength_in = node.inputs["Color"], node.inputs["Strength"]
    if color_in.is_linked or strength_in.is_linked:
        warnings.append(f"World '{world.name}': textured backgrounds are not supported yet; "
                        "the Background node's own colour is used")
    color = np.array(color_in.default_value[:3], np.float32) * float(strength_in.default_value)
    return cs.World(color=color)


def extract_scene(depsgraph, settings: cs.RenderSettings | None = None):
    """Translate the evaluated depsgraph into plain data.

    returns: (core.scene.Scene, warnings: list[str] of messages to report once each)
    """
    warnings: list[str] = []
    scene = depsgraph.scene
    camera = extract_camera(depsgraph)
    materials: list[cs.Material] = [cs.Material(name="(no material)")]
    mat_ids: dict[str, int] = {}
    meshes: list[cs.MeshBatch] = []
    lights: list[cs.Light] = []
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type == "LIGHT":
            lights.append(_light(obj, _matrix(inst.matrix_world)))
            continue
        if obj.type not in _GEOMETRY_TYPES or not getattr(obj, "visible_camera", True):
            continue
        mesh = obj.to_mesh()
        try:
            if mesh is None or len(mesh.polygons) == 0:
                continue
            pos, nrm, slot = _read_mesh(mesh)
            slot_ids = []
            for ms in obj.material_slots:
                mat = ms.material
                key = mat.name_full if mat is not None else ""
                if key not in mat_ids:
                    mat_ids[key] = len(materials)
                    materials.append(convert_material(mat, warnings))
                slot_ids.append(mat_ids[key])
            lut = np.array(slot_ids or [0], np.int32)
            mat_index = lut[np.clip(slot, 0, len(lut) - 1)]
        finally:
            obj.to_mesh_clear()
        wpos, wn = _to_world(pos, nrm, _matrix(inst.matrix_world))
        meshes.append(cs.MeshBatch(wpos, wn, mat_index, name=obj.name))
    if not lights:
        warnings.append("The scene has no lights: only emission and the world are visible")
    return cs.Scene(
        camera=camera,
        meshes=meshes,
        materials=materials,
        lights=lights,
        world=extract_world(scene, warnings),
        settings=settings or cs.RenderSettings(),
    ), warnings
