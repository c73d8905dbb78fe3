"""Hair curves and point clouds (a Curves object; points a mesh's geometry nodes make) against
Cycles, which renders them as round tubes and spheres: the share of the frame
they cover (film transparent: the alpha) and their colour under a sun.
"""

import math

import bpy
import numpy as np
import pytest
from util import principled, render_pixels

from bo2_lighting.addon.blender import engine, extract


def scene_with_camera(width=160, height=120):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.view_settings.view_transform = "Standard"
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (0.0, -1.2, 0.35), (math.radians(80), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.rotation_euler = 3.0, (0.5, 0.2, 0.0)
    scene.collection.objects.link(sun)
    scene.cycles.max_bounces = 0  # direct light alone, as BO2 without probes
    scene.bo2.indirect.use = False
    return scene


def hair(count=400, points=16, radius=0.003, seed=1):
    """Curves standing on a 0.6 m square, bending a little, ``points`` each."""
    rng = np.random.default_rng(seed)
    curves = bpy.data.hair_curves.new("Hair")
    curves.add_curves([points] * count)
    roots = np.column_stack([rng.uniform(-0.3, 0.3, (count, 2)), np.zeros(count)])
    t = np.linspace(0.0, 1.0, points)
    bend = rng.uniform(-0.1, 0.1, (count, 1, 2))
    pos = np.repeat(roots[:, None, :], points, 1)
    pos[..., 2] = 0.3 * t
    pos[..., :2] += bend * (t ** 2)[None, :, None]
    curves.position_data.foreach_set("vector", pos.astype(np.float32).ravel())
    attribute = curves.attributes.new("radius", "FLOAT", "POINT")
    attribute.data.foreach_set("value", np.full(count * points, radius, np.float32))
    obj = bpy.data.objects.new("Hair", curves)
    obj.data.materials.append(principled("Hair", (0.8, 0.5, 0.2), 0.6))
    bpy.context.scene.collection.objects.link(obj)
    return obj


def cloud(count=300, radius=0.015, seed=2):
    """Points made by geometry nodes (Mesh to Points, Set Material) from a mesh's vertices."""
    rng = np.random.default_rng(seed)
    pos = np.column_stack([rng.uniform(-0.3, 0.3, (count, 2)), rng.uniform(0.0, 0.3, count)])
    mesh = bpy.data.meshes.new("Points")
    mesh.from_pydata(pos.tolist(), [], [])
    obj = bpy.data.objects.new("Points", mesh)
    obj.data.materials.append(principled("Points", (0.2, 0.5, 0.8), 0.6))
    tree = bpy.data.node_groups.new("To Points", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    given, out = tree.nodes.new("NodeGroupInput"), tree.nodes.new("NodeGroupOutput")
    points = tree.nodes.new("GeometryNodeMeshToPoints")
    points.inputs["Radius"].default_value = radius
    paint = tree.nodes.new("GeometryNodeSetMaterial")
    paint.inputs["Material"].default_value = obj.data.materials[0]
    tree.links.new(given.outputs[0], points.inputs["Mesh"])
    tree.links.new(points.outputs[0], paint.inputs["Geometry"])
    tree.links.new(paint.outputs[0], out.inputs[0])
    obj.modifiers.new("To Points", "NODES").node_group = tree
    bpy.context.scene.collection.objects.link(obj)
    return obj


@pytest.mark.parametrize("kind", ["hair", "points"])
def test_coverage_and_colour_match_cycles(addon, kind):
    """The frame's mean alpha within 6% of Cycles' and the mean colour where both see the
    object within 12%."""
    scene = scene_with_camera()
    (hair if kind == "hair" else cloud)()
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)
    cycles = render_pixels(scene, "CYCLES", samples=64)
    cover_ours, cover_cycles = ours[..., 3].mean(), cycles[..., 3].mean()
    both = (ours[..., 3] > 0.9) & (cycles[..., 3] > 0.9)
    colour = ours[both, :3].mean(0), cycles[both, :3].mean(0)
    print(f"{kind}: coverage BO2 {cover_ours:.4f}, Cycles {cover_cycles:.4f}; colour "
          f"{colour[0].round(3)} / {colour[1].round(3)} over {both.sum()} pixels")
    assert 0.02 < cover_cycles < 0.9
    assert cover_ours == pytest.approx(cover_cycles, rel=0.06)
    assert both.sum() > 50
    np.testing.assert_allclose(colour[0], colour[1], rtol=0.12)


def test_dense_hair_is_thinned_with_one_warning(addon, monkeypatch):
    """More segments than an object draws: every k-th curve, k times as thick (the coverage
    kept), and one warning."""
    scene = scene_with_camera()
    hair(count=400)
    full = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., 3].mean()
    monkeypatch.setattr(extract, "HAIR_SEGMENTS", 1500)
    with engine.listening() as said:
        thinned = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., 3].mean()
    assert [t for t in said.texts() if t.startswith("Hair 'Hair'")] == [
        "Hair 'Hair': 6,000 segments, more than 1,500: every 4th curve is drawn, 4 times as "
        "thick"]
    assert thinned == pytest.approx(full, rel=0.25)
