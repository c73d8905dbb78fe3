"""Build ``old_vs_new.blend``: a scene for the talk's old-versus-new comparisons.

A row of spheres of rising gloss (dielectric in front, metal behind) on a glossy floor; a tall
wall casts the sun's shadow over the right half of the row. One reflection probe is captured in
the sun, so the shadowed spheres show how each environment map normalization fits its
reflections to their darker lighting (slides "Environment map normalization: old method / new
method"); the irradiance volume gives every sphere its own lighting. The same scene also shows
prefiltering (angular Gaussian against cosine power), the environment BRDF (BO1 against BO2)
and the optimized direct terms against the exact ones. ``tools/demo.py`` renders the pairs.

Run with a Python that has ``bpy``:  python demo_blends/build_old_vs_new.py [OUT.blend]
"""

import math
import sys
from pathlib import Path

import bpy
from scene_kit import bo2_material, camera, empty_scene, light, probe, sky

HERE = Path(__file__).resolve().parent
GLOSS = [0.3, 0.5, 0.7, 0.9]


def build(out: Path) -> None:
    scene = empty_scene()
    scene.cycles.samples = 64

    for i, gloss in enumerate(GLOSS * 2):
        metal = i >= len(GLOSS)
        mat = bo2_material(f"{'Metal' if metal else 'Dielectric'} {gloss}",
                           (0.0, 0.0, 0.0) if metal else (0.55, 0.2, 0.1),
                           (0.95, 0.64, 0.54) if metal else (0.04, 0.04, 0.04), gloss)
        x = -2.1 + 1.4 * (i % len(GLOSS))
        bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.5,
                                             location=(x, 1.3 if metal else 0.0, 0.5))
        bpy.ops.object.shade_smooth()
        bpy.context.object.data.materials.append(mat)
    bpy.ops.mesh.primitive_plane_add(size=14)
    bpy.context.object.data.materials.append(
        bo2_material("Glossy floor", (0.35, 0.35, 0.35), (0.04, 0.04, 0.04), 0.75))
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.9, 3.2, 2.0))
    wall = bpy.context.object
    wall.scale = (4.0, 0.2, 4.0)
    wall.data.materials.append(bo2_material("Wall", (0.7, 0.7, 0.7), (0.04, 0.04, 0.04), 0.2))

    light("SUN", "Sun", (0, 0, 5), (math.radians(50), 0, math.radians(200)),  # behind the wall
          energy=3.0, angle=math.radians(1.5))
    sky((0.3, 0.4, 0.6))
    probe("SPHERE", "Reflection", (-1.4, 0.6, 1.0), influence_distance=10.0,
          use_custom_parallax=True, parallax_distance=1.0e4)  # the sky: no room to correct to
    probe("VOLUME", "Irradiance", (0.0, 0.7, 1.0), scale=(3.5, 2.0, 1.0), resolution_x=8,
          resolution_y=4, resolution_z=2, influence_distance=1.0)
    scene.bo2.probes.volume_face_size = "16"

    camera(35, (0.0, -5.5, 2.2), (72, 0, 0))
    bpy.ops.wm.save_as_mainfile(filepath=str(out), compress=True)


if __name__ == "__main__":
    build(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "old_vs_new.blend")
