"""Build ``outdoor.blend``: objects on open ground under a sun and a blue sky, no light probes,
to measure the world's light where nothing but the objects themselves occludes it (the ground
under them darkens) against Cycles (``tools/measure_indirect.py``).

A 30 x 30 m ground, a sphere resting on it, a cube, a low bench (a slab on two legs) and a
thin pole; a sun low in the west; a uniform sky of strength 1.

Run with a Python that has ``bpy``:  python demo_blends/build_outdoor.py [OUT.blend]
"""

import math
import sys
from pathlib import Path

from scene_kit import ball, camera, empty_scene, light, principled, save, sky, slab

HERE = Path(__file__).resolve().parent


def build(out: Path) -> None:
    scene = empty_scene()
    c = scene.cycles
    c.samples, c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 256, 32, 32, 32

    ground = principled("Ground", (0.45, 0.42, 0.38), roughness=0.9)
    stone = principled("Stone", (0.7, 0.7, 0.68), roughness=0.7)
    red = principled("Red", (0.75, 0.1, 0.06), roughness=0.4)
    slab("Ground", (-15.0, -15.0, -0.1), (15.0, 15.0, 0.0), ground)
    ball("Sphere", 0.6, (-1.2, 0.4, 0.6), red)
    slab("Cube", (0.6, -0.2, 0.0), (1.6, 0.8, 1.0), stone)
    slab("Bench top", (-0.8, -1.6, 0.45), (1.0, -1.1, 0.55), stone)
    slab("Bench leg L", (-0.7, -1.55, 0.0), (-0.55, -1.15, 0.45), stone)
    slab("Bench leg R", (0.75, -1.55, 0.0), (0.9, -1.15, 0.45), stone)
    slab("Pole", (2.4, 1.4, 0.0), (2.5, 1.5, 2.5), stone)

    light("SUN", "Sun", (0, 0, 10), (math.radians(60), 0, math.radians(-70)), energy=3.0,
          angle=math.radians(2.0))
    sky((0.35, 0.55, 1.0))

    camera(30, (5.5, -6.5, 3.6), (66, 0, 40))
    save(out)


if __name__ == "__main__":
    build(Path(sys.argv[-1]) if sys.argv[-1].endswith(".blend") else HERE / "outdoor.blend")
