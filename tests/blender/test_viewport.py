"""The viewport's Rendered shading, headless: depsgraph updates re-read only what changed, the
image through the scene camera matches the F12 render, look-dev views, errors, probe hints.

Updates are caught with ``depsgraph_update_post`` (it receives the same ``Depsgraph.updates``
that ``RenderEngine.view_update`` reads). Drawing needs a GPU and is not run here.
"""

import threading
import types

import bpy
import numpy as np
import pytest
from util import camera_of, render_pixels, set_world_color

from bo2_lighting.addon.blender import viewport
from bo2_lighting.addon.core.lighting import world_probes
from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render import viewport as core_viewport

W, H = 96, 64


@pytest.fixture
def updates():
    """A list that collects the depsgraph updates of each ``view_layer.update()``."""
    got = []

    def handler(scene, depsgraph):
        got.extend(viewport.Update.copy(u) for u in depsgraph.updates)

    bpy.app.handlers.depsgraph_update_post.append(handler)
    yield got
    bpy.app.handlers.depsgraph_update_post.remove(handler)


def material(name, color):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (*color, 1.0)
    return mat


def build(scene):
    set_world_color(scene, (0.05, 0.05, 0.05))
    scene.render.resolution_x, scene.render.resolution_y = W, H
    for name, x, color in (("Left", -1.2, (0.8, 0.2, 0.2)), ("Right", 1.2, (0.2, 0.2, 0.8))):
        bpy.ops.mesh.primitive_cube_add(size=1.5, location=(x, 0.0, 0.0))
        bpy.context.object.name = name
        bpy.context.object.data.materials.append(material(name, color))
    bpy.ops.mesh.primitive_plane_add(size=20.0, location=(0.0, 0.0, -0.75))
    light = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    light.data.energy = 800.0
    light.location = (1.0, -2.0, 4.0)
    scene.collection.objects.link(light)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -7.0, 3.0)
    cam.rotation_euler = (np.radians(70.0), 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.indirect.use = False
    bpy.context.view_layer.update()


@pytest.fixture
def view(addon):
    v = viewport.Viewport()
    yield v
    v.close()


def open_view(view, scene):
    """``view`` opened on ``scene`` through its camera, rendered to the end."""
    view.sync(bpy.context.evaluated_depsgraph_get())
    view.set_camera(camera_of(scene, W, H))
    assert view.session.wait(120)


def settle(view, updates):
    """Apply the collected updates to ``view``; returns the changes."""
    bpy.context.view_layer.update()
    changed = view.sync(bpy.context.evaluated_depsgraph_get(), list(updates))
    updates.clear()
    assert view.session.wait(120)
    return changed


def test_only_what_changed_is_read_again(view, updates):
    scene = bpy.context.scene
    build(scene)
    scene.bo2.viewport.samples = 2
    open_view(view, scene)
    first = view.session.image().pixels.copy()
    reads = dict(view.cache.reads)
    assert reads[("mesh", "Left")] == reads[("mesh", "Right")] == 1
    updates.clear()

    bpy.data.objects["Left"].location.x -= 0.5  # a move: the transform alone
    assert settle(view, updates) == {"geometry"}
    assert dict(view.cache.reads) == reads
    assert view.session.stats["prepares"] == 2
    moved = view.session.image().pixels
    assert np.abs(moved - first).max() > 0.05

    mat = bpy.data.materials["Right"]  # a material tweak: that material, nothing else
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0, 1, 0, 1)
    assert settle(view, updates) == {"materials"}
    assert view.cache.reads[("material", "Right")] == reads[("material", "Right")] + 1
    assert view.cache.reads[("material", "Left")] == reads[("material", "Left")]
    assert view.cache.reads[("mesh", "Right")] == 1
    assert view.session.stats["prepares"] == 2 and view.session.stats["material_tables"] == 1

    cube = bpy.data.objects["Right"].data  # a mesh edit: that mesh
    cube.vertices[0].co.z += 0.5
    cube.update()
    assert settle(view, updates) == {"geometry"}
    assert view.cache.reads[("mesh", "Right")] == 2
    assert view.cache.reads[("mesh", "Left")] == 1

    scene.bo2.specular_model = "bo2"  # a setting: no extraction of meshes or materials
    before = dict(view.cache.reads)
    assert settle(view, updates) == {"settings"}
    assert dict(view.cache.reads) == before


