"""Pictures of docs/lightmaps.md: a room's lightmaps with a 10 km ground under it, and a
subdivided block, rendered by BO2 Lighting beside Cycles (the ``bpy`` module).

Usage: python tools/make_lightmap_scale_images.py [OUT_DIR] [--before NPY]
       python tools/make_lightmap_scale_images.py --bo2-only NPY

The scene: an open room (floor, two walls) with a block under a Subdivision Surface at
Blender's defaults (Levels Viewport 1, Render 2), a sun and a blue sky, on a 10 km ground 50 m
below it. Its lightmaps are baked from the Lightmaps panel's operator (``bo2.bake_lightmaps``)
and the camera's view rendered (F12) by BO2 Lighting with them and by Cycles.
``lightmap_far_ground.png``: the two side by side, and first, with ``--before``, BO2's render
from an earlier version (written there by ``--bo2-only``, which bakes and renders BO2 alone and
uses only operators that version has). Each caption gives the mean of the floor's pixels.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def scene_of(folder: Path):
    """The room on its far ground, saved in ``folder``."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    import bo2_lighting

    bo2_lighting.register()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 320, 240
    scene.view_settings.view_transform = "Standard"
    world = bpy.data.worlds.new("Sky")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.4, 0.6, 1.0)
    scene.world = world

    def material(name, color):
        mat = bpy.data.materials.new(name)
        if mat.node_tree is None:
            mat.use_nodes = True
        node = mat.node_tree.nodes["Principled BSDF"]
        node.inputs["Base Color"].default_value = (*color, 1.0)
        node.inputs["Roughness"].default_value = 0.8
        return mat

    for name, size, loc, rot in [("Floor", 4, (0, 0, 0), (0, 0, 0)),
                                 ("Back", 4, (0, 2, 1), (math.pi / 2, 0, 0)),
                                 ("Left", 4, (-2, 0, 1), (0, math.pi / 2, 0)),
                                 ("Far Ground", 10000, (0, 0, -50), (0, 0, 0))]:
        bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
        bpy.context.object.name = name
        bpy.context.object.data.materials.append(material(name, (0.7, 0.7, 0.7)))
    scene.objects["Far Ground"].bo2.lightmap_mode = "DYNAMIC"
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.4, 0.6, 0.4))
    block = bpy.context.object
    block.name = "Block"
    block.data.materials.append(material("Red", (0.8, 0.1, 0.1)))
    block.modifiers.new("Subdivision", "SUBSURF")  # Levels Viewport 1, Render 2
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), 0, math.radians(-30))
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (2.5, -3.5, 2.5), (math.radians(60), 0, math.radians(35))
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.lightmap_density = 16.0
    scene.bo2.lightmap_rays = 128
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "far_ground.blend"))
    return scene


def render(scene, engine: str) -> np.ndarray:
    """(H, W, 3) scene-linear Combined, row 0 at the top."""
    import bpy

    from bo2_lighting.addon.blender import images

    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.samples = 256
        scene.cycles.device = "CPU"
    else:
        scene.bo2.samples = 16
    assert bpy.ops.render.render() == {"FINISHED"}
    return np.ascontiguousarray(images.render_result_pixels(scene)[::-1, :, :3])


def bo2_render() -> np.ndarray:
    """Bake the lightmaps from the panel's operator and render with BO2 Lighting."""
    import bpy

    with tempfile.TemporaryDirectory() as tmp:
        scene = scene_of(Path(tmp))
        assert bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="ALL") == {"FINISHED"}
        return render(scene, "BO2_LIGHTING"), scene


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", nargs="?", type=Path, default=ROOT / "docs" / "images")
    parser.add_argument("--before", type=Path, help="BO2's render by an earlier version (.npy)")
    parser.add_argument("--bo2-only", type=Path, metavar="NPY")
    args = parser.parse_args()
    ours, scene = bo2_render()
    if args.bo2_only:
        np.save(args.bo2_only, ours)
        return 0
    from bo2_lighting.addon.core import imaging

    cycles = render(scene, "CYCLES")
    floor = (slice(170, 230), slice(20, 120))  # open floor in front of the block, in view
    shown = [("before", np.load(args.before))] if args.before else []
    shown += [("BO2 Lighting, lightmaps", ours), ("Cycles", cycles)]
    pictures, labels = [], []
    for name, image in shown:
        pictures.append(np.clip(image, 0.0, 1.0) ** (1 / 2.2))
        labels.append((f"{name}: floor {image[floor].mean():.3f}", name))
    args.out.mkdir(parents=True, exist_ok=True)
    imaging.write_png(args.out / "lightmap_far_ground.png", imaging.panels(pictures, labels))
    print(f"wrote {args.out / 'lightmap_far_ground.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
