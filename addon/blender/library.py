"""The node group asset library: ``node_groups/bo2_node_groups.blend`` with every BO2 group
marked as an asset in the "BO2 Lighting" catalog.

``build()`` writes the file (``tools/build_node_library.py``, from the specs in
``node_groups/``), each group with a preview that BO2 Lighting renders (``render_preview``);
``register_library()`` adds ``node_groups/`` to Blender's asset libraries
(Preferences > File Paths), so the groups show in the Asset Browser and in the shader editor's
Add menu; ``unregister_library()`` removes exactly what it added.
"""

from __future__ import annotations

import os
from pathlib import Path

import bpy
import numpy as np

from ..core.formulas import texture
from ..core.system import atomic
from . import images, node_groups

LIBRARY_NAME = "BO2 Lighting"
LIBRARY_DIR = node_groups.SPEC_DIR
LIBRARY_FILE = LIBRARY_DIR / "bo2_node_groups.blend"
CATALOG_FILE = LIBRARY_DIR / "blender_assets.cats.txt"
CATALOG_ID = "c33160b0-b9e2-4415-bb72-eec7a1bc6d3c"
CATALOG_PATH = "BO2 Lighting"
PREVIEW_SIZE = 128
_added: list[str] = []  # the library this session added (its path)


def _same(a: str, b: Path) -> bool:
    try:
        return os.path.samefile(bpy.path.abspath(a), b)
    except OSError:
        return False


def register_library() -> None:
    """Add ``node_groups/`` as the asset library "BO2 Lighting", unless one points there
    (one of that name, left by saved preferences, is then taken as this one)."""
    libraries = bpy.context.preferences.filepaths.asset_libraries
    existing = [lib for lib in libraries if _same(lib.path, LIBRARY_DIR)]
    if existing:  # ours from an earlier session's saved preferences is ours to remove
        _added.extend(lib.path for lib in existing if lib.name == LIBRARY_NAME)
        return
    lib = libraries.new(name=LIBRARY_NAME, directory=str(LIBRARY_DIR))
    try:
        lib.import_method = "APPEND_REUSE"  # a group added twice is not duplicated
    except TypeError:  # Blender 5 offers Link, Append and Pack
        lib.import_method = "APPEND"
    _added.append(lib.path)


def unregister_library() -> None:
    """Remove the library ``register_library()`` added."""
    libraries = bpy.context.preferences.filepaths.asset_libraries
    for path in _added:
        lib = next((lib for lib in libraries if lib.path == path), None)
        if lib is not None:
            libraries.remove(lib)
    _added.clear()


def render_preview(group, size: int = PREVIEW_SIZE) -> np.ndarray:
    """(size, size, 4) float32 display-referred RGBA, row 0 at the top: a sphere whose BO2
    Material uses ``group`` (its first output fed to the first input of that type; the BO2
    Material itself as it is), rendered by BO2 Lighting under a sun and a rim light.
    The scene it makes is removed again."""
    scene = bpy.data.scenes.new("BO2 preview")
    made = []
    try:
        scene.render.engine = "BO2_LIGHTING"
        scene.render.resolution_x = scene.render.resolution_y = size
        scene.render.resolution_percentage = 100
        scene.render.film_transparent = True
        scene.view_settings.view_transform = "Standard"
        scene.bo2.samples = 8
        world = bpy.data.worlds.new("BO2 preview")
        world.color = (0.05, 0.05, 0.05)
        made.append(world)
        scene.world = world
        mat = node_groups.new_material(f"{group.name} preview")
        made.append(mat)
        if group.name != node_groups.MATERIAL_GROUP:
            _feed(mat.node_tree, group)
        mesh = bpy.data.meshes.new("BO2 preview")
        made.append(mesh)
        _uv_sphere(mesh, 48, 24)
        mesh.materials.append(mat)
        sphere = bpy.data.objects.new("BO2 preview", mesh)
        made.append(sphere)
        scene.collection.objects.link(sphere)
        for name, kind, power, location, rotation in (
                ("Key", "SUN", 3.0, (0.0, 0.0, 0.0), (0.9, 0.0, -0.7)),
                ("Rim", "POINT", 300.0, (2.5, 3.0, 2.5), (0.0, 0.0, 0.0))):
            light = bpy.data.lights.new(f"BO2 preview {name}", kind)
            light.energy = power
            made.append(light)
            obj = bpy.data.objects.new(light.name, light)
            made.append(obj)
            obj.location, obj.rotation_euler = location, rotation
            scene.collection.objects.link(obj)
        cam = bpy.data.cameras.new("BO2 preview")
        cam.lens = 110.0
        made.append(cam)
        camera = bpy.data.objects.new("BO2 preview camera", cam)
        made.append(camera)
        camera.location = (0.0, -8.0, 0.0)
        camera.rotation_euler = (np.pi / 2, 0.0, 0.0)
        scene.collection.objects.link(camera)
        scene.camera = camera
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(scene=scene.name)
        linear = images.render_result_pixels(scene)
        return np.concatenate([texture.linear_to_srgb(np.clip(linear[..., :3], 0.0, 1.0)),
                               linear[..., 3:]], -1).astype(np.float32)
    finally:
        bpy.data.batch_remove([scene, *made])


def _feed(tree, group) -> None:
    """Put ``group`` before the BO2 Material node of ``tree``: its first output into the
    material's first input of the same kind."""
    material = next(n for n in tree.nodes if node_groups.is_bo2_material_node(n))
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    output = node.outputs[0]
    kind = "RGBA" if output.type in {"RGBA", "VECTOR"} else "VALUE"
    target = next((i for i in material.inputs if i.type == kind), material.inputs[0])
    tree.links.new(output, target)


def _uv_sphere(mesh, segments: int, rings: int) -> None:
    """A smooth UV sphere of radius 1 into ``mesh``."""
    import bmesh

    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=rings, radius=1.0)
    for face in bm.faces:
        face.smooth = True
    bm.to_mesh(mesh)
    bm.free()


def build(path: Path = LIBRARY_FILE) -> list[str]:
    """Write the library: every group of ``node_groups.GROUP_NAMES`` built from its spec and
    marked as an asset (catalog, description, tags), in a file of its own, and the catalog
    definition beside it. Runs in a fresh file (the current one is replaced). Returns the
    group names."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for name in node_groups.GROUP_NAMES:
        tree = node_groups.ensure_group(name)
    for name in node_groups.GROUP_NAMES:
        tree = bpy.data.node_groups[name]
        pixels = render_preview(tree)
        tree.asset_mark()
        tree.preview_ensure()
        tree.preview.image_size = pixels.shape[1], pixels.shape[0]
        tree.preview.image_pixels_float = pixels[::-1].ravel()
        tree.asset_data.catalog_id = CATALOG_ID
        tree.asset_data.description = node_groups.load_spec(name).get("description", "")
        tree.asset_data.tags.new("BO2 Lighting")
        tree.asset_data.author = "BO2 Lighting developers"
    path = Path(path)
    atomic.write_atomically(path, lambda tmp: bpy.ops.wm.save_as_mainfile(
        filepath=str(tmp), compress=True, copy=True))
    catalog = path.parent / CATALOG_FILE.name
    catalog.write_text("# Asset catalogs of BO2 Lighting (Blender's catalog definition "
                       "format).\nVERSION 1\n\n"
                       f"{CATALOG_ID}:{CATALOG_PATH}:{CATALOG_PATH}\n")
    return list(node_groups.GROUP_NAMES)
