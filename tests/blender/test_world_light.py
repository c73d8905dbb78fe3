"""The world's light where no probe was placed (``core.bakes.bounce``), against Cycles: the
underside of a ball over a white ground under a uniform sky is lit by the ground's bounce."""

import math

import bpy
from util import principled, render_pixels

from bo2_lighting.addon.blender import extract


def ball_over_ground(scene):
    bpy.ops.mesh.primitive_plane_add(size=30.0)
    bpy.context.object.data.materials.append(principled("Ground", (0.8, 0.8, 0.8), 1.0))
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.5,
                                         location=(0, 0, 0.9))
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(principled("Ball", (0.8, 0.8, 0.8), 1.0))
    world = bpy.data.worlds.new("Sky")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    scene.world = world
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.angle = math.radians(20.0)
    cam.location, cam.rotation_euler = (0.0, -6.0, 0.55), (math.radians(93.0), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y = 48, 48
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"


def underside(px):
    """Mean of the ball's lower part, seen from the side (rows from the bottom)."""
    return float(px[16:20, 19:29, :3].mean())


def test_the_ground_bounces_onto_the_ball_without_any_probe(addon, empty_scene, tmp_path):
    scene = empty_scene
    scene.bo2.bake_folder = str(tmp_path)
    ball_over_ground(scene)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    assert extract.extract_scene(depsgraph, camera=False, indirect=True)[0].probes.volumes == []
    cycles = underside(render_pixels(scene, "CYCLES", samples=128))
    with_bounce = underside(render_pixels(scene, "BO2_LIGHTING", samples=2))
    scene.bo2.indirect.use_implicit_bounce = False
    without = underside(render_pixels(scene, "BO2_LIGHTING", samples=2))
    assert abs(with_bounce - cycles) < 0.15 * cycles, (with_bounce, cycles)
    assert without < 0.8 * cycles, (without, cycles)
