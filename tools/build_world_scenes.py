"""Build the scenes that measure the world as a light: its sun, its bounce and its cost.

Usage: python tools/build_world_scenes.py OUT_DIR [NAME ...]

Writes OUT_DIR/<name>.blend for each scene (all by default), to be measured against Cycles
with ``tools/measure_indirect.py`` and timed with ``tools/bench_render.py``:

- ``sky_sun``: a Sky Texture with its sun disc (elevation 35 degrees), no lamp: a 40 m ground,
  a box, a sphere and a low wall;
- ``sky_sun_evening``: the same kind built differently, a low sun (12 degrees) behind a row of
  pillars and an arch, a wide lens;
- ``hdri_sun``: pedestrian_overpass (its sun low in the sky) over a set of a platform, crates
  and a column;
- ``hdri_sun_venice``: venice_sunset over a stair of blocks and a bust-like stack of spheres;
- ``asset_set``: an asset set on a ground disc under royal_esplanade, no probes, seen from a
  low angle so that the objects' undersides show;
- ``asset_set_probes``: the same with a volume and a sphere probe placed as an artist would;
- ``heavy``: 125k triangles (subdivided spheres, a field of boxes) under three lamps and a
  colour world.

Run with a Python that has ``bpy`` and the add-on importable as ``bo2_lighting``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import bpy

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "demo_blends"))
from scene_kit import ball, camera, empty_scene, light, principled, probe, save, slab  # noqa: E402

ENVMAPS = ROOT.parent / "shared" / "reference" / "envmaps"


def _cycles(scene, samples=256):
    c = scene.cycles
    c.samples, c.max_bounces, c.diffuse_bounces, c.glossy_bounces = samples, 32, 32, 32


def _world_nodes(name):
    world = bpy.data.worlds.new(name)
    if world.node_tree is None:
        world.use_nodes = True
    bpy.context.scene.world = world
    return world, world.node_tree


def sky_world(elevation_deg, rotation_deg, strength=0.04):
    """A Sky Texture world (the version's default physical model, its sun disc on)."""
    world, tree = _world_nodes("Sky")
    node = tree.nodes.new("ShaderNodeTexSky")
    if bpy.app.version < (5, 0, 0):
        node.sky_type = "NISHITA"
    node.sun_elevation = math.radians(elevation_deg)
    node.sun_rotation = math.radians(rotation_deg)
    tree.links.new(node.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    tree.nodes["Background"].inputs["Strength"].default_value = strength
    return world


def hdri_world(name, rotation_deg=0.0, strength=1.0):
    """An Environment Texture world of ``ENVMAPS/<name>.hdr``, rotated about Z."""
    path = ENVMAPS / f"{name}.hdr"
    if not path.is_file():
        raise SystemExit(f"build_world_scenes: {path.name} is missing from the reference "
                         "environment maps (shared/reference/envmaps beside the project)")
    world, tree = _world_nodes(name)
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(str(path))
    coord = tree.nodes.new("ShaderNodeTexCoord")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value[2] = math.radians(rotation_deg)
    tree.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    tree.links.new(env.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    tree.nodes["Background"].inputs["Strength"].default_value = strength
    return world


def disc(name, radius, material, segments=64):
    """A flat ground disc at z = 0 (a thin cylinder)."""
    bpy.ops.mesh.primitive_cylinder_add(vertices=segments, radius=radius, depth=0.1,
                                        location=(0, 0, -0.05))
    obj = bpy.context.object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def build_sky_sun(out: Path):
    scene = empty_scene()
    _cycles(scene)
    ground = principled("Ground", (0.4, 0.38, 0.35), roughness=0.9)
    white = principled("White", (0.75, 0.75, 0.72), roughness=0.6)
    blue = principled("Blue", (0.1, 0.2, 0.6), roughness=0.3)
    slab("Ground", (-20, -20, -0.1), (20, 20, 0), ground)
    slab("Box", (0.3, -0.5, 0), (1.3, 0.5, 1.0), white)
    ball("Sphere", 0.5, (-1.0, 0.2, 0.5), blue)
    slab("Wall", (-2.0, 1.4, 0), (1.8, 1.6, 0.6), white)
    sky_world(35, 200)
    camera(35, (3.3, -4.4, 2.4), (66, 0, 37))
    save(out)


def build_sky_sun_evening(out: Path):
    scene = empty_scene((400, 300))
    _cycles(scene)
    ground = principled("Sand", (0.55, 0.45, 0.3), roughness=0.95)
    stone = principled("Stone", (0.6, 0.58, 0.55), roughness=0.7)
    slab("Ground", (-30, -30, -0.1), (30, 30, 0), ground)
    for k in range(5):
        slab(f"Pillar {k}", (-3 + 1.4 * k, 2.0, 0), (-2.6 + 1.4 * k, 2.4, 2.5), stone)
    slab("Lintel", (-3.2, 1.9, 2.5), (3.0, 2.5, 2.8), stone)
    slab("Block", (-0.8, -1.0, 0), (0.4, 0.2, 0.7), stone)
    sky_world(12, 20)
    camera(20, (6.5, -7.5, 2.0), (82, 0, 40))
    save(out)


def build_hdri_sun(out: Path):
    scene = empty_scene()
    _cycles(scene)
    concrete = principled("Concrete", (0.5, 0.5, 0.48), roughness=0.8)
    wood = principled("Wood", (0.45, 0.28, 0.14), roughness=0.6)
    metal = principled("Metal", (0.9, 0.85, 0.8), metallic=1.0, roughness=0.35)
    slab("Platform", (-6, -6, -0.2), (6, 6, 0), concrete)
    slab("Crate A", (-0.5, -0.5, 0), (0.5, 0.5, 1.0), wood)
    slab("Crate B", (0.7, -0.2, 0), (1.3, 0.4, 0.6), wood)
    slab("Column", (-2.0, 0.8, 0), (-1.6, 1.2, 2.4), concrete)
    ball("Ball", 0.35, (0.0, -1.5, 0.35), metal)
    hdri_world("pedestrian_overpass_1k", rotation_deg=0.0)
    camera(35, (3.5, -7.0, 2.8), (73, 0, 25))
    save(out)


def build_hdri_sun_venice(out: Path):
    scene = empty_scene((360, 360))
    _cycles(scene)
    marble = principled("Marble", (0.7, 0.68, 0.62), roughness=0.4)
    brick = principled("Brick", (0.5, 0.2, 0.12), roughness=0.8)
    slab("Floor", (-8, -8, -0.1), (8, 8, 0), marble)
    for k in range(4):  # side by side, not overlapping
        slab(f"Step {k}", (-1.5, -1.0 + 0.4 * k, 0), (1.5, -0.6 + 0.4 * k, 0.2 * (k + 1)),
             brick)
    for k, r in enumerate((0.5, 0.35, 0.22)):
        ball(f"Stack {k}", r, (2.2, -0.8, 0.8 + 0.75 * k), marble)
    slab("Plinth", (1.8, -1.2, 0), (2.6, -0.4, 0.3), brick)
    hdri_world("venice_sunset_1k", rotation_deg=150.0, strength=1.5)
    camera(28, (-4.0, -6.5, 2.4), (75, 0, -30))
    save(out)


def _asset_set(probes: bool, out: Path):
    scene = empty_scene()
    _cycles(scene)
    ground = principled("Ground", (0.6, 0.58, 0.55), roughness=0.85)
    red = principled("Red", (0.7, 0.12, 0.08), roughness=0.4)
    grey = principled("Grey", (0.5, 0.5, 0.5), roughness=0.5)
    gold = principled("Gold", (1.0, 0.76, 0.34), metallic=1.0, roughness=0.3)
    disc("Ground", 4.0, ground)
    ball("Ball", 0.5, (-0.9, 0.0, 0.8), red)
    slab("Shelf", (0.2, -0.6, 0.7), (1.6, 0.6, 0.8), grey)
    slab("Leg A", (0.3, -0.5, 0), (0.4, -0.4, 0.7), grey)
    slab("Leg B", (1.4, 0.4, 0), (1.5, 0.5, 0.7), grey)
    ball("Knob", 0.25, (0.9, 0.0, 1.05), gold)
    hdri_world("royal_esplanade_1k", rotation_deg=60.0)
    if probes:
        probe("VOLUME", "Volume", (0.2, 0.0, 0.9), scale=(2.4, 1.6, 1.0), resolution_x=6,
              resolution_y=5, resolution_z=4)
        probe("SPHERE", "Reflection", (0.3, 0.0, 0.9), influence_distance=3.0)
    camera(35, (2.6, -5.0, 0.7), (88, 0, 28))
    save(out)


def build_heavy(out: Path):
    scene = empty_scene((480, 270))
    _cycles(scene, 64)
    floor = principled("Floor", (0.4, 0.4, 0.4), roughness=0.7)
    mats = [principled(f"M{k}", c, roughness=0.4)
            for k, c in enumerate(((0.7, 0.2, 0.1), (0.2, 0.5, 0.7), (0.6, 0.6, 0.3)))]
    slab("Floor", (-12, -12, -0.1), (12, 12, 0), floor)
    for i in range(6):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=128, ring_count=82, radius=0.6,
                                             location=(-5 + 2 * i, 2.0, 0.6))
        obj = bpy.context.object
        obj.data.materials.append(mats[i % 3])
        bpy.ops.object.shade_smooth()
    for i in range(20):
        for j in range(12):
            slab(f"Box {i} {j}", (-8 + 0.8 * i, -6 + 0.6 * j, 0),
                 (-7.6 + 0.8 * i, -5.7 + 0.6 * j, 0.2 + 0.05 * ((i * 7 + j * 3) % 9)),
                 mats[(i + j) % 3])
    light("SUN", "Sun", (0, 0, 10), (math.radians(40), 0, math.radians(30)), energy=3.0)
    light("POINT", "Lamp", (2, -2, 3), (0, 0, 0), energy=400.0)
    light("SPOT", "Spot", (-4, -4, 5), (math.radians(35), 0, math.radians(-40)),
          energy=800.0)
    world, tree = _world_nodes("Colour")
    tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.4, 0.55, 1.0)
    camera(30, (0, -16, 9), (62, 0, 0))
    tris = sum(len(o.data.loop_triangles) or _count(o) for o in scene.objects
               if o.type == "MESH")
    print(f"heavy: {tris} triangles")
    save(out)


def _count(obj):
    obj.data.calc_loop_triangles()
    return len(obj.data.loop_triangles)


BUILDERS = {"sky_sun": build_sky_sun, "sky_sun_evening": build_sky_sun_evening,
            "hdri_sun": build_hdri_sun, "hdri_sun_venice": build_hdri_sun_venice,
            "asset_set": lambda out: _asset_set(False, out),
            "asset_set_probes": lambda out: _asset_set(True, out), "heavy": build_heavy}


def main() -> int:
    args = [a for a in sys.argv[1:] if not a.startswith("-")]
    if not args:
        print(__doc__)
        return 2
    out = Path(args[0])
    for name in args[1:] or BUILDERS:
        BUILDERS[name](out / f"{name}.blend")
    return 0


if __name__ == "__main__":
    sys.exit(main())