def test_viewport_through_the_scene_camera_matches_f12(view):
    scene = bpy.context.scene
    build(scene)
    scene.bo2.viewport.samples = 4
    open_view(view, scene)
    image = view.session.image()
    assert image.final and image.samples == 4 and image.pixels.shape == (H, W, 4)
    f12 = render_pixels(scene, "BO2_LIGHTING", samples=4)
    # the viewport adds one sample at a time; F12 shades a pixel's samples on one triangle once
    assert np.abs(image.pixels[..., :3] - f12[..., :3]).mean() < 0.01


def test_lookdev_view_and_viewport_samples(view, updates):
    """The look-dev view is the viewport's own (its header's selector, read at each draw):
    it shows the last passes without rendering; the scene's viewport samples render anew."""
    scene = bpy.context.scene
    build(scene)
    open_view(view, scene)
    renders = view.session.stats["renders"]
    updates.clear()
    view.session.set_view("ALBEDO")
    assert settle(view, updates) == set()  # shown from the last passes: no render
    assert view.session.view == "ALBEDO"
    assert view.session.stats["renders"] == renders
    pixels = view.session.image().pixels
    # the left cube's red albedo somewhere, the right's blue elsewhere, as the materials say
    red = np.all(np.abs(pixels[..., :3] - [0.8, 0.2, 0.2]) < 0.01, axis=-1)
    blue = np.all(np.abs(pixels[..., :3] - [0.2, 0.2, 0.8]) < 0.01, axis=-1)
    assert red.sum() > 50 and blue.sum() > 50
    scene.bo2.viewport.samples = 3  # a setting that changes the image renders again
    assert settle(view, updates) == {"settings"}
    assert view.session.image().samples == 3
    for key in core_viewport.VIEWS:
        view.session.set_view(key)
        settle(view, updates)
        assert np.isfinite(view.session.image().pixels).all()


def test_a_failed_render_shows_its_error_and_the_next_change_renders(view, updates,
                                                                     monkeypatch):
    scene = bpy.context.scene
    build(scene)
    real = pipeline.prepare

    def broken(*args, **kwargs):
        raise MemoryError("out of memory")

    monkeypatch.setattr(pipeline, "prepare", broken)
    open_view(view, scene)
    assert view.status() == "Error: MemoryError: out of memory"
    monkeypatch.setattr(pipeline, "prepare", real)
    updates.clear()
    bpy.data.objects["Left"].location.z += 0.1
    settle(view, updates)
    assert view.session.error is None and view.session.image().final
    assert view.status().startswith("Sample")


def test_probe_state_hint(view, tmp_path):
    scene = bpy.context.scene
    build(scene)
    scene.bo2.indirect.use = True
    scene.bo2.bake_folder = str(tmp_path)
    probe = bpy.data.objects.new("Probe", bpy.data.lightprobes.new("Probe", "SPHERE"))
    scene.collection.objects.link(probe)
    bpy.context.view_layer.update()
    open_view(view, scene)
    assert "Light probes: 1 missing: re-bake" in view.status()
    [(obj, text, _)] = viewport.probe_labels(scene)
    assert obj == probe and text == "BO2 bake: missing"
    bpy.context.view_layer.objects.active = probe
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    scene.bo2.probes.face_size, scene.bo2.probes.samples = "32", 1
    assert bpy.ops.bo2.bake_probes(mode="ACTIVE") == {"FINISHED"}
    assert viewport.probe_labels(scene)[0][1] == "BO2 bake: baked"
    assert viewport.probe_hint(scene) == ""
    probe.location.x += 1.0  # moved after its bake: stale, still used
    bpy.context.view_layer.update()
    assert viewport.probe_labels(scene)[0][1] == "BO2 bake: stale"
    assert viewport.probe_hint(scene).startswith("Light probes: 1 stale: re-bake")


