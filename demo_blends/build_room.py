"""Build ``room.blend``: a closed room lit by a point light, a spot and a sun through a window,
with an irradiance volume and two reflection probes; more than 100k triangles.

The room (6 x 5 x 3 m) has a window in its left wall; the sun shines through it onto the floor.
Furniture-like shapes: a table with four legs, two chairs, a shelf with vases and bowls (smooth
spheres and cylinders), a sofa, a rug, a glossy metal sculpture (a subdivided Suzanne) and a
chrome ball. Principled BSDF materials. Light probes: a Volume probe filling the room (5 x 4 x 3
samples) and Sphere probes over the table and in front of the shelf.

Run with a Python that has ``bpy``:  python demo_blends/build_room.py [OUT.blend]
"""

import math
import sys
from pathlib import Path

import bpy
from scene_kit import light, principled, probe, sky

import bo2_lighting

HERE = Path(__file__).resolve().parent


def box(name, size, location, material, rotation=(0, 0, 0)):
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=location, rotation=rotation)
    obj = bpy.context.object
    obj.name = name
    obj.scale = size
    obj.data.materials.append(material)
    return obj


def cylinder(name, radius, depth, location, material, vertices=64):
    bpy.ops.mesh.primitive_cylinder_add(vertices=vertices, radius=radius, depth=depth,
                                        location=location)
    obj = bpy.context.object
    obj.name = name
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)
    return obj


def sphere(name, radius, location, material, segments=64, rings=32, scale=(1, 1, 1)):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=radius,
                                         location=location)
    obj = bpy.context.object
    obj.name = name
    obj.scale = scale
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)
    return obj


