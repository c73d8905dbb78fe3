"""Shadow Catcher objects (Object > Visibility > Mask > Shadow Catcher) against Cycles: a sphere
over a catcher plane under a sun; with a transparent film the catcher keeps only the sphere's
shadow as opacity, and the Shadow Catcher pass is the share of light its shadows let through.
Cycles renders direct light only (no bounce), as BO2 without probes.
"""

import math

import bpy
import numpy as np
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from util import film, principled, render_on_devices, render_passes

W, H = 120, 90


def build():
    scene = bpy.context.scene
    film(scene, W, H)
    bpy.ops.mesh.primitive_plane_add(size=6.0)
    catcher = bpy.context.object
    catcher.name = "Catcher"
    catcher.data.materials.append(principled("Catcher", roughness=1.0))
    catcher.is_shadow_catcher = True
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.0, 0.0, 0.8))
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(principled("Ball", (0.8, 0.2, 0.1), 1.0))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.0, math.radians(2.0)
    sun.rotation_euler = (math.radians(-30.0), 0.0, 0.0)  # shadow falls towards -Y
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (0.0, -5.0, 3.5), (math.radians(55.0), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.cycles.max_bounces = 0
    return scene


def at(scene, image, co, r=1):
    p = world_to_camera_view(scene, scene.camera, Vector(co))
    row, col = H - 1 - int(p.y * H), int(p.x * W)
    return image[row - r:row + r + 1, col - r:col + r + 1].mean((0, 1))


@pytest.mark.parametrize("with_pass", [True, False])
def test_the_catcher_holds_the_shadow_as_cycles_does(addon, with_pass):
    """In the ball's shadow and beside it: Combined's alpha within 0.1 of Cycles' (with the
    pass the catcher leaves Combined, without it the shadow is its opacity), the Shadow
    Catcher pass within 0.1; the ball itself renders as it is."""
    scene = build()
    bpy.context.view_layer.cycles.use_pass_shadow_catcher = with_pass
    bpy.context.view_layer.bo2.use_pass_shadow_catcher = with_pass
    names = ["Combined"] + (["Shadow Catcher"] if with_pass else [])
    ours = render_passes(scene, "BO2_LIGHTING", names, samples=16)
    cycles = render_passes(scene, "CYCLES", names, samples=64)
    shadow = (0.0, -0.8 * math.tan(math.radians(30.0)), 0.0)  # the ball's centre, cast down
    for where, name in ((shadow, "shadow"), ((1.8, -1.0, 0.0), "open")):
        a, b = at(scene, ours["Combined"], where), at(scene, cycles["Combined"], where)
        print(f"{name}: alpha BO2 {a[3]:.3f}, Cycles {b[3]:.3f}")
        assert a[3] == pytest.approx(b[3], abs=0.1), name
        if with_pass:
            sa = at(scene, ours["Shadow Catcher"], where)
            sb = at(scene, cycles["Shadow Catcher"], where)
            print(f"{name}: share BO2 {sa.round(3)}, Cycles {sb.round(3)}")
            np.testing.assert_allclose(sa, sb, atol=0.1)
    ball = at(scene, ours["Combined"], (0.0, -0.35, 0.9))
    assert ball[3] == 1.0  # the ball itself is drawn, opaque


def test_the_gpu_draws_catchers_as_the_cpu(addon):
    """Device GPU: the catcher's Combined as the CPU's, and with the Shadow Catcher pass on,
    Combined without the catcher and the pass, as the CPU's (where there is no GPU context:
    the CPU, said so)."""
    scene = build()
    images = render_on_devices(scene, ["Combined"])
    if images is None:
        return
    np.testing.assert_allclose(images["GPU"]["Combined"], images["CPU"]["Combined"], atol=0.02)
    bpy.context.view_layer.bo2.use_pass_shadow_catcher = True
    images = render_on_devices(scene, ["Combined", "Shadow Catcher"])
    for name in ("Combined", "Shadow Catcher"):
        np.testing.assert_allclose(images["GPU"][name], images["CPU"][name], atol=0.02)
    shadow = at(scene, images["GPU"]["Shadow Catcher"],
                (0.0, -0.8 * math.tan(math.radians(30.0)), 0.0))
    assert shadow.max() < 0.5  # the ball's shadow in the pass
