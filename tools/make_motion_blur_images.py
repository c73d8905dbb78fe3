"""Pictures of motion blur in docs/user_guide.md, rendered in Blender (the ``bpy`` module).

Usage: python tools/make_motion_blur_images.py [OUT_DIR]   (default docs/images)

``motion_blur.png``: a ball moving 2.5 m per frame and a cube turning 90 degrees per frame
under a sun, Shutter 0.5 at Position Center; BO2 Lighting (32 samples, direct light) beside
Cycles (128 samples, no bounce). Prints the PSNR between them.

``rolling_shutter.png``: a row of poles seen by a camera that pans 3 m per frame, Shutter 0.5,
Rolling Shutter Top-Bottom with Duration 0.1: the poles lean as the rows are read one after
the other; BO2 beside Cycles, likewise.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
W, H = 480, 292
sys.path.insert(0, str(ROOT / "demo_blends"))


def build():
    import bpy
    from scene_kit import camera, empty_scene, light, principled, sky

    scene = empty_scene((W, H))
    sky((0.05, 0.05, 0.06))
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    bpy.ops.mesh.primitive_plane_add(size=30.0)
    bpy.context.object.data.materials.append(principled("Floor", (0.8, 0.8, 0.8),
                                                        roughness=0.6))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(0.0, 0.0, 1.1), segments=48,
                                         ring_count=24)
    ball = bpy.context.object
    bpy.ops.object.shade_smooth()
    ball.data.materials.append(principled("Ball", (0.9, 0.35, 0.1), roughness=0.6))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(2.2, 1.2, 0.5))
    cube = bpy.context.object
    cube.data.materials.append(principled("Cube", (0.1, 0.35, 0.9), roughness=0.6))
    for frame, x, angle in ((1, -2.5, 0.0), (3, 2.5, math.pi)):
        ball.location.x = x
        ball.keyframe_insert("location", index=0, frame=frame)
        cube.rotation_euler.z = angle
        cube.keyframe_insert("rotation_euler", index=2, frame=frame)
    light("SUN", "Sun", (0.0, 0.0, 5.0), (math.radians(35.0), 0.0, math.radians(-20.0)),
          energy=3.0, angle=math.radians(2.0))
    camera(50.0, (0.0, -9.0, 5.0), (62.0, 0.0, 0.0))
    scene.frame_set(2)
    return scene


def build_rolling():
    import bpy
    from scene_kit import camera, empty_scene, light, principled, sky, slab

    scene = empty_scene((W, H))
    sky((0.05, 0.05, 0.06))
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5
    scene.cycles.rolling_shutter_type = "TOP"
    scene.cycles.rolling_shutter_duration = 0.1
    bpy.context.preferences.edit.keyframe_new_interpolation_type = "LINEAR"
    bpy.ops.mesh.primitive_plane_add(size=40.0)
    bpy.context.object.data.materials.append(principled("Ground", (0.6, 0.6, 0.6),
                                                        roughness=0.7))
    pole = principled("Pole", (0.9, 0.5, 0.1), roughness=0.5)
    for k in range(9):
        x = -8.0 + 2.0 * k
        slab(f"Pole {k}", (x - 0.15, -0.15, 0.0), (x + 0.15, 0.15, 4.0), pole)
    light("SUN", "Sun", (0.0, 0.0, 5.0), (math.radians(40.0), 0.0, math.radians(30.0)),
          energy=3.0, angle=math.radians(2.0))
    cam = camera(35.0, (0.0, -10.0, 2.0), (90.0, 0.0, 0.0))
    for frame, x in ((1, -3.0), (3, 3.0)):
        cam.location.x = x
        cam.keyframe_insert("location", index=0, frame=frame)
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
    return images.render_result_pixels(scene)[..., :3]  # row 0 at the top


def main() -> int:
    from bo2_lighting.addon.core.review import compare, imaging

    out = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    for name, make in (("motion_blur.png", build), ("rolling_shutter.png", build_rolling)):
        scene = make()
        ours, cycles = render(scene, "BO2_LIGHTING", 32), render(scene, "CYCLES", 128)
        shown = [np.clip(im, 0.0, 1.0) ** (1 / 2.2) for im in (ours, cycles)]
        print(f"{name}: PSNR BO2 against Cycles {compare.psnr(shown[0], shown[1]):.2f} dB")
        imaging.write_png(out / name, imaging.panels(
            shown, [("BO2 Lighting, 32 samples", "BO2"),
                    ("Cycles, 128 samples (direct light)", "Cycles")]))
        print(f"wrote {out / name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
