"""Build ``closed_room.blend``: the indirect-light test room (docs/probes.md).

A closed room of 6 x 5 x 3 m with 20 cm thick walls, floor and ceiling (so that volume samples
near them see real geometry), a window in the left wall with the sun and the sky shining
through it, a ceiling lamp, a pillar that three volume samples fall inside, a gold sphere and a
red sphere. One Sphere light probe in the middle, its reflections corrected to the room's box
(custom parallax), and a 6 x 5 x 3 Volume light probe filling the room. The metals' materials
have Pass Index 1, so that a comparison can pick their pixels from the Material Index pass.

Run with a Python that has ``bpy``:  python demo_blends/build_closed_room.py [OUT.blend]
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
WALL = 0.2  # thickness, metres
ROOM = (6.0, 5.0, 3.0)  # inside, metres: x from -3 to 3, y from -2.5 to 2.5, z from 0 to 3
WINDOW = (-1.0, 1.0, 1.0, 2.2)  # in the left wall: y0, y1, z0, z1


def build(out: Path) -> None:
    scene = empty_scene()
    c = scene.cycles  # full global illumination
    c.samples, c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 256, 32, 32, 32

    wall = principled("Wall", (0.75, 0.75, 0.72), roughness=0.8)
    floor = principled("Floor", (0.45, 0.32, 0.22), roughness=0.6)
    pillar = principled("Pillar", (0.6, 0.6, 0.6), roughness=0.7)
    gold = principled("Gold", (1.0, 0.766, 0.336), metallic=1.0, roughness=0.25)
    gold.pass_index = 1
    red = principled("Red", (0.7, 0.05, 0.04), roughness=0.4)

    x, y, z = ROOM[0] / 2, ROOM[1] / 2, ROOM[2]
    closed_room((-x, -y, 0.0), (x, y, z), wall, WALL, WINDOW)
    bpy.data.objects["Floor"].data.materials[0] = floor
    slab("Pillar", (1.2, 0.7, 0.0), (1.8, 1.3, z), pillar)  # holds the samples at x 1.5, y 1
    ball("Gold sphere", 0.45, (0.2, -0.9, 0.45), gold)
    ball("Red sphere", 0.4, (-1.2, 0.6, 0.4), red)

    light("SUN", "Sun", (-6, 0, 5), (math.radians(55), 0, math.radians(-90)), energy=5.0,
          angle=math.radians(1.0), color=(1.0, 0.93, 0.82))
    light("POINT", "Lamp", (1.0, -1.2, 2.7), (0, 0, 0), energy=150.0, shadow_soft_size=0.1)
    sky((0.35, 0.5, 0.9))

    refl = probe("SPHERE", "Room reflection", (0.0, 0.0, 1.5), scale=(x, y, z / 2),
                 influence_distance=6.0, falloff=0.2)
    refl.data.use_custom_parallax = True
    refl.data.parallax_type = "BOX"
    refl.data.parallax_distance = 1.0  # the object's unit box: the room
    probe("VOLUME", "Room irradiance", (0.0, 0.0, z / 2), scale=(x, y, z / 2),
          resolution_x=6, resolution_y=5, resolution_z=3, influence_distance=0.2)
    scene.bo2.probes.volume_face_size = "16"
    scene.bo2.probes.bounces = 3

    camera(16, (2.7, -2.2, 1.6), (82, 0, 62))
    save(out)


if __name__ == "__main__":
    build(Path(sys.argv[-1]) if sys.argv[-1].endswith(".blend")
          else HERE / "closed_room.blend")
