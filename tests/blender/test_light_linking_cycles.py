"""Light and shadow linking (Object > Shading > Light Linking, Shadow Linking) against Cycles:
in F12, in a Volume probe's captures, and the messages of an empty collection.

The scene: two spheres on a floor; a point light above them linked to the left sphere alone
(its receiver collection), a sun whose blocker collection holds the left sphere alone. Cycles
renders direct light only (no bounce), as BO2 without probes.
"""

import bpy
import numpy as np
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from test_probes import _volume_irradiance
from util import principled, render_pixels, set_world_color

from bo2_lighting.addon.blender import engine

W, H = 160, 120
SUN_TILT = -0.9  # the sun's rotation about X: it shines down and towards -Y (the camera)
SPHERES = {"A": (-1.2, 0.0, 0.5), "B": (1.2, 0.0, 0.5)}


def build():
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    set_world_color(scene)
    bpy.ops.mesh.primitive_plane_add(size=8.0)
    bpy.context.object.name = "Floor"
    bpy.context.object.data.materials.append(principled("Floor", roughness=1.0))
    for name, location in SPHERES.items():
        bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=location, segments=48,
                                             ring_count=24)
        bpy.ops.object.shade_smooth()
        bpy.context.object.name = name
        bpy.context.object.data.materials.append(principled(name, roughness=1.0))
    key = bpy.data.objects.new("Key", bpy.data.lights.new("Key", "POINT"))
    key.data.energy, key.location = 400.0, (0.0, 0.0, 3.0)
    sun = bpy.data.objects.new("Fill", bpy.data.lights.new("Fill", "SUN"))
    sun.data.energy, sun.data.angle = 2.0, 0.02
    sun.rotation_euler = (SUN_TILT, 0.0, 0.0)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (0.0, -6.0, 4.5), (0.9, 0.0, 0.0)
    for obj in (key, sun, cam):
        scene.collection.objects.link(obj)
    scene.camera = cam
    scene.cycles.max_bounces = 0
    return scene


def link(scene, receivers=("A",), blockers=("A",)):
    """The key's receiver collection and the fill's blocker collection (None: unlinked)."""
    for light, kind, names in (("Key", "receiver_collection", receivers),
                               ("Fill", "blocker_collection", blockers)):
        collection = None
        if names is not None:
            collection = bpy.data.collections.new(
                f"{light} {'Receivers' if kind == 'receiver_collection' else 'Blockers'}")
            for name in names:
                collection.objects.link(scene.objects[name])
        setattr(scene.objects[light].light_linking, kind, collection)


def at(scene, px, co, r=2):
    """The mean luminance of a (2r+1)^2 patch around world point ``co`` (row 0 at the bottom)."""
    p = world_to_camera_view(scene, scene.camera, Vector(co))
    row, col = int(p.y * H), int(p.x * W)
    patch = px[row - r:row + r + 1, col - r:col + r + 1, :3]
    return float((patch @ np.array([0.2126, 0.7152, 0.0722], np.float32)).mean())


def shadow_of(centre):
    """Where the sun's shadow of a sphere centred at ``centre`` falls on the floor."""
    x, y, z = centre  # the sun shines along (0, sin(tilt), -cos(tilt))
    return (x, y + z * np.tan(SUN_TILT), 0.0)


def measure(scene, px):
    return {
        "A top": at(scene, px, (-1.2, -0.2, 0.96)),
        "B top": at(scene, px, (1.2, -0.2, 0.96)),
        "floor middle": at(scene, px, (0.0, 1.0, 0.0)),
        "A shadow": at(scene, px, shadow_of(SPHERES["A"]), 1),
        "B shadow": at(scene, px, shadow_of(SPHERES["B"]), 1),
        "open floor": at(scene, px, (0.0, -1.5, 0.0)),
    }


