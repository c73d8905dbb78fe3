"""Build ``material_spheres.blend``: the talk's material chart as spheres.

Gloss 0.0 to 1.0 across (six columns), and down: a dielectric (rf0 = 0.04), gold, copper and
iron (rf0 of the metals from the measured values tabulated by Hoffman, "Physics and Math of
Shading", SIGGRAPH 2013 course: gold (1.00, 0.71, 0.29), copper (0.95, 0.64, 0.54), iron
(0.56, 0.57, 0.58)), all BO2 Material node groups, so that Cycles renders the same inputs. Lit
by an HDRI of the reference folder (``royal_esplanade_1k.hdr``, packed into the file) or, when
that folder is absent, by a procedural sky (packed), with one reflection probe in front of the
chart and a floor under it.

Run with a Python that has ``bpy``:  python demo_blends/build_material_spheres.py [OUT.blend]
"""

import math
import sys
from pathlib import Path

import bpy
import numpy as np
from scene_kit import principled, probe

import bo2_lighting

HERE = Path(__file__).resolve().parent
HDRI = HERE.parents[1] / "shared" / "reference" / "envmaps" / "royal_esplanade_1k.hdr"
GLOSS = [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
ROWS = [("Dielectric", (0.5, 0.5, 0.5), (0.04, 0.04, 0.04)),
        ("Gold", (0.0, 0.0, 0.0), (1.0, 0.71, 0.29)),
        ("Copper", (0.0, 0.0, 0.0), (0.95, 0.64, 0.54)),
        ("Iron", (0.0, 0.0, 0.0), (0.56, 0.57, 0.58))]


def procedural_sky(width=512, height=256) -> np.ndarray:
    """(H, W, 4) float32 equirectangular sky: a blue gradient, a warm sun, a grey ground."""
    v = 0.5 - (np.arange(height) + 0.5) / height  # +0.5 at the top row
    elevation = v[:, None] * math.pi * np.ones((1, width))
    u = (np.arange(width) + 0.5) / width
    azimuth = (0.5 - u)[None, :] * 2 * math.pi * np.ones((height, 1))
    d = np.stack([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth),
                  np.sin(elevation)], -1)
    up = np.clip(d[..., 2], 0, 1)[..., None]
    sky = (1 - up) * np.array([0.9, 0.95, 1.0]) + up * np.array([0.25, 0.45, 0.9])
    ground = np.array([0.15, 0.13, 0.1])
    img = np.where(d[..., 2:3] > 0, sky, ground)
    sun = np.array([math.cos(0.6) * math.cos(-0.8), math.cos(0.6) * math.sin(-0.8),
                    math.sin(0.6)])
    img = img + (d @ sun > math.cos(math.radians(2.5)))[..., None] * 400.0
    return np.concatenate([img, np.ones((height, width, 1))], -1).astype(np.float32)


def environment_image():
    if HDRI.exists():
        img = bpy.data.images.load(str(HDRI))
    else:
        sky = procedural_sky()
        img = bpy.data.images.new("Procedural sky", sky.shape[1], sky.shape[0],
                                  float_buffer=True)
        img.pixels.foreach_set(sky[::-1].ravel())  # Blender rows run bottom to top
    img.pack()
    if HDRI.exists():  # the file keeps no path of the machine that built it
        img.packed_files[0].filepath = f"//{HDRI.name}"
    return img


def build(out: Path) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bo2_lighting.register()
    from bo2_lighting.addon.blender import node_groups

    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 640, 400
    scene.render.resolution_percentage = 100
    scene.render.engine = "BO2_LIGHTING"
    scene.view_settings.view_transform = "Standard"
    scene.cycles.samples = 64
    for row, (name, albedo, rf0) in enumerate(ROWS):
        for col, gloss in enumerate(GLOSS):
            mat = node_groups.new_material(f"{name} {gloss:.1f}")
            group = next(n for n in mat.node_tree.nodes if node_groups.is_bo2_material_node(n))
            group.inputs["Albedo"].default_value = (*albedo, 1.0)
            group.inputs["Specular Color"].default_value = (*rf0, 1.0)
            group.inputs["Gloss"].default_value = gloss
            bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.42,
                                                 location=(-2.5 + col, 0.0, 3.6 - row))
            bpy.ops.object.shade_smooth()
            bpy.context.object.name = f"{name} gloss {gloss:.1f}"
            bpy.context.object.data.materials.append(mat)
    bpy.ops.mesh.primitive_plane_add(size=20, location=(0, 0, 0))
    bpy.context.object.data.materials.append(principled("Floor", (0.3, 0.3, 0.3)))

    world = bpy.data.worlds.new("Environment")
    if world.node_tree is None:
        world.use_nodes = True
    tree = world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = environment_image()
    tree.links.new(env.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    scene.world = world

    probe("SPHERE", "Reflection", (0.0, -2.0, 2.1), influence_distance=12.0,
          use_custom_parallax=True, parallax_distance=1.0e4)  # the sky: no room to correct to
    scene.bo2.probes.face_size = "128"

    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 50
    cam.location, cam.rotation_euler = (0.0, -9.0, 2.1), (math.radians(90), 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    bpy.ops.wm.save_as_mainfile(filepath=str(out), compress=True)


if __name__ == "__main__":
    build(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "material_spheres.blend")