def build(out: Path) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bo2_lighting.register()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.resolution_percentage = 100
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.view_settings.view_transform = "Standard"
    scene.cycles.samples = 64
    scene.cycles.max_bounces = 4

    plaster = principled("Plaster", (0.75, 0.72, 0.66), roughness=0.9)
    wood = principled("Wood", (0.42, 0.25, 0.13), roughness=0.45)
    floor_mat = principled("Floor", (0.55, 0.45, 0.35), roughness=0.3)
    fabric = principled("Fabric", (0.15, 0.3, 0.55), roughness=1.0)
    rug = principled("Rug", (0.6, 0.12, 0.1), roughness=1.0)
    ceramic = principled("Ceramic", (0.85, 0.85, 0.8), roughness=0.15)
    brass = principled("Brass", (0.91, 0.78, 0.42), metallic=1.0, roughness=0.25)
    chrome = principled("Chrome", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.05)

    # Shell: floor, ceiling, four walls; the left wall (x = -3) has a 1.6 x 1.2 m window.
    box("Floor", (6.2, 5.2, 0.1), (0, 0, -0.05), floor_mat)
    box("Ceiling", (6.2, 5.2, 0.1), (0, 0, 3.05), plaster)
    box("Back wall", (6.2, 0.1, 3.0), (0, 2.55, 1.5), plaster)
    box("Front wall", (6.2, 0.1, 3.0), (0, -2.55, 1.5), plaster)
    box("Right wall", (0.1, 5.2, 3.0), (3.05, 0, 1.5), plaster)
    for name, size, loc in [("Wall below window", (0.1, 5.2, 0.9), (-3.05, 0, 0.45)),
                            ("Wall above window", (0.1, 5.2, 0.9), (-3.05, 0, 2.55)),
                            ("Wall left of window", (0.1, 1.8, 1.2), (-3.05, -1.7, 1.5)),
                            ("Wall right of window", (0.1, 1.8, 1.2), (-3.05, 1.7, 1.5))]:
        box(name, size, loc, plaster)

    # Table and chairs.
    box("Table top", (1.6, 0.9, 0.06), (0.3, 0.2, 0.75), wood)
    for dx in (-0.7, 0.7):
        for dy in (-0.35, 0.35):
            cylinder("Table leg", 0.035, 0.72, (0.3 + dx, 0.2 + dy, 0.36), wood, vertices=32)
    for i, y in enumerate((-0.55, 0.95)):
        box(f"Chair seat {i}", (0.45, 0.45, 0.05), (0.3, y, 0.45), wood)
        box(f"Chair back {i}", (0.45, 0.05, 0.5), (0.3, y + (0.22 if y > 0 else -0.22), 0.72),
            wood)
    # Shelf with vases and bowls against the back wall.
    box("Shelf", (1.8, 0.35, 0.04), (1.6, 2.3, 1.2), wood)
    box("Shelf low", (1.8, 0.35, 0.04), (1.6, 2.3, 0.6), wood)
    for i, x in enumerate((0.9, 1.35, 1.8, 2.25)):
        sphere(f"Vase {i}", 0.12, (x, 2.3, 1.36), ceramic, scale=(1, 1, 1.4))
        sphere(f"Bowl {i}", 0.1, (x + 0.2, 2.3, 0.7), brass, scale=(1, 1, 0.6))
    # Sofa and rug.
    box("Sofa base", (0.9, 2.2, 0.45), (2.4, -0.6, 0.22), fabric)
    box("Sofa back", (0.25, 2.2, 0.5), (2.75, -0.6, 0.7), fabric)
    box("Rug", (2.4, 1.6, 0.01), (0.3, 0.2, 0.005), rug)
    # Sculpture and a chrome ball on the table; smooth spheres in the corner.
    bpy.ops.mesh.primitive_monkey_add(size=0.4, location=(0.0, 0.2, 1.0))
    monkey = bpy.context.object
    monkey.name = "Sculpture"
    monkey.modifiers.new("Subdivision", "SUBSURF").levels = 3
    monkey.modifiers["Subdivision"].render_levels = 3
    bpy.ops.object.shade_smooth()
    monkey.data.materials.append(brass)
    sphere("Chrome ball", 0.15, (0.75, 0.25, 0.93), chrome, segments=128, rings=64)
    for i in range(3):
        sphere(f"Floor ball {i}", 0.25, (-2.3 + 0.55 * i, 2.1, 0.25), ceramic, segments=128,
               rings=64)

    # Lights: sun through the window, a ceiling point light, a spot on the shelf.
    light("SUN", "Sun", (-5, 0, 4), (math.radians(55), 0, math.radians(-80)), energy=4.0,
          angle=math.radians(1.0), color=(1.0, 0.92, 0.8))
    light("POINT", "Ceiling light", (0.3, 0.2, 2.7), (0, 0, 0), energy=120.0,
          shadow_soft_size=0.15)
    light("SPOT", "Shelf spot", (1.6, 0.6, 2.8), (math.radians(35), 0, math.radians(180)),
          energy=150.0, spot_size=math.radians(45), spot_blend=0.4, shadow_soft_size=0.05)

    sky((0.45, 0.6, 0.9))

    probe("VOLUME", "Room irradiance", (0, 0, 1.5), scale=(3.1, 2.6, 1.55),  # walls inside
          resolution_x=5, resolution_y=4, resolution_z=3, influence_distance=0.5)
    probe("SPHERE", "Table reflection", (0.3, -0.6, 1.4), influence_distance=2.5, falloff=0.3)
    probe("SPHERE", "Shelf reflection", (1.6, 1.4, 1.2), influence_distance=1.6, falloff=0.3)
    scene.bo2.probes.volume_face_size = "16"
    scene.bo2.probes.bounces = 3  # with the render's own bounce, as Cycles' 4 diffuse bounces

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 20
    cam.location = (-2.2, -2.2, 1.7)
    cam.rotation_euler = (math.radians(80), 0, math.radians(-50))
    scene.collection.objects.link(cam)
    scene.camera = cam
    depsgraph = bpy.context.evaluated_depsgraph_get()
    tris = 0
    for obj in scene.objects:
        if obj.type == "MESH":
            mesh = obj.evaluated_get(depsgraph).to_mesh()
            mesh.calc_loop_triangles()
            tris += len(mesh.loop_triangles)
            obj.evaluated_get(depsgraph).to_mesh_clear()
    print(f"TRIANGLES {tris}")
    bpy.ops.wm.save_as_mainfile(filepath=str(out), compress=True)


if __name__ == "__main__":
    build(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "room.blend")
