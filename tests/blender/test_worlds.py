"""Any world node tree (``blender.worlds``): rendered by Cycles into an equirect once per
content, and read as the world by captures, frames and the viewport. Independent values:
Cycles' own renders of the same world, seen by a camera and lighting a sphere."""

import math

import bpy
import numpy as np
import pytest
from mathutils import Vector
from util import render_pixels

from bo2_lighting.addon.blender import extract, worlds
from bo2_lighting.addon.core.render.job import Warnings


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
    warnings = Warnings()
    assert extract.extract_world(scene, warnings).texture is None
    assert "has not been evaluated" in warnings.texts()[0]  # before: the viewport colour, and why
    assert worlds.ensure(scene)
    assert list(tmp_path.glob("world_*.exr"))  # beside the bakes, for renders elsewhere
    world = extract.extract_world(scene, warnings := Warnings())
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
    warnings = Warnings()
    got = extract.extract_world(scene, warnings)
    assert got.texture is None
    np.testing.assert_allclose(got.color, world.color[:3], rtol=1e-6)
    assert len(warnings) == 1 and "gone.hdr" in warnings.texts()[0]
    assert "viewport colour" in warnings.texts()[0]


def hdri_world(name, pixels):
    """A world of one equirectangular Environment Texture of ``pixels`` (H, W, 4), packed."""
    img = bpy.data.images.new(name, pixels.shape[1], pixels.shape[0], float_buffer=True)
    img.pixels.foreach_set(pixels.ravel())
    img.pack()
    world = bpy.data.worlds.new(name)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = img
    world.node_tree.links.new(env.outputs["Color"],
                              world.node_tree.nodes["Background"].inputs["Color"])
    return world


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_and_zero_worlds_render_finite(addon, empty_scene, tmp_path, value):
    """An HDRI with NaN or infinite texels and a world of zero strength bake and render
    finite."""
    scene = empty_scene
    px = np.full((8, 16, 4), 0.5, np.float32)
    px[2, 3, :3] = value
    world = scene.world = hdri_world("Bad", px)
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


def sky_world(elevation_deg, rotation_deg=30.0, strength=0.05):
    """A Sky Texture world (the version's physical model) with its sun disc."""
    world = bpy.data.worlds.new("Sky")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    nt = world.node_tree
    node = nt.nodes.new("ShaderNodeTexSky")
    if bpy.app.version < (5, 0, 0):
        node.sky_type = "NISHITA"
    node.sun_elevation, node.sun_rotation = (math.radians(elevation_deg),
                                             math.radians(rotation_deg))
    nt.links.new(node.outputs["Color"], nt.nodes["Background"].inputs["Color"])
    nt.nodes["Background"].inputs["Strength"].default_value = strength
    return world


def lit_card(scene, towards):
    """A white diffuse card facing ``towards`` (3,), seen straight on from 3 m."""
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    card = bpy.context.object
    rot = Vector(towards).to_track_quat("Z", "Y")
    card.rotation_mode = "QUATERNION"
    card.rotation_quaternion = rot
    mat = bpy.data.materials.new("White")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    (bsdf.inputs.get("Specular IOR Level") or bsdf.inputs.get("Specular")).default_value = 0.0
    card.data.materials.append(mat)
    cam = look(scene, (0, 0, 0), angle=10.0, size=(16, 16))
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = Vector(towards).to_track_quat("Z", "Y")
    cam.location = 3.0 * Vector(towards)
    return card


def test_a_sky_texture_sun_disc_is_the_worlds_sun(addon, empty_scene, tmp_path):
    """The disc's irradiance against Cycles' own: a white Lambert card facing the sun has
    radiance 0.8 E / pi more with the disc than without (Cycles, the disc toggled)."""
    scene = empty_scene
    scene.world = sky_world(40.0)
    scene.bo2.bake_folder = str(tmp_path)
    towards = (math.sin(math.radians(30)) * math.cos(math.radians(40)),
               math.cos(math.radians(30)) * math.cos(math.radians(40)), math.sin(math.radians(40)))
    lit_card(scene, towards)
    assert worlds.ensure(scene)
    warnings = Warnings()
    world = extract.extract_world(scene, warnings)
    assert not warnings and world.sun is not None and world.sun.shadow
    np.testing.assert_allclose(-world.sun.direction, towards, atol=1e-6)
    assert world.sun.radius == pytest.approx(scene.world.node_tree.nodes["Sky Texture"]
                                             .sun_size)
    on = render_pixels(scene, "CYCLES", samples=64)[4:12, 4:12, :3].mean((0, 1))
    scene.world.node_tree.nodes["Sky Texture"].sun_disc = False
    off = render_pixels(scene, "CYCLES", samples=64)[4:12, 4:12, :3].mean((0, 1))
    np.testing.assert_allclose(0.8 * world.sun.color / math.pi, on - off, rtol=0.05)
    # the image it lights the world with holds no disc: the disc's node was switched off
    lum = world.texture.linear(0)[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    assert lum.max() * world.strength < 100.0
    # the engine counts it once: the card's brightness as Cycles' with the disc
    scene.world.node_tree.nodes["Sky Texture"].sun_disc = True
    bo2 = render_pixels(scene, "BO2_LIGHTING", samples=1)[4:12, 4:12, :3].mean((0, 1))
    np.testing.assert_allclose(bo2, on, rtol=0.1)
    # Threshold 0: no sun, the disc stays in the image
    scene.world.sun_threshold = 0.0
    assert worlds.ensure(scene)
    assert extract.extract_world(scene, Warnings()).sun is None


def test_a_sun_below_the_horizon_gives_no_sun(addon, empty_scene, tmp_path):
    scene = empty_scene
    scene.world = sky_world(-10.0)
    scene.bo2.bake_folder = str(tmp_path)
    assert worlds.ensure(scene)
    warnings = Warnings()
    world = extract.extract_world(scene, warnings)
    assert world.sun is None and np.isfinite(world.texture.linear(0)).all()


def test_an_hdri_sun_is_taken_out_with_the_worlds_settings(addon, empty_scene, tmp_path):
    """An HDRI read directly, its sun a single texel of 1e6: one shadowed sun light of the
    World > Sun Angle, the texel clamped; no warning that the scene has no lights."""
    scene = empty_scene
    px = np.full((32, 64, 4), 0.3, np.float32)
    px[20, 40, :3] = 1e6  # Blender's rows from the bottom: above the horizon
    world = scene.world = hdri_world("HDRI", px)
    world.sun_angle = math.radians(1.0)
    world.use_sun_shadow = False
    assert worlds.direct(world)
    got = extract.extract_world(scene, warnings := Warnings())
    assert not warnings and got.sun is not None and not got.sun.shadow
    assert got.sun.radius == pytest.approx(math.radians(1.0))
    assert -got.sun.direction[2] > 0.0  # above the horizon
    assert got.texture.linear(0).max() <= 10.0 * 1.0001
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    look(scene, (math.radians(60), 0, 0), size=(16, 12)).location = (0, -4, 3)
    from bo2_lighting.addon.blender import engine
    with engine.listening() as said:
        render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert not any("no lights" in w for w in said.texts())
    world.sun_threshold = 0.0
    assert extract.extract_world(scene, Warnings()).sun is None
