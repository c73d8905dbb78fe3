"""Depth of field (Camera > Depth of Field) against Cycles: three emitting cards at three
depths, the camera focused on the middle one (by distance and by a focus object), blades and
ratio; the profile across each card's edge, BO2's against Cycles'.
"""

import math

import bpy
import numpy as np
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from util import bare_material, render_pixels, set_world_color

from bo2_lighting.addon.blender import engine

W, H = 320, 120
DEPTHS = (2.0, 4.0, 8.0)  # the cards' distances ahead of the camera, metres


def glow():
    mat, tree = bare_material("Glow")
    node = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def build(fstop=0.4, blades=0, ratio=1.0):
    """The camera at the origin looking along +Y (50 mm on a 36 mm sensor: the frame's edges
    at tangent 0.36); a card per depth in its own third of the frame, taller than it."""
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.filter_size = 0.01  # the lens alone blurs
    set_world_color(scene)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.data.lens = 50.0
    dof = cam.data.dof
    dof.use_dof, dof.focus_distance, dof.aperture_fstop = True, 4.0, fstop
    dof.aperture_blades, dof.aperture_ratio = blades, ratio
    mat = glow()
    for k, depth in enumerate(DEPTHS):  # card k spans x from 0.05 to 0.28 of frame third k
        left, right = ((2.0 * (k / 3.0 + f) - 1.0) * 0.36 * depth for f in (0.05, 0.28))
        bpy.ops.mesh.primitive_plane_add(size=1.0, location=(0.5 * (left + right), depth, 0.0),
                                         rotation=(math.pi / 2, 0, 0))
        card = bpy.context.object
        card.name = f"Card {depth:g}"
        card.scale = (right - left, 2.0 * depth, 1.0)
        card.data.materials.append(mat)
    target = bpy.data.objects.new("Focus", None)
    target.location = (0.3, 4.0, 0.2)
    scene.collection.objects.link(target)
    return scene


def edges(scene, image):
    """Per card, the row profile around its left edge: (2 N + 1,) values."""
    out = []
    for depth in DEPTHS:
        card = scene.objects[f"Card {depth:g}"]
        left = card.matrix_world @ Vector((-0.5, 0.0, 0.0))
        p = world_to_camera_view(scene, scene.camera, left)
        col, row = int(round(p.x * W)), H // 2
        out.append(image[row - 8:row + 8, col - 14:col + 15, 0].mean(0))
    return out


def blur_width(profile):
    """Pixels between the 10% and 90% crossings of a rising edge profile."""
    lo, hi = np.interp([0.1, 0.9], np.maximum.accumulate(profile), np.arange(len(profile)))
    return hi - lo


@pytest.mark.parametrize(("fstop", "blades", "ratio"), [(0.4, 0, 1.0), (0.5, 5, 1.0),
                                                         (0.4, 0, 2.0)])
def test_edges_blur_as_cycles_blurs_them(addon, fstop, blades, ratio):
    """The edge of the card in focus stays sharp (10-90% within 1.5 px), the near and far ones
    blur by Cycles' widths within 20% (and 1 px), their profiles within 0.1 of Cycles'."""
    scene = build(fstop, blades, ratio)
    ours = edges(scene, render_pixels(scene, "BO2_LIGHTING", samples=64))
    cycles = edges(scene, render_pixels(scene, "CYCLES", samples=256))
    for depth, a, b in zip(DEPTHS, ours, cycles, strict=True):
        wa, wb = blur_width(a), blur_width(b)
        print(f"f/{fstop} blades {blades} ratio {ratio} at {depth} m: 10-90% BO2 {wa:.2f} px, "
              f"Cycles {wb:.2f} px; profiles within {np.abs(a - b).max():.3f}")
        if depth == 4.0:  # (Cycles' narrowest pixel filter still spreads it a little)
            assert wa < 1.5 and wb < 2.0
        else:
            assert wa == pytest.approx(wb, rel=0.2, abs=1.0)
            assert np.abs(a - b).max() < 0.1


def test_a_focus_object_sets_the_distance_and_one_behind_is_said(addon):
    """Focused on an empty 4 m ahead: as at Focus Distance 4; the empty moved behind the
    camera: the same image (its distance, as Cycles), and the render says so."""
    scene = build()
    scene.camera.data.dof.focus_distance = 4.0
    by_distance = render_pixels(scene, "BO2_LIGHTING", samples=16)
    scene.camera.data.dof.focus_distance = 1.0
    scene.camera.data.dof.focus_object = scene.objects["Focus"]
    np.testing.assert_allclose(render_pixels(scene, "BO2_LIGHTING", samples=16), by_distance,
                               atol=1e-6)
    scene.objects["Focus"].location = (0.3, -4.0, 0.2)
    with engine.listening() as said:
        behind = render_pixels(scene, "BO2_LIGHTING", samples=16)
    np.testing.assert_allclose(behind, by_distance, atol=1e-6)
    assert any("focus object 'Focus' is behind it" in t for t in said.texts()), said.texts()
