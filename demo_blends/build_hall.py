"""Build ``hall.blend``: an L-shaped hall lit by the sun through a window (docs/probes.md).

An indirect-light test room built unlike the others: two arms of 3 m wide meeting at a corner
(8 x 3 m and 3 x 6 m more, 3.5 m high, 20 cm thick walls), one tall window in the long arm's
outer wall with the sun falling through it onto the floor, a sky, no lamp; a steel sphere and
a copper column in the far arm, which the sun never reaches, a bench and a low wall. Probes as
an artist places them: one Volume light probe per arm, each a little larger than its arm, at
Blender's default resolution of 4 x 4 x 4 and Distance, overlapping at the corner, and one
Sphere light probe per arm at eye height with Blender's default influence. The metals'
materials have a Metallic of 1 (``tools/measure_indirect.py`` picks them by it).

Run with a Python that has ``bpy``:  python demo_blends/build_hall.py [OUT.blend]
"""

import math
import sys
from pathlib import Path

import bpy
from scene_kit import ball, camera, empty_scene, light, principled, probe, save, sky, slab

HERE = Path(__file__).resolve().parent
T = 0.2  # wall thickness, metres
H = 3.5  # height
# inside: the long arm x 0..8, y 0..3; the far arm x 5..8, y 3..9
WINDOW = (2.0, 3.6, 0.6, 2.9)  # in the long arm's wall at y = 0: x0, x1, z0, z1


def build(out: Path) -> None:
    scene = empty_scene()
    c = scene.cycles  # full global illumination
    c.samples, c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 256, 32, 32, 32

    wall = principled("Plaster", (0.7, 0.68, 0.62), roughness=0.9)
    floor = principled("Stone floor", (0.35, 0.33, 0.3), roughness=0.5)
    wood = principled("Oak", (0.42, 0.25, 0.12), roughness=0.55)
    steel = principled("Steel", (0.56, 0.57, 0.58), metallic=1.0, roughness=0.3)
    copper = principled("Copper", (0.95, 0.64, 0.54), metallic=1.0, roughness=0.4)

    # floor and ceiling: the two arms' rectangles
    for name, z0, z1, mat in (("Floor", -T, 0.0, floor), ("Ceiling", H, H + T, wall)):
        slab(f"{name} long", (-T, -T, z0), (8.0 + T, 3.0, z1), mat)
        slab(f"{name} far", (5.0 - T, 3.0, z0), (8.0 + T, 9.0 + T, z1), mat)
    # the outline of the L, the window in the long arm's wall at y = 0
    x0, x1, z0, z1 = WINDOW
    slab("Wall south 1", (-T, -T, 0.0), (x0, 0.0, H), wall)
    slab("Wall south 2", (x1, -T, 0.0), (8.0 + T, 0.0, H), wall)
    slab("Wall south sill", (x0, -T, 0.0), (x1, 0.0, z0), wall)
    slab("Wall south lintel", (x0, -T, z1), (x1, 0.0, H), wall)
    slab("Wall west", (-T, 0.0, 0.0), (0.0, 3.0, H), wall)
    slab("Wall north", (-T, 3.0, 0.0), (5.0, 3.0 + T, H), wall)
    slab("Wall inner", (5.0 - T, 3.0 + T, 0.0), (5.0, 9.0, H), wall)
    slab("Wall far", (5.0 - T, 9.0, 0.0), (8.0 + T, 9.0 + T, H), wall)
    slab("Wall east", (8.0, 0.0, 0.0), (8.0 + T, 9.0, H), wall)

    slab("Bench", (0.8, 2.3, 0.0), (3.8, 2.8, 0.45), wood)
    slab("Low wall", (5.6, 5.0, 0.0), (7.4, 5.25, 1.1), wall)
    ball("Steel sphere", 0.5, (6.2, 7.2, 0.5), steel)
    bpy.ops.mesh.primitive_cylinder_add(vertices=48, radius=0.3, depth=2.2,
                                        location=(7.3, 3.8, 1.1))
    column = bpy.context.object
    column.name = "Copper column"
    bpy.ops.object.shade_smooth()
    column.data.materials.append(copper)

    # the sun from the south, low enough to fall through the window onto the floor
    light("SUN", "Sun", (3, -6, 6), (math.radians(50), 0, math.radians(8)), energy=4.0,
          angle=math.radians(0.8), color=(1.0, 0.95, 0.86))
    sky((0.3, 0.45, 0.85))

    probe("VOLUME", "Long arm irradiance", (4.0, 1.5, H / 2), scale=(4.3, 1.7, 1.9))
    probe("VOLUME", "Far arm irradiance", (6.5, 6.0, H / 2), scale=(1.7, 3.3, 1.9))
    probe("SPHERE", "Long arm reflection", (3.0, 1.5, 1.7))
    probe("SPHERE", "Far arm reflection", (6.5, 6.5, 1.7))

    camera(16, (0.3, 1.1, 1.8), (80, 0, -80))
    save(out)


if __name__ == "__main__":
    build(Path(sys.argv[-1]) if sys.argv[-1].endswith(".blend") else HERE / "hall.blend")