def test_linked_lights_match_cycles(addon):
    """The key lights the left sphere alone and the fill's shadow is the left sphere's alone,
    as Cycles renders them: each patch within 12% of Cycles', and the linked image differs
    from the unlinked one where linking says it must."""
    scene = build()
    link(scene)
    bo2 = measure(scene, render_pixels(scene, "BO2_LIGHTING", samples=16))
    cycles = measure(scene, render_pixels(scene, "CYCLES", samples=64))
    for key, value in cycles.items():
        assert bo2[key] == pytest.approx(value, rel=0.12, abs=0.01), (key, bo2, cycles)
    for m in (bo2, cycles):
        assert m["B top"] < 0.5 * m["A top"], m  # the key lights A alone
        assert m["floor middle"] < 0.5 * m["A top"], m
        assert m["A shadow"] < 0.2 * m["open floor"], m  # A blocks the fill
        assert m["B shadow"] > 0.9 * m["open floor"], m  # B does not
    link(scene, None, ("A",))
    assert measure(scene, render_pixels(scene, "BO2_LIGHTING", samples=16))["B top"] \
        > 1.5 * bo2["B top"]
    link(scene, ("A",), None)
    unblocked = measure(scene, render_pixels(scene, "BO2_LIGHTING", samples=16))
    assert unblocked["B shadow"] < 0.2 * unblocked["open floor"]


def test_an_empty_collection_links_nothing_and_says_so(addon):
    """A light whose receiver collection is empty lights every object, as Cycles does (the
    image as without a collection), and the render says why once."""
    scene = build()
    link(scene, None, None)
    plain = render_pixels(scene, "BO2_LIGHTING", samples=4)
    link(scene, (), None)
    with engine.listening() as said:
        empty = render_pixels(scene, "BO2_LIGHTING", samples=4)
    np.testing.assert_array_equal(empty, plain)
    texts = [t for t in said.texts() if "is empty" in t]
    assert texts == ["Light 'Key': its receiver collection 'Key Receivers' is empty, "
                     "so every object receives its light (as in Cycles)"], said.texts()


def test_captures_honour_linking_as_cycles_does(addon, tmp_path):
    """A Volume probe around the spheres, baked by BO2 and by Cycles, linked and unlinked:
    the change linking makes to each sample's light, BO2's against Cycles' (within 0.08)."""
    scene = build()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "linking.blend"))
    volume = bpy.data.objects.new("Irradiance", bpy.data.lightprobes.new("Irradiance", "VOLUME"))
    volume.location, volume.scale = (0.0, 0.0, 1.0), (2.5, 1.5, 0.8)
    volume.data.resolution_x, volume.data.resolution_y, volume.data.resolution_z = 3, 2, 2
    scene.collection.objects.link(volume)
    scene.bo2.probes.bounces = 1  # as Cycles' backend: the world and one bounce of the lights
    scene.bo2.probes.cycles_samples = 16
    plain = {b: _volume_irradiance(scene, b) for b in ("BO2", "CYCLES")}
    link(scene)
    linked = {b: _volume_irradiance(scene, b) for b in ("BO2", "CYCLES")}
    change = linked["BO2"] / plain["BO2"]
    truth = linked["CYCLES"] / plain["CYCLES"]
    assert truth.min() < 0.8  # the key's bounce off the floor and B is gone
    assert np.abs(change - truth).max() < 0.08, (change, truth)


def test_blenders_linking_panels_show_for_the_engine(addon):
    """Object > Shading (Light Linking, Shadow Linking) polls true for BO2 Lighting on lights
    and meshes, as for Cycles and EEVEE; Cycles' own children of it stay Cycles'."""
    from types import SimpleNamespace

    scene = build()
    shading = bpy.types.OBJECT_PT_shading
    for name in ("Key", "A"):
        assert shading.poll(SimpleNamespace(engine="BO2_LIGHTING", object=scene.objects[name]))
    assert not bpy.types.OBJECT_PT_shadow_terminator.poll(
        SimpleNamespace(engine="BO2_LIGHTING", object=scene.objects["A"]))
