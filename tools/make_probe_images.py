"""Pictures of the light probes for docs/probes.md, rendered here with both engines.

Usage: python tools/make_probe_images.py [--size 240]

Builds a small open room (a floor, a red and a white wall, a chrome ball, a glossy blue ball)
lit by a low sun and a dim sky, with one reflection probe and a 4 x 4 x 2 irradiance volume;
bakes the probes with BO2 Lighting and writes, through the Standard view transform:

- docs/images/probes_indirect.png: direct light only | + the world | + the baked probes |
  Cycles (4 bounces), with the mean absolute difference of each BO2 image from Cycles;
- docs/images/probes_normalization.png: environment map normalization None | BO1 average
  irradiance | BO2 directional irradiance, and BO1 angular Gaussian prefiltering.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

import bo2_lighting
from bo2_lighting.addon.blender import images as blender_images

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images"
sys.path.insert(0, str(ROOT / "demo_blends"))
from scene_kit import light, principled, probe, sky  # noqa: E402  (the demo scenes' helpers)


def build(folder: Path, size: int):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = size, size * 3 // 4
    scene.view_settings.view_transform = "Standard"
    sky((0.25, 0.3, 0.4))
    for size_m, loc, rot, mat in [
        (8, (0, 0, 0), (0, 0, 0), principled("Floor", (0.6, 0.6, 0.6), roughness=0.35)),
        (8, (0, 2.5, 2), (math.pi / 2, 0, 0), principled("Red", (0.8, 0.08, 0.05), roughness=0.6)),
        (8, (-2.5, 0, 2), (0, math.pi / 2, 0), principled("White", (0.8, 0.8, 0.8), roughness=0.6)),
    ]:
        bpy.ops.mesh.primitive_plane_add(size=size_m, location=loc, rotation=rot)
        bpy.context.object.data.materials.append(mat)
    for loc, mat in [((0.2, 0.6, 0.6), principled("Chrome", (0.95, 0.95, 0.95), 1.0, 0.1)),
                     ((-1.2, -0.3, 0.45), principled("Blue", (0.1, 0.2, 0.7), 0.0, 0.25))]:
        bpy.ops.mesh.primitive_uv_sphere_add(radius=loc[2], location=loc, segments=64,
                                             ring_count=32)
        bpy.ops.object.shade_smooth()
        bpy.context.object.data.materials.append(mat)
    light("SUN", "Sun", (0, 0, 5), (math.radians(55), 0, math.radians(25)), energy=4.0,
          angle=math.radians(2))
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (2.6, -4.2, 2.4), (math.radians(68), 0, math.radians(30))
    scene.collection.objects.link(cam)
    scene.camera = cam
    probe("SPHERE", "Reflection", (0, 0, 1.0), influence_distance=6.0)
    probe("VOLUME", "Irradiance", (0, 0, 1.2), scale=(2.4, 2.4, 1.2), resolution_x=4,
          resolution_y=4, resolution_z=2, influence_distance=1.0)
    scene.cycles.device, scene.cycles.use_denoising = "CPU", False
    scene.cycles.max_bounces = 4
    scene.bo2.probes.bounces = 2  # the second bounce brings the sky onto the walls
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / "probes.blend"))
    return scene


def render(scene, engine: str, samples: int) -> np.ndarray:
    """(H, W, 3) scene-linear pixels, row 0 at the top."""
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.samples = samples
    else:
        scene.bo2.samples = samples
    bpy.ops.render.render()
    return blender_images.render_result_pixels(scene)[..., :3]


def save_row(scene, images: list[np.ndarray], path: Path) -> None:
    """Side by side, through the scene's view transform, as PNG."""
    blender_images.save_pixels(scene, np.concatenate(images, 1), path, "PNG", "8", "RGB")
    print(f"wrote {path.relative_to(OUT.parents[1])}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=240, help="image width in pixels")
    args = parser.parse_args()
    bo2_lighting.register()
    with tempfile.TemporaryDirectory() as tmp:
        scene = build(Path(tmp), args.size)
        cycles = render(scene, "CYCLES", 256)
        scene.bo2.indirect.use = False
        direct = render(scene, "BO2_LIGHTING", 8)
        scene.bo2.indirect.use = True
        world = render(scene, "BO2_LIGHTING", 8)
        assert bpy.ops.bo2.bake_probes() == {"FINISHED"}
        baked = render(scene, "BO2_LIGHTING", 8)
        for name, img in (("direct only", direct), ("+ world", world), ("+ probes", baked)):
            print(f"{name:12s} mean |BO2 - Cycles| = {np.abs(img - cycles).mean():.4f}")
        save_row(scene, [direct, world, baked, cycles], OUT / "probes_indirect.png")
        rows = []
        for norm, pre in (("none", "bo2"), ("bo1", "bo2"), ("bo2", "bo2"), ("bo2", "bo1")):
            scene.bo2.indirect.normalization, scene.bo2.indirect.prefilter = norm, pre
            rows.append(render(scene, "BO2_LIGHTING", 8))
        save_row(scene, rows, OUT / "probes_normalization.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
