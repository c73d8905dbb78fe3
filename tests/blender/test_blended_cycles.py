"""Blended materials (Material > Settings > Render Method: Blended) against Cycles: two glowing
cards of alpha 0.4 and 0.7 overlapping in front of a glowing backdrop, half over the world,
and a Glass BSDF pane. Cycles composites transparency exactly (its transparent bounces), so
the blended stack's colour and coverage are compared with it; the scene has no light, so the
emission alone is seen and no lighting model differs.
"""

import math

import bpy
import numpy as np
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from util import film, render_on_devices, render_passes

W, H = 160, 100


def glowing(name, color, alpha, method="BLENDED"):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    node.inputs["Specular IOR Level"].default_value = 0.0
    node.inputs["Emission Color"].default_value = (*color, 1.0)
    node.inputs["Emission Strength"].default_value = 1.0
    node.inputs["Alpha"].default_value = alpha
    mat.surface_render_method = method
    return mat


def glass(name, color):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    node = nodes.new("ShaderNodeBsdfGlass")
    node.inputs["Color"].default_value = (*color, 1.0)
    node.inputs["Roughness"].default_value = 0.0
    node.inputs["IOR"].default_value = 1.5
    mat.node_tree.links.new(node.outputs[0], nodes["Material Output"].inputs["Surface"])
    mat.surface_render_method = "BLENDED"
    return mat


def clear(name, color):
    """A Principled BSDF of Transmission 1 (glass, as the Principled BSDF makes it)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (*color, 1.0)
    node.inputs["Roughness"].default_value = 0.0
    node.inputs["Transmission Weight"].default_value = 1.0
    mat.surface_render_method = "BLENDED"
    return mat


def card(name, size, location, material):
    bpy.ops.mesh.primitive_plane_add(size=size, location=location,
                                     rotation=(math.radians(90.0), 0.0, 0.0))
    obj = bpy.context.object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def build(method="BLENDED"):
    scene = bpy.context.scene
    film(scene, W, H)
    back = card("Backdrop", 1.0, (-1.2, 2.0, 0.0), glowing("Back", (0.2, 0.3, 0.5), 1.0))
    back.scale = (3.0, 3.0, 1.0)  # the frame's left, the world on its right
    card("Red", 1.2, (-0.1, 0.0, 0.2), glowing("Red", (1.0, 0.2, 0.1), 0.4, method))
    card("Green", 1.2, (0.2, 0.5, -0.2), glowing("Green", (0.1, 0.9, 0.3), 0.7, method))
    card("Glass", 0.6, (-1.6, 1.0, 0.0), glass("Glass", (0.9, 0.9, 0.9)))
    card("Clear", 0.5, (-2.0, 1.0, 0.9), clear("Clear", (0.8, 0.8, 0.8)))
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (0.0, -6.0, 0.0), (math.radians(90.0), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.cycles.transparent_max_bounces = 16
    scene.cycles.max_bounces = scene.cycles.transmission_bounces = 8
    scene.cycles.diffuse_bounces = scene.cycles.glossy_bounces = 0
    return scene


def at(scene, image, co, r=2):
    p = world_to_camera_view(scene, scene.camera, Vector(co))
    row, col = H - 1 - int(p.y * H), int(p.x * W)
    return image[row - r:row + r + 1, col - r:col + r + 1].mean((0, 1))


PATCHES = {  # name: a point on the nearest card's plane (y) that the patch looks through
    "red over backdrop": (-0.5, 0.0, 0.4),
    "both over backdrop": (-0.1, 0.0, 0.1),
    "both over world": (0.35, 0.0, -0.1),
    "green over world": (0.7, 0.5, -0.5),
    "backdrop": (-2.2, 2.0, -1.0),
    "glass over backdrop": (-1.6, 1.0, 0.0),
    "transmission over backdrop": (-2.0, 1.0, 0.9),
}


def test_a_blended_stack_matches_cycles(addon):
    """Each patch's colour within 0.005 + 1% of Cycles' and its alpha within 0.005: the stack
    in depth order over the backdrop or the world; a Glass BSDF and a Principled BSDF of
    Transmission 1 let 1 - F0 of their (grey) colour through."""
    scene = build()
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=4)["Combined"]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=256)["Combined"]
    for name, where in PATCHES.items():
        a, b = at(scene, ours, where), at(scene, cycles, where)
        print(f"{name}: BO2 {a.round(4)}, Cycles {b.round(4)}")
        np.testing.assert_allclose(a[:3], b[:3], atol=0.005, rtol=0.01, err_msg=name)
        assert a[3] == pytest.approx(b[3], abs=0.005), name


@pytest.mark.parametrize("method", ["BLENDED", "DITHERED"])
def test_blending_is_smooth_where_dithering_is_noisy(addon, method):
    """At 4 samples the blended stack is flat (its spread over 7 x 7 pixels below 1e-4); the
    same materials dithered are noisy (above 0.01)."""
    scene = build(method)
    image = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=4)["Combined"]
    p = world_to_camera_view(scene, scene.camera, Vector(PATCHES["both over backdrop"]))
    row, col = H - 1 - int(p.y * H), int(p.x * W)
    spread = float(image[row - 3:row + 4, col - 3:col + 4, 1].std())
    print(method, spread)
    assert spread < 1e-4 if method == "BLENDED" else spread > 0.01


def test_the_gpu_draws_blended_stacks_as_the_cpu(addon):
    """Device GPU: the cards and panes of the Cycles comparison as the CPU draws them (where
    there is no GPU context: the CPU, said so)."""
    scene = build()
    images = render_on_devices(scene, ["Combined"], samples=4)
    if images is None:
        return
    np.testing.assert_allclose(images["GPU"]["Combined"], images["CPU"]["Combined"],
                               atol=0.005)
