"""The equirectangular mapping of ``core.formulas.texture`` is the one of Blender's Environment
Texture.

Independent values: Cycles renders. The world shows a 64 x 32 float image (Non-Color, Closest
interpolation) whose texels encode their own UV: R = cos(2 pi u), G = sin(2 pi u) (smooth across
the u = 0 / 1 seam) and B = v, at texel centres. A narrow-angle perspective camera looks along a
direction; its centre pixel sees the background around that direction, and the (u, v) decoded
from the rendered colour must equal ``direction_to_equirect_uv`` of the direction within one
texel. The poles are looked at from 1 degree away (elevation +-89, azimuth 0): exactly at a pole
Cycles computes v = 1 (or 0), which the image's REPEAT lookup wraps onto the opposite row, so the
pole itself measures the wrap rather than the mapping.
"""

import math

import bpy
import numpy as np
import pytest
from mathutils import Vector

from bo2_lighting.addon.blender import images
from bo2_lighting.addon.core.formulas import texture

W, H = 64, 32
RES = 5  # odd: the centre pixel is centred on the camera axis

DIRECTIONS = {
    "+X": (1.0, 0.0, 0.0),
    "+Y": (0.0, 1.0, 0.0),
    "-X": (-1.0, 0.0, 0.0),
    "-Y": (0.0, -1.0, 0.0),
    "+Z": (math.cos(math.radians(89)), 0.0, math.sin(math.radians(89))),
    "-Z": (math.cos(math.radians(89)), 0.0, -math.sin(math.radians(89))),
    # Off-axis: tells asin(z) (v = 0.75 here) from other latitude laws such as z / 2 (v = 0.854).
    "az30_el45": (
        math.cos(math.radians(45)) * math.cos(math.radians(30)),
        math.cos(math.radians(45)) * math.sin(math.radians(30)),
        math.sin(math.radians(45)),
    ),
    "az-120_el-20": (
        math.cos(math.radians(-20)) * math.cos(math.radians(-120)),
        math.cos(math.radians(-20)) * math.sin(math.radians(-120)),
        math.sin(math.radians(-20)),
    ),
}


def uv_world(scene):
    """A world whose Environment Texture shows the UV-encoding image."""
    img = bpy.data.images.new("uv", W, H, float_buffer=True, alpha=True)
    img.colorspace_settings.name = "Non-Color"
    u, v = np.meshgrid((np.arange(W) + 0.5) / W, (np.arange(H) + 0.5) / H)  # rows bottom-up
    px = np.ones((H, W, 4), np.float32)
    px[..., 0] = np.cos(2.0 * np.pi * u)
    px[..., 1] = np.sin(2.0 * np.pi * u)
    px[..., 2] = v
    img.pixels.foreach_set(px.ravel())
    img.update()
    world = bpy.data.worlds.new("UV")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    nodes = world.node_tree.nodes
    env = nodes.new("ShaderNodeTexEnvironment")
    env.image = img
    env.projection = "EQUIRECTANGULAR"
    env.interpolation = "Closest"
    world.node_tree.links.new(env.outputs["Color"], nodes["Background"].inputs["Color"])
    nodes["Background"].inputs["Strength"].default_value = 1.0
    scene.world = world


def setup_scene():
    scene = bpy.context.scene
    uv_world(scene)
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 16
    scene.cycles.use_denoising = False
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    data = bpy.data.cameras.new("Camera")
    data.type = "PERSP"
    data.angle = math.radians(1.0)  # the centre pixel spans 0.2 degrees; a texel is 5.6
    cam = bpy.data.objects.new("Camera", data)
    cam.rotation_mode = "QUATERNION"
    scene.collection.objects.link(cam)
    scene.camera = cam
    return scene, cam


def render_centre(scene):
    """(3,) RGB of the centre pixel of a Cycles render, read back from a 32-bit EXR."""
    bpy.ops.render.render()
    px = images.render_result_pixels(scene)[::-1]  # rows bottom to top
    return px[RES // 2, RES // 2, :3].copy()


@pytest.mark.parametrize("name", list(DIRECTIONS))
def test_environment_texture_equirect_uv(name):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene, cam = setup_scene()
    d = Vector(DIRECTIONS[name]).normalized()
    cam.rotation_quaternion = d.to_track_quat("-Z", "Y")
    bpy.context.view_layer.update()
    assert (cam.matrix_world.to_3x3() @ Vector((0, 0, -1)) - d).length < 1e-5

    r, g, b = render_centre(scene)
    expected = texture.direction_to_equirect_uv(np.array([d], np.float32))[0]
    # Within one texel, plus the Closest rounding (the texel centre is up to half a texel away).
    assert abs(b - expected[1]) <= 1.0 / H, (name, b, expected)
    assert math.hypot(r, g) > 0.5, (name, r, g)  # one texel, or a few neighbours averaged
    u = (math.atan2(g, r) / (2.0 * math.pi)) % 1.0
    du = (u - expected[0] + 0.5) % 1.0 - 0.5  # distance on the circle
    assert abs(du) <= 1.0 / W, (name, u, expected)
