"""Any world node tree (``blender.worlds``): rendered by Cycles into an equirect once per
content, and read as the world by captures, frames and the viewport. Independent values:
Cycles' own renders of the same world, seen by a camera and lighting a sphere."""

import math

import bpy
import numpy as np
import pytest
from util import render_pixels

from bo2_lighting.addon.blender import extract, worlds


def gradient_world(name="Gradient"):
    """A world no Background colour can say: blue overhead, warm at the horizon, dark brown
    below (its direction's z through a colour ramp), its strength driven by a Math node."""
    world = bpy.data.worlds.new(name)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    nt = world.node_tree
    coords = nt.nodes.new("ShaderNodeTexCoord")
    split = nt.nodes.new("ShaderNodeSeparateXYZ")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position, ramp.color_ramp.elements[0].color = (
        0.35, (0.12, 0.07, 0.04, 1.0))
    ramp.color_ramp.elements[1].position, ramp.color_ramp.elements[1].color = (
        0.9, (0.2, 0.45, 1.0, 1.0))
    mid = ramp.color_ramp.elements.new(0.52)
    mid.color = (1.0, 0.7, 0.45, 1.0)
    shift = nt.nodes.new("ShaderNodeMath")
    shift.operation, shift.inputs[1].default_value = "MULTIPLY_ADD", 0.5
    shift.inputs[2].default_value = 0.5
    power = nt.nodes.new("ShaderNodeMath")
    power.operation = "MULTIPLY"
    power.inputs[0].default_value, power.inputs[1].default_value = 0.75, 2.0
    bg = nt.nodes["Background"]
    nt.links.new(coords.outputs["Generated"], split.inputs[0])
    nt.links.new(split.outputs["Z"], shift.inputs[0])
    shift.inputs[1].default_value = 0.5
    nt.links.new(shift.outputs[0], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], bg.inputs["Color"])
    nt.links.new(power.outputs[0], bg.inputs["Strength"])
    world.color = (0.3, 0.3, 0.3)
    return world


def look(scene, direction, angle=70.0, size=(48, 32)):
    data = bpy.data.cameras.new("Camera")
    data.angle = math.radians(angle)
    cam = bpy.data.objects.new("Camera", data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.rotation_euler = direction
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    return cam


def test_a_world_of_nodes_is_seen_as_cycles_sees_it(addon, empty_scene, tmp_path):
    scene = empty_scene
    scene.world = gradient_world()
    scene.bo2.bake_folder = str(tmp_path)
    assert not worlds.direct(scene.world)
    warnings = []
    assert extract.extract_world(scene, warnings).texture is None
    assert "has not been evaluated" in warnings[0]  # before: the viewport colour, and why
    assert worlds.ensure(scene)
    assert list(tmp_path.glob("world_*.exr"))  # beside the bakes, for renders elsewhere
    world = extract.extract_world(scene, warnings := [])
    assert world.texture is not None and not warnings
    for direction in ((math.radians(80), 0, math.radians(30)),  # the horizon, warm
                      (math.radians(150), 0, math.radians(-100)),  # overhead, blue
                      (math.radians(20), 0, math.radians(200))):  # the ground, dark
        look(scene, direction)
        cycles = render_pixels(scene, "CYCLES", samples=16)[..., :3]
        bo2 = render_pixels(scene, "BO2_LIGHTING", samples=4)[..., :3]
        err = np.abs(bo2 - cycles).mean() / max(float(cycles.mean()), 1e-3)
        assert err < 0.03, (direction, err)


def test_its_light_is_the_light_cycles_gives(addon, empty_scene, tmp_path):
    """A white diffuse sphere lit by the world alone: its top (sky), its side (horizon) and
    its bottom (ground) as Cycles shades them."""
    scene = empty_scene
    scene.world = gradient_world()
    scene.bo2.bake_folder = str(tmp_path)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0)
    mat = bpy.data.materials.new("White")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    spec = bsdf.inputs.get("Specular IOR Level") or bsdf.inputs.get("Specular")
    spec.default_value = 0.0
    bpy.context.object.data.materials.append(mat)
    bpy.ops.object.shade_smooth()
    look(scene, (math.radians(90), 0, 0), angle=40.0, size=(40, 40)).location = (0, -4.5, 0)
    assert worlds.ensure(scene)
    cycles = render_pixels(scene, "CYCLES", samples=64)[..., :3]
    bo2 = render_pixels(scene, "BO2_LIGHTING", samples=4)[..., :3]
    for rows in (slice(10, 14), slice(18, 22), slice(26, 30)):  # top, middle, bottom
        c, b = cycles[rows, 16:24].mean((0, 1)), bo2[rows, 16:24].mean((0, 1))
        np.testing.assert_allclose(b, c, rtol=0.12, atol=0.01)


def test_the_digest_follows_the_content_and_bad_trees_fall_back(addon, empty_scene, tmp_path):
    scene = empty_scene
    world = scene.world = gradient_world()
    scene.bo2.bake_folder = str(tmp_path)
    key = worlds.digest(world)
    assert worlds.digest(world) == key
    world.node_tree.nodes["Math.001"].inputs[0].default_value = 0.5  # the strength's node
    assert worlds.digest(world) != key
    world.node_tree.nodes["Math.001"].inputs[0].default_value = 0.75
    assert worlds.digest(world) == key
    ramp = world.node_tree.nodes["Color Ramp"].color_ramp.elements[1]
    was = tuple(ramp.color)
    ramp.color = (0.2, 0.45, 0.9, 1.0)  # a colour of the ramp
    assert worlds.digest(world) != key
    ramp.color = was
    assert worlds.digest(world) == key
    # a missing image: not rendered, the viewport colour with one warning that says why
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.new("gone", 4, 2)
    env.image.source, env.image.filepath = "FILE", str(tmp_path / "gone.hdr")
    world.node_tree.links.new(env.outputs["Color"],
                              world.node_tree.nodes["Background"].inputs["Color"])
    assert not worlds.ensure(scene)
    warnings = []
    got = extract.extract_world(scene, warnings)
    assert got.texture is None
    np.testing.assert_allclose(got.color, world.color[:3], rtol=1e-6)
    assert len(warnings) == 1 and "gone.hdr" in warnings[0] and "viewport colour" in warnings[0]


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_and_zero_worlds_render_finite(addon, empty_scene, tmp_path, value):
    """An HDRI with NaN or infinite texels and a world of zero strength bake and render
    finite."""
    scene = empty_scene
    img = bpy.data.images.new("bad", 16, 8, float_buffer=True)
    px = np.full((8, 16, 4), 0.5, np.float32)
    px[2, 3, :3] = value
    img.pixels.foreach_set(px.ravel())
    img.pack()
    world = bpy.data.worlds.new("Bad")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = img
    world.node_tree.links.new(env.outputs["Color"], world.node_tree.nodes["Background"]
                              .inputs["Color"])
    scene.world = world
    scene.bo2.bake_folder = str(tmp_path)
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    bpy.ops.object.lightprobe_add(type="VOLUME", location=(0, 0, 1))
    bpy.context.object.data.influence_distance = 0.0  # a volume of zero Distance
    look(scene, (math.radians(60), 0, 0), size=(16, 12)).location = (0, -4, 3)
    for strength in (1.0, 0.0):
        world.node_tree.nodes["Background"].inputs["Strength"].default_value = strength
        assert bpy.ops.bo2.bake_probes() == {"FINISHED"}
        px = render_pixels(scene, "BO2_LIGHTING", samples=1)
        assert np.isfinite(px).all()
