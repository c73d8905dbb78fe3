"""Build ``artist_room.blend``: an interior set up as an artist sets one up, to measure the
indirect light on a room the probes were not fitted to (``tools/measure_indirect.py``).

A 6 x 5 x 3 m room with 20 cm walls, a 2 x 1.4 m window, a sun and a blue sky of strength
1.5, a pillar, a gold and a red sphere; one Sphere probe without custom parallax; a 6 x 5 x 3
Volume probe whose box stops 10 cm short of the walls, floor and ceiling, its Distance left at
Blender's default. Unlike ``closed_room.blend``, nothing is fitted to the walls.

Run with a Python that has ``bpy``:  python demo_blends/build_artist_room.py [OUT.blend]
"""

import math
import sys
from pathlib import Path

import bpy
from scene_kit import (
    ball,
    camera,
    closed_room,
    empty_scene,
    light,
    principled,
    probe,
    save,
    sky,
    slab,
)

HERE = Path(__file__).resolve().parent
WALL = 0.2
ROOM = (6.0, 5.0, 3.0)
WINDOW = (-1.0, 1.0, 0.9, 2.3)  # 2 m wide, 1.4 m high, in the left wall
GAP = 0.1  # the volume's box short of each wall


def build(out: Path) -> None:
    scene = empty_scene()
    c = scene.cycles
    c.samples, c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 256, 32, 32, 32

    wall = principled("Plaster", (0.8, 0.78, 0.74), roughness=0.9)
    floor = principled("Oak", (0.5, 0.36, 0.24), roughness=0.5)
    gold = principled("Gold", (1.0, 0.766, 0.336), metallic=1.0, roughness=0.3)
    gold.pass_index = 1
    red = principled("Red", (0.75, 0.08, 0.05), roughness=0.35)
    x, y, z = ROOM[0] / 2, ROOM[1] / 2, ROOM[2]
    closed_room((-x, -y, 0.0), (x, y, z), wall, WALL, WINDOW)
    bpy.data.objects["Floor"].data.materials[0] = floor
    slab("Pillar", (-0.4, 1.2, 0.0), (0.0, 1.6, z), wall)
    ball("Gold sphere", 0.4, (0.8, -0.5, 0.4), gold)
    ball("Red sphere", 0.35, (-1.4, -0.8, 0.35), red)

    light("SUN", "Sun", (-6, 0, 5), (math.radians(50), 0, math.radians(-80)), energy=4.0,
          angle=math.radians(0.5))
    world = sky((0.3, 0.5, 1.0))
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.5

    probe("SPHERE", "Reflection", (0.0, 0.0, 1.4), influence_distance=4.0)
    probe("VOLUME", "Irradiance", (0.0, 0.0, z / 2),
          scale=(x - GAP, y - GAP, z / 2 - GAP),
          resolution_x=6, resolution_y=5, resolution_z=3)
    scene.bo2.probes.volume_face_size = "16"

    camera(18, (2.6, -2.1, 1.5), (80, 0, 55))
    save(out)


if __name__ == "__main__":
    build(Path(sys.argv[-1]) if sys.argv[-1].endswith(".blend")
          else HERE / "artist_room.blend")
