"""Build ``office.blend``: a small office lit by a desk lamp, full of objects (docs/probes.md).

An indirect-light test room built unlike the others: 4 x 3.2 m, 2.6 m high, 15 cm walls, a
small window behind the desk with an overcast sky, a desk lamp (a spot light just under a
brass shade, 36 cm above the desk) as the main light and a weak ceiling light; a desk, a
chair, two shelves of books, boxes and a cabinet (about 90 objects), a chrome mug and the
brass lamp shade as metals. Probes as an
artist places them: one Volume light probe scaled roughly to the room (a little beyond the
walls, not aligned to them) at 5 x 4 x 3, and one Sphere light probe above the desk with its
default influence. The metals' materials have a Metallic of 1 (``tools/measure_indirect.py``
picks them by it).

Run with a Python that has ``bpy``:  python demo_blends/build_office.py [OUT.blend]
"""

import math
import random
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
ROOM = (4.0, 3.2, 2.6)  # inside: x -2..2, y -1.6..1.6, z 0..2.6
WINDOW = (-0.5, 0.5, 1.1, 1.9)  # in the wall at x = -2: y0, y1, z0, z1
BOOK_COLOURS = ((0.5, 0.08, 0.06), (0.08, 0.2, 0.45), (0.12, 0.35, 0.12), (0.6, 0.5, 0.3),
                (0.15, 0.15, 0.15), (0.7, 0.65, 0.55))


def build(out: Path) -> None:
    scene = empty_scene()
    c = scene.cycles  # full global illumination
    c.samples, c.max_bounces, c.diffuse_bounces, c.glossy_bounces = 256, 32, 32, 32
    rng = random.Random(7)

    wall = principled("Wall paint", (0.62, 0.66, 0.6), roughness=0.85)
    carpet = principled("Carpet", (0.25, 0.22, 0.3), roughness=1.0)
    desk_top = principled("Desk", (0.55, 0.4, 0.25), roughness=0.4)
    grey = principled("Grey metal", (0.3, 0.3, 0.32), roughness=0.6)
    chrome = principled("Chrome", (0.8, 0.8, 0.8), metallic=1.0, roughness=0.12)
    brass = principled("Brass", (0.91, 0.78, 0.42), metallic=1.0, roughness=0.35)
    books = [principled(f"Book {k}", colour, roughness=0.7)
             for k, colour in enumerate(BOOK_COLOURS)]

    x, y, z = ROOM[0] / 2, ROOM[1] / 2, ROOM[2]
    closed_room((-x, -y, 0.0), (x, y, z), wall, 0.15, WINDOW)
    bpy.data.objects["Floor"].data.materials[0] = carpet

    # the desk under the window, a chair, a cabinet
    slab("Desk top", (-2.0, -0.8, 0.72), (-1.3, 0.8, 0.76), desk_top)
    for k, (dx, dy) in enumerate(((-1.95, -0.75), (-1.95, 0.7), (-1.4, -0.75), (-1.4, 0.7))):
        slab(f"Desk leg {k}", (dx, dy, 0.0), (dx + 0.05, dy + 0.05, 0.72), grey)
    slab("Chair seat", (-1.15, -0.25, 0.45), (-0.7, 0.25, 0.5), grey)
    slab("Chair back", (-0.75, -0.25, 0.5), (-0.7, 0.25, 1.0), grey)
    slab("Chair post", (-0.95, -0.03, 0.0), (-0.9, 0.03, 0.45), grey)
    slab("Cabinet", (1.4, -1.6, 0.0), (2.0, -0.9, 1.2), grey)
    slab("Monitor", (-1.95, -0.3, 0.9), (-1.9, 0.3, 1.25), grey)
    slab("Monitor stand", (-1.95, -0.05, 0.76), (-1.9, 0.05, 0.9), grey)

    # two shelves along the back wall, full of books and a few boxes
    for level, top in enumerate((0.9, 1.6)):
        slab(f"Shelf {level}", (-0.6, 1.3, top - 0.03), (1.8, 1.6, top), desk_top)
        at = -0.58
        while at < 1.7:
            w = rng.uniform(0.03, 0.07)
            h = rng.uniform(0.2, 0.32)
            if rng.random() < 0.12:  # a box instead of a book
                w, h = rng.uniform(0.15, 0.25), rng.uniform(0.12, 0.2)
            slab(f"Book {level}.{int((at + 0.6) * 100)}", (at, 1.32, top),
                 (at + w, 1.32 + rng.uniform(0.18, 0.26), top + h), rng.choice(books))
            at += w + rng.uniform(0.0, 0.01)
    for k in range(6):  # boxes on the floor
        bx, by = rng.uniform(0.2, 1.2), rng.uniform(-1.5, -0.8)
        s = rng.uniform(0.2, 0.4)
        slab(f"Box {k}", (bx, by, 0.0), (bx + s, by + s * 0.8, s * 0.7), rng.choice(books))

    # the metals: a chrome mug on the desk, the lamp's brass shade
    ball("Chrome mug", 0.06, (-1.55, -0.45, 0.82), chrome)
    bpy.ops.mesh.primitive_cone_add(vertices=48, radius1=0.14, radius2=0.05, depth=0.16,
                                    location=(-1.6, 0.4, 1.22))
    shade = bpy.context.object
    shade.name = "Lamp shade"
    bpy.ops.object.shade_smooth()
    shade.data.materials.append(brass)
    slab("Lamp arm", (-1.77, 0.38, 0.76), (-1.73, 0.42, 1.24), grey)  # beside the light

    # the desk lamp just under its shade, pointing down; a weak ceiling light; an overcast sky
    light("SPOT", "Desk lamp", (-1.6, 0.4, 1.12), (0, 0, 0), energy=100.0,
          spot_size=math.radians(110), spot_blend=0.4, shadow_soft_size=0.03,
          color=(1.0, 0.85, 0.65))
    light("AREA", "Ceiling light", (0.4, 0.0, 2.58), (0, 0, 0), energy=30.0, size=0.6)
    sky((0.5, 0.55, 0.62))

    probe("VOLUME", "Office irradiance", (0.05, 0.02, 1.3), scale=(2.15, 1.7, 1.4),
          resolution_x=5, resolution_y=4, resolution_z=3)
    probe("SPHERE", "Desk reflection", (-1.2, 0.0, 1.2))

    camera(20, (1.8, -1.3, 1.55), (80, 0, 60))
    save(out)


if __name__ == "__main__":
    build(Path(sys.argv[-1]) if sys.argv[-1].endswith(".blend") else HERE / "office.blend")