def test_hiding_instancing_and_renaming_reach_the_viewport(view, updates):
    scene = bpy.context.scene
    build(scene)
    scene.bo2.viewport.samples = 1
    open_view(view, scene)
    updates.clear()
    shown = view.session.image().pixels.copy()

    bpy.data.objects["Left"].hide_set(True)  # hidden in the viewport: gone from the image
    assert "geometry" in settle(view, updates)
    hidden = view.session.image().pixels.copy()
    assert np.abs(hidden - shown).max() > 0.05
    bpy.data.objects["Left"].hide_set(False)
    settle(view, updates)
    np.testing.assert_allclose(view.session.image().pixels, shown, atol=1e-6)

    # an empty instancing a collection: moving the empty moves the instance
    group = bpy.data.collections.new("Kit")
    bpy.ops.mesh.primitive_ico_sphere_add(radius=0.4, location=(0.0, 0.0, 0.0))
    ball = bpy.context.object
    for c in ball.users_collection:
        c.objects.unlink(ball)
    group.objects.link(ball)
    empty = bpy.data.objects.new("Instancer", None)
    empty.instance_type, empty.instance_collection = "COLLECTION", group
    empty.location = (0.0, -1.5, 0.0)
    scene.collection.objects.link(empty)
    settle(view, updates)
    before = view.session.image().pixels.copy()
    empty.location.x += 0.6
    assert "geometry" in settle(view, updates)
    assert np.abs(view.session.image().pixels - before).max() > 0.05

    # a renamed material keeps its compiled program, and an edit after the rename is seen
    mat = bpy.data.materials["Right"]
    mat.name = "Renamed"
    settle(view, updates)
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (1, 1, 0, 1)
    view.session.set_view("ALBEDO")
    settle(view, updates)
    pixels = view.session.image().pixels
    assert np.all(np.abs(pixels[..., :3] - [1.0, 1.0, 0.0]) < 0.01, axis=-1).sum() > 50


def test_a_new_bake_reaches_the_viewport(view, updates, tmp_path):
    scene = bpy.context.scene
    build(scene)
    scene.bo2.indirect.use = True
    scene.bo2.viewport.samples = 1
    scene.bo2.bake_folder = str(tmp_path)
    probe = bpy.data.objects.new("Probe", bpy.data.lightprobes.new("Probe", "SPHERE"))
    probe.location = (0.0, 0.0, 1.0)
    scene.collection.objects.link(probe)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    open_view(view, scene)
    updates.clear()
    bpy.context.view_layer.objects.active = probe
    scene.bo2.probes.face_size, scene.bo2.probes.samples = "32", 1
    assert bpy.ops.bo2.bake_probes(mode="ACTIVE") == {"FINISHED"}
    assert "probes" in settle(view, updates)  # the operator tags the scene; the file is new
    assert "missing" not in view.status()


