"""Render imported glTF assets with BO2 Lighting beside Cycles (docs/images/gltf_assets.png).

Usage: python tools/make_asset_images.py ASSET.glb [ASSET.glb ...] [-o PNG] [--size WxH]

Each asset is imported with Blender's own glTF importer into an empty scene, framed by a camera
and lit by one sun from over the camera's shoulder (``stage``), and rendered by both engines,
direct light only (Cycles with no bounces, 64 samples; BO2 Lighting 16 samples). One row per
asset: BO2 Lighting on the left, Cycles on the right, through the Standard view transform.
Prints each pair's mean absolute difference.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np


def stage(scene, width: int, height: int, distance: float = 1.9) -> None:
    """The comparison set-up: the scene's own lights removed and one sun added, a black world,
    a camera framing every visible mesh at ``distance`` times their bounding radius (the sun
    shines from over its shoulder), direct light only in Cycles."""
    import bpy
    import mathutils

    for obj in list(scene.objects):
        if obj.type == "LIGHT":
            bpy.data.objects.remove(obj)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.data.angle = math.radians(2.0)
    sun.rotation_euler = (math.radians(35), 0.0, math.radians(20))
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("Black")
    world.color = (0.0, 0.0, 0.0)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.cycles.max_bounces = 0
    scene.cycles.transparent_max_bounces = 8
    meshes = [o for o in scene.objects if o.type == "MESH" and o.visible_get()]
    if not meshes:
        return
    pts = [o.matrix_world @ mathutils.Vector(c) for o in meshes for c in o.bound_box]
    lo = mathutils.Vector([min(p[i] for p in pts) for i in range(3)])
    hi = mathutils.Vector([max(p[i] for p in pts) for i in range(3)])
    centre, radius = (lo + hi) / 2, (hi - lo).length / 2
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = centre + mathutils.Vector((0.5, -0.8, 0.6)).normalized() * radius * distance
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun.rotation_euler = (cam.rotation_euler.x - 0.35, cam.rotation_euler.y,
                          cam.rotation_euler.z + 0.3)


def render(scene, engine: str, samples: int) -> np.ndarray:
    """(H, W, 3) scene-linear Combined of one render, row 0 at the top."""
    import bpy

    from bo2_lighting.addon.blender import images

    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.samples, scene.cycles.device = samples, "CPU"
        scene.cycles.use_denoising = False
    else:
        scene.bo2.samples = samples
    bpy.ops.render.render()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "render.exr"
        images.save_render_result(scene, path, "OPEN_EXR", "32", "RGBA")
        return images.read_file(path)[..., :3]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("assets", nargs="+", type=Path)
    parser.add_argument("-o", "--output", type=Path,
                        default=Path(__file__).resolve().parent.parent / "docs" / "images"
                        / "gltf_assets.png")
    parser.add_argument("--size", default="320x240")
    parser.add_argument("--distance", type=float, default=2.4,
                        help="camera distance in bounding radii")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.lower().split("x"))

    import bpy

    import bo2_lighting
    from bo2_lighting.addon.blender import images
    from bo2_lighting.addon.core.review import imaging

    rows = []
    for asset in args.assets:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bo2_lighting.register()
        bpy.ops.import_scene.gltf(filepath=str(asset))
        scene = bpy.context.scene
        stage(scene, width, height, args.distance)
        ours, cycles = render(scene, "BO2_LIGHTING", 16), render(scene, "CYCLES", 64)
        print(f"{asset.name}: mean |BO2 - Cycles| {np.abs(ours - cycles).mean():.4f}")
        left, right = images.to_display(scene, [ours, cycles])
        rows.append(imaging.side_by_side(left, right, (
            (f"BO2 Lighting: {asset.stem}", "BO2 Lighting"), (f"Cycles: {asset.stem}", "Cycles"))))
        bo2_lighting.unregister()
    imaging.write_png(args.output, np.concatenate(rows))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
