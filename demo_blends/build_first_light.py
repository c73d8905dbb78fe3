"""Build ``first_light.blend``: spheres of a dielectric, a plastic and two metals on a floor,
lit by a point, a spot, a sun and an area light; Principled BSDF materials only. A reflection
probe over the spheres and an irradiance volume around them give the indirect light once baked
(``bo2 bake``; the bakes go to ``bo2_bake/`` next to the file).

Run with a Python that has ``bpy``:  python demo_blends/build_first_light.py [OUT.blend]
"""

import math
import sys
from pathlib import Path

import bpy
from scene_kit import light, principled, probe, sky

HERE = Path(__file__).resolve().parent


def add_object(mesh_op, name, material, **kwargs):
    mesh_op(**kwargs)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def build(out: Path) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.resolution_percentage = 100
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.view_settings.view_transform = "Standard"
    scene.cycles.samples = 64

    floor = principled("Floor", (0.45, 0.45, 0.42), roughness=0.7)
    add_object(bpy.ops.mesh.primitive_plane_add, "Floor", floor, size=12.0)
    spheres = [
        ("Red dielectric", principled("Red dielectric", (0.7, 0.08, 0.05), roughness=0.6)),
        ("White plastic", principled("White plastic", (0.8, 0.8, 0.8), roughness=0.2)),
        ("Gold", principled("Gold", (1.0, 0.78, 0.34), metallic=1.0, roughness=0.3)),
        ("Copper", principled("Copper", (0.95, 0.64, 0.54), metallic=1.0, roughness=0.15)),
    ]
    for i, (name, mat) in enumerate(spheres):
        sphere = add_object(bpy.ops.mesh.primitive_uv_sphere_add, name, mat,
                            segments=64, ring_count=32, radius=0.6,
                            location=(-2.1 + 1.4 * i, 0.0, 0.6))
        bpy.ops.object.shade_smooth()
        sphere.select_set(False)

    light("POINT", "Point", (-2.5, -2.0, 2.5), (0, 0, 0), energy=300.0,
              shadow_soft_size=0.1, color=(1.0, 0.9, 0.8))
    light("SPOT", "Spot", (2.5, -2.5, 3.0), (math.radians(45), 0, math.radians(45)),
              energy=500.0, spot_size=math.radians(50), spot_blend=0.3, shadow_soft_size=0.1)
    light("SUN", "Sun", (0, 0, 5), (math.radians(50), 0, math.radians(-30)),
              energy=1.5, angle=math.radians(1.0))
    light("AREA", "Area", (0.0, 3.0, 2.0), (math.radians(-60), 0, 0), energy=150.0,
              size=0.5, color=(0.7, 0.8, 1.0))

    # in front of the spheres, not between them
    probe("SPHERE", "Reflection", (0.0, -1.6, 0.9), influence_distance=6.0,
          use_custom_parallax=True, parallax_distance=1.0e4)  # the sky: no room to correct to
    probe("VOLUME", "Irradiance", (0.0, 0.0, 1.0), scale=(3.5, 2.0, 1.0), resolution_x=6,
          resolution_y=4, resolution_z=2, influence_distance=2.0)

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 40
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = (0.0, -7.0, 3.2)
    cam.rotation_euler = (math.radians(68), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    sky((0.05, 0.06, 0.08), "World")
    bpy.ops.wm.save_as_mainfile(filepath=str(out), compress=True)


if __name__ == "__main__":
    build(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "first_light.blend")