def test_warnings_show_in_the_status(view):
    scene = bpy.context.scene
    build(scene)
    mat = bpy.data.materials["Left"]
    checker = mat.node_tree.nodes.new("ShaderNodeTexChecker")  # not read by the engine
    mat.node_tree.links.new(checker.outputs["Color"],
                            mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    open_view(view, scene)
    assert "1 warning: Material 'Left': node 'Checker Texture'" in view.status()


def studio_space(**overrides):
    """A viewport in Rendered shading with Scene World off and Blender's "forest" HDRI."""
    light = next(s for s in bpy.context.preferences.studio_lights
                 if s.type == "WORLD" and s.name.startswith("forest"))
    shading = dict(type="RENDERED", use_scene_world_render=False, use_scene_lights_render=True,
                   selected_studio_light=light, studiolight_rotate_z=0.9,
                   studiolight_intensity=1.5, studiolight_background_blur=0.0,
                   studiolight_background_alpha=1.0)
    shading.update(overrides)
    return types.SimpleNamespace(shading=types.SimpleNamespace(**shading)), light


def test_studio_light_lights_the_viewport_as_the_same_world_would(view, monkeypatch):
    """Scene World off: the viewport is lit by the studio HDRI, rotated and scaled as the
    shading says, exactly as a scene whose world is that HDRI through a Mapping node renders
    (Cycles builds its studio world the same way); Scene World on again restores the scene's
    world and probes; Scene Lights off takes the lights away."""
    scene = bpy.context.scene
    build(scene)
    scene.bo2.viewport.samples = 2
    scene.bo2.indirect.use = True
    open_view(view, scene)
    own = view.session.image().pixels.copy()
    threads = []  # where the HDRI's SH and chains are made: not on Blender's thread
    real = world_probes.world_probes
    monkeypatch.setattr(world_probes, "world_probes", lambda world, *args: (
        threads.append(threading.current_thread()), real(world, *args))[1])
    depsgraph = bpy.context.evaluated_depsgraph_get()
    space, light = studio_space()
    assert view.set_shading(depsgraph, space)
    assert not view.set_shading(depsgraph, space)  # the same toggles: nothing to do
    assert view.session.wait(120)
    studio = view.session.image().pixels.copy()
    assert np.abs(studio - own).mean() > 0.02
    assert threads and threading.main_thread() not in threads

    # the scene's world made the studio light by hand: the same picture
    tree = scene.world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(light.path)
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, 0.9)
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"],
                   mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    background = tree.nodes["Background"]
    tree.links.new(env.outputs["Color"], background.inputs["Color"])
    background.inputs["Strength"].default_value = 1.5
    other = viewport.Viewport()
    try:
        open_view(other, scene)
        by_hand = other.session.image().pixels
    finally:
        other.close()
    assert np.abs(by_hand - studio).mean() < 0.01 * max(studio[..., :3].mean(), 0.05)

    space, _ = studio_space(use_scene_lights_render=False)  # Scene Lights off: darker
    assert view.set_shading(depsgraph, space)
    assert view.session.wait(120)
    assert view.session.image().pixels[..., :3].mean() < studio[..., :3].mean()
    space, _ = studio_space(studiolight_background_alpha=0.0)  # a see-through background
    assert view.set_shading(depsgraph, space)
    assert view.session.wait(120)
    alpha = view.session.image().pixels[..., 3]
    sky = alpha == 0.0
    assert 0 < sky.sum() < alpha.size * 0.5 and (studio[..., 3] == 1.0).all()

    space.shading.use_scene_world_render = True  # back to the scene's world (the HDRI now)
    assert view.set_shading(depsgraph, space)
    assert view.session.wait(120)
    assert np.abs(view.session.image().pixels - by_hand).max() < 1e-5


def test_pixel_size_renders_fewer_pixels():
    region = types.SimpleNamespace(width=301, height=200)
    data = types.SimpleNamespace(view_matrix=np.eye(4), window_matrix=np.eye(4),
                                 is_perspective=True)
    assert (viewport.region_camera(region, data, 1).width,
            viewport.region_camera(region, data, 2).width,
            viewport.region_camera(region, data, 4).height) == (301, 151, 50)
    scene = bpy.context.scene
    scene.render.preview_pixel_size = "4"
    assert viewport.pixel_size(scene, bpy.context.preferences) == 4
    scene.render.preview_pixel_size = "AUTO"
    assert viewport.pixel_size(scene, bpy.context.preferences) == 1  # no HiDPI headless
