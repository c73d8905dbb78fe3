"""The viewport's Rendered shading, headless: depsgraph updates re-read only what changed, the
image through the scene camera matches the F12 render, look-dev views, errors, probe hints.

Updates are caught with ``depsgraph_update_post`` (it receives the same ``Depsgraph.updates``
that ``RenderEngine.view_update`` reads). Drawing needs a GPU and is not run here.
"""

import bpy
import numpy as np
import pytest
from util import camera_of, render_pixels, set_world_color

from bo2_lighting.addon.blender import viewport
from bo2_lighting.addon.core import pipeline
from bo2_lighting.addon.core import viewport as core_viewport

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
    scene.bo2.use_indirect = False
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
    scene.bo2.viewport_samples = 2
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
    scene.bo2.viewport_samples = 4
    open_view(view, scene)
    image = view.session.image()
    assert image.final and image.samples == 4 and image.pixels.shape == (H, W, 4)
    f12 = render_pixels(scene, "BO2_LIGHTING", samples=4)
    # the viewport adds one sample at a time; F12 shades a pixel's samples on one triangle once
    assert np.abs(image.pixels[..., :3] - f12[..., :3]).mean() < 0.01


def test_lookdev_view_and_viewport_samples_follow_the_scene(view, updates):
    scene = bpy.context.scene
    build(scene)
    open_view(view, scene)
    renders = view.session.stats["renders"]
    updates.clear()
    scene.bo2.lookdev_view = "ALBEDO"
    assert settle(view, updates) == set()  # shown from the last passes: no render
    assert view.session.view == "ALBEDO"
    assert view.session.stats["renders"] == renders
    pixels = view.session.image().pixels
    # the left cube's red albedo somewhere, the right's blue elsewhere, as the materials say
    red = np.all(np.abs(pixels[..., :3] - [0.8, 0.2, 0.2]) < 0.01, axis=-1)
    blue = np.all(np.abs(pixels[..., :3] - [0.2, 0.2, 0.8]) < 0.01, axis=-1)
    assert red.sum() > 50 and blue.sum() > 50
    scene.bo2.viewport_samples = 3  # a setting that changes the image renders again
    assert settle(view, updates) == {"settings"}
    assert view.session.image().samples == 3
    for key in core_viewport.VIEWS:
        scene.bo2.lookdev_view = key
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
    scene.bo2.use_indirect = True
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
    scene.bo2.bake_face_size, scene.bo2.bake_samples = "32", 1
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
    scene.bo2.viewport_samples = 1
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
    scene.bo2.lookdev_view = "ALBEDO"
    settle(view, updates)
    pixels = view.session.image().pixels
    assert np.all(np.abs(pixels[..., :3] - [1.0, 1.0, 0.0]) < 0.01, axis=-1).sum() > 50


def test_a_new_bake_reaches_the_viewport(view, updates, tmp_path):
    scene = bpy.context.scene
    build(scene)
    scene.bo2.use_indirect = True
    scene.bo2.viewport_samples = 1
    scene.bo2.bake_folder = str(tmp_path)
    probe = bpy.data.objects.new("Probe", bpy.data.lightprobes.new("Probe", "SPHERE"))
    probe.location = (0.0, 0.0, 1.0)
    scene.collection.objects.link(probe)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    open_view(view, scene)
    updates.clear()
    bpy.context.view_layer.objects.active = probe
    scene.bo2.bake_face_size, scene.bo2.bake_samples = "32", 1
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
