"""Every material feature the compiler supports under every light type, shadows on and off, in
F12, the viewport and a probe capture.

One scene holds them all (film transparent, lights straight above the middle):
- a horizontal plane of alpha 0.5 ("Veil") and a stack of two ("Layers") over the floor: the
  floor where their shadows fall keeps about 1/2 and 1/4 of its light with shadows on
  (stochastic transparency of the casters), all of it with shadows off;
- the same two in front of the empty background: coverage (Combined alpha) 1/2 and 3/4;
- a Holdout surface (alpha 0, no colour), an Emission surface (its radiance), and a plane with a
  striped normal map beside the same plane without it (the stripes' relief in the shading).

- a card the light's receiver collection excludes (light linking): dark under every light;
  a card its blocker collection excludes (shadow linking): the floor under it fully lit.

The expected values come from the geometry and the alphas, not from the renderer: shadow
points are where the line from the light through the casters meets the floor.
"""

import math

import bpy
import numpy as np
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector
from util import (
    bare_material,
    camera_of,
    principled,
    render_passes,
    render_pixels,
    set_world_color,
)

from bo2_lighting.addon.blender import bake_files, viewport

W, H = 120, 90
SAMPLES = 16
LIGHT_HEIGHT = 3.0
VEIL = (1.2, 0.0, 1.0)  # centre of the single alpha-0.5 plane
LAYERS = ((-1.2, 0.0, 1.0), (-1.2, 0.0, 1.3))  # the stack of two
LINKED_OUT = (-1.5, 1.2, 0.01)  # a card the light does not light (light linking)
FREE = (1.6, 1.4, 1.0)  # a card that does not shadow the light (shadow linking)
# (kind, area shape)
LIGHTS = [("POINT", None), ("SPOT", None), ("SUN", None), ("AREA", "SQUARE"),
          ("AREA", "RECTANGLE"), ("AREA", "DISK"), ("AREA", "ELLIPSE")]


def matte(name, alpha=1.0):
    """A rough grey Principled material of ``alpha``, rendered dithered (as BO2 does)."""
    mat = principled(name, roughness=1.0, alpha=alpha)
    if hasattr(mat, "surface_render_method"):
        mat.surface_render_method = "DITHERED"
    return mat


def surface_material(name, kind):
    """A material whose surface is one node: "HOLDOUT" or "EMISSION" (red, strength 5)."""
    mat, tree = bare_material(name)
    out = tree.nodes["Material Output"]
    if kind == "HOLDOUT":
        node = tree.nodes.new("ShaderNodeHoldout")
        tree.links.new(node.outputs[0], out.inputs["Surface"])
    else:
        node = tree.nodes.new("ShaderNodeEmission")
        node.inputs["Color"].default_value = (1.0, 0.2, 0.2, 1.0)
        node.inputs["Strength"].default_value = 5.0
        tree.links.new(node.outputs[0], out.inputs["Surface"])
    return mat


def striped_normal_map(name):
    """A Principled material whose normal comes from a Normal Map node reading stripes along
    U, every other one tilting the normal 45 degrees towards -X."""
    mat = matte(name)
    tree = mat.node_tree
    img = bpy.data.images.new(name, 16, 16, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    px = np.empty((16, 16, 4), np.float32)
    tilt = np.where((np.arange(16) // 2) % 2 == 0, math.radians(45.0), 0.0)
    px[..., 0] = 0.5 - 0.5 * np.sin(tilt)[None, :]  # away from the lights (towards -X)
    px[..., 1] = 0.5
    px[..., 2] = 0.5 + 0.5 * np.cos(tilt)[None, :]
    px[..., 3] = 1.0
    img.pixels.foreach_set(px.reshape(-1))
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image, tex.interpolation = img, "Closest"
    nmap = tree.nodes.new("ShaderNodeNormalMap")
    tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    tree.links.new(nmap.outputs["Normal"], tree.nodes["Principled BSDF"].inputs["Normal"])
    return mat


def plane(mat, size, location, rotation=(0.0, 0.0, 0.0)):
    bpy.ops.mesh.primitive_plane_add(size=size, location=location, rotation=rotation)
    obj = bpy.context.object
    obj.data.materials.append(mat)
    return obj


def build(tmp_path):
    scene = bpy.context.scene
    set_world_color(scene, (0.02, 0.02, 0.02))
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True
    scene.view_settings.view_transform = "Standard"
    plane(matte("Floor"), 6.0, (0.0, 0.0, 0.0))
    veil, layers = matte("Veil", alpha=0.5), matte("Layers", alpha=0.5)
    plane(veil, 0.8, VEIL)
    for c in LAYERS:
        plane(layers, 0.8, c)
    upright = (math.pi / 2, 0.0, 0.0)  # facing the camera, in front of the empty background
    plane(veil, 0.8, (1.2, 4.0, 0.6), upright)
    plane(layers, 0.8, (-1.2, 4.0, 0.6), upright)
    plane(layers, 0.8, (-1.2, 4.3, 0.6), upright)
    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(0.0, 1.5, 0.2))
    bpy.context.object.data.materials.append(surface_material("Holdout", "HOLDOUT"))
    bpy.ops.mesh.primitive_cube_add(size=0.4, location=(0.0, -1.2, 0.2))
    bpy.context.object.data.materials.append(surface_material("Glow", "EMISSION"))
    plane(striped_normal_map("Striped"), 1.0, (-1.5, -1.6, 0.01))
    plane(matte("Plain"), 1.0, (1.5, -1.6, 0.01)).name = "Plain"
    plane(matte("Linked Out"), 0.8, LINKED_OUT).name = "Linked Out"
    plane(matte("Free"), 0.6, FREE).name = "Free"
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -6.0, 3.5)
    direction = Vector((0.0, 0.5, 0.3)) - cam.location
    cam.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(cam)
    scene.camera = cam
    probe = bpy.data.objects.new("Probe", bpy.data.lightprobes.new("Probe", "SPHERE"))
    probe.location = (0.0, 0.0, 0.4)
    probe.data.influence_distance = 3.0
    scene.collection.objects.link(probe)
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.indirect.use = False
    scene.bo2.probes.face_size = "32"
    scene.bo2.probes.volume_face_size = "8"
    scene.bo2.probes.samples = 1
    scene.bo2.probes.bounces = 1
    scene.bo2.viewport.samples = SAMPLES
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "cross.blend"))
    return scene


def add_light(scene, kind, shape):
    data = bpy.data.lights.new("Light", kind)
    data.energy = 3.0 if kind == "SUN" else 600.0
    if kind == "SPOT":
        data.spot_size = math.radians(150.0)
    if kind == "AREA":
        data.shape = shape
        data.size, data.size_y = 0.5, 0.3
    obj = bpy.data.objects.new("Light", data)
    obj.location = (0.0, 0.0, LIGHT_HEIGHT)  # every kind shines straight down
    scene.collection.objects.link(obj)
    for kind_, card in (("receiver_collection", "Linked Out"), ("blocker_collection", "Free")):
        collection = bpy.data.collections.new(kind_)
        collection.objects.link(scene.objects[card])
        collection.collection_objects[0].light_linking.link_state = "EXCLUDE"
        setattr(obj.light_linking, kind_, collection)
    return obj


def floor_point(kind, centre):
    """Where the shadow of a caster centred at ``centre`` falls on the floor (z = 0)."""
    x, y, z = centre
    if kind == "SUN":
        return Vector((x, y, 0.0))
    s = LIGHT_HEIGHT / (LIGHT_HEIGHT - z)
    return Vector((x * s, y * s, 0.0))


def pixel(scene, co):
    """(row, column) of world point ``co`` in an image with row 0 at the bottom."""
    p = world_to_camera_view(scene, scene.camera, Vector(co))
    return int(p.y * H), int(p.x * W)


def patch(px, rc, r=1):
    return px[rc[0] - r:rc[0] + r + 1, rc[1] - r:rc[1] + r + 1]


def luminance(px):
    return px[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)


def measure(scene, kind, px):
    """What the image shows of each feature."""
    # 7 x 7 pixels (28 cm): the dither of the casters makes each point's shadow noisy
    veil = pixel(scene, floor_point(kind, VEIL))
    layers = pixel(scene, floor_point(kind, np.mean(LAYERS, axis=0)))
    lo, hi = pixel(scene, (-1.8, -1.9, 0.01)), pixel(scene, (-1.2, -1.3, 0.01))
    striped = luminance(px[lo[0]:hi[0], lo[1]:hi[1]])
    lo, hi = pixel(scene, (1.2, -1.9, 0.01)), pixel(scene, (1.8, -1.3, 0.01))
    plain = luminance(px[lo[0]:hi[0], lo[1]:hi[1]])
    return {
        "veil_floor": float(luminance(patch(px, veil, 3)).mean()),
        "layers_floor": float(luminance(patch(px, layers, 3)).mean()),
        "veil_cover": float(patch(px, pixel(scene, (1.2, 4.0, 0.6)), 2)[..., 3].mean()),
        "layers_cover": float(patch(px, pixel(scene, (-1.2, 4.0, 0.6)), 2)[..., 3].mean()),
        "holdout": patch(px, pixel(scene, (0.0, 1.5, 0.4)), 0)[0, 0].copy(),
        "glow": patch(px, pixel(scene, (0.0, -1.4, 0.2)), 0)[0, 0].copy(),
        "striped_relief": float(np.abs(np.diff(striped, axis=1)).mean()),
        "plain_relief": float(np.abs(np.diff(plain, axis=1)).mean()),
        "plain": float(plain.mean()),
        "linked_out": float(luminance(patch(px, pixel(scene, LINKED_OUT), 2)).mean()),
        "free_floor": float(luminance(patch(px, pixel(scene, floor_point(kind, FREE)), 2))
                            .mean()),
    }


def check_features(m, name):
    assert 0.3 < m["veil_cover"] < 0.7, (name, m)  # 1 - 0.5
    assert 0.6 < m["layers_cover"] < 0.9, (name, m)  # 1 - 0.5^2
    assert m["holdout"][3] == 0.0 and np.abs(m["holdout"][:3]).max() == 0.0, (name, m)
    assert m["glow"][0] > 4.5 and m["glow"][0] > 3.0 * m["glow"][1], (name, m)
    assert m["striped_relief"] > 4.0 * m["plain_relief"] + 0.01, (name, m)
    assert m["linked_out"] < 0.02 * m["plain"], (name, m)


def check_shadows(on, off, name):
    """The floor under the casters keeps about 1/2 (one layer of alpha 0.5) and 1/4 (two) of
    its light once shadows are on."""
    veil = on["veil_floor"] / off["veil_floor"]
    layers = on["layers_floor"] / off["layers_floor"]
    assert 0.3 < veil < 0.7, (name, veil, on, off)
    assert 0.12 < layers < 0.4, (name, layers, on, off)
    assert on["free_floor"] > 0.97 * off["free_floor"], (name, on, off)


def render_viewport(scene):
    view = viewport.Viewport()
    try:
        view.sync(bpy.context.evaluated_depsgraph_get())
        view.set_camera(camera_of(scene, W, H))
        assert view.session.wait(180)
        assert view.session.error is None, view.session.error
        image = view.session.image()
        assert image.final and image.samples == SAMPLES
        return image.pixels.copy()
    finally:
        view.close()


def probe_luminance(scene):
    assert bpy.ops.bo2.bake_probes() == {"FINISHED"}
    from bo2_lighting.addon.core.files import probe_file

    _, sh, chains = probe_file.read(bake_files.path(scene.objects["Probe"]))
    assert np.isfinite(sh).all() and all(np.isfinite(m).all() for c in chains.values()
                                         for m in c)
    return float(sh[0, 0] @ np.array([0.2126, 0.7152, 0.0722]))


@pytest.mark.parametrize(("kind", "shape"), LIGHTS, ids=[s or k for k, s in LIGHTS])
def test_every_feature_under_every_light(addon, tmp_path, kind, shape):
    scene = build(tmp_path)
    light = add_light(scene, kind, shape)
    results = {}
    for shadow in (True, False):
        light.data.use_shadow = shadow
        bpy.context.view_layer.update()
        f12 = render_pixels(scene, "BO2_LIGHTING", samples=SAMPLES)
        view = render_viewport(scene)
        assert np.isfinite(f12).all() and np.isfinite(view).all()
        results[shadow] = (measure(scene, kind, f12), measure(scene, kind, view),
                           probe_luminance(scene))
        for m, where in zip(results[shadow][:2], ("F12", "viewport"), strict=True):
            check_features(m, (kind, shape, shadow, where))
        # the viewport draws F12's samples, one at a time (shading each, where F12 shades a
        # pixel's samples on one triangle once: shadows of dithered casters differ in noise)
        f12_m, view_m = results[shadow][:2]
        for key in ("veil_floor", "layers_floor", "veil_cover", "layers_cover"):
            assert view_m[key] == pytest.approx(f12_m[key], rel=0.12, abs=0.01), key
        np.testing.assert_allclose(view_m["glow"], f12_m["glow"], rtol=0.02)
    for k, where in enumerate(("F12", "viewport")):
        check_shadows(results[True][k], results[False][k], (kind, shape, where))
    # the probe sees the floor darkened by the casters' shadows
    assert results[True][2] < 0.99 * results[False][2], (kind, shape, results)


MOVER = (0.0, 4.0, 0.6)  # an upright card moving 1 m along x while the shutter is open


def add_mover(scene):
    """A card of 0.4 m in front of the empty background, moving 1 m per frame along x (linear
    keys around the current frame, Shutter 1): it covers its centre 0.4 of the shutter."""
    from test_motion_blur_cycles import linear_keys

    plane(matte("Mover"), 0.4, MOVER, (math.pi / 2, 0.0, 0.0)).name = "Mover"
    card = scene.objects["Mover"]
    for frame, dx in ((scene.frame_current - 1, -1.0), (scene.frame_current + 1, 1.0)):
        card.location.x = MOVER[0] + dx
        card.keyframe_insert("location", index=0, frame=frame)
    linear_keys(scene)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 1.0
    scene.frame_set(scene.frame_current)


HAIR = (2.1, 1.4)  # where the hair patch and the points stand (x, y on the floor)
POINTS = (-2.1, 1.6)


def add_strands():
    """A small patch of hair (orange) and a cloud of points (blue) on the floor."""
    from test_strands_cycles import cloud, hair

    patch = hair(count=300, points=8, radius=0.006)
    patch.location = (*HAIR, 0.0)
    dots = cloud(count=80, radius=0.02)
    dots.location = (*POINTS, 0.0)


@pytest.mark.parametrize(("kind", "shape"), LIGHTS, ids=[s or k for k, s in LIGHTS])
def test_production_features_under_every_light(addon, tmp_path, kind, shape):
    """The scene above with hair and points, a light group for the light and one for the
    world, Cryptomatte, the stack of two ("Layers") Blended, a shader AOV and a card moving
    over the shutter, in F12: the groups add up to Combined, the Cryptomatte Object pass names
    the card under the pixel, the hair and the points are drawn in their colours, the blended
    stack covers 3/4 exactly where the dithered one is near it, its shadow is still dithered
    (the floor under it keeps about half the light the single veil's keeps), the AOV is its
    node's value on its card and 0 beside it, the moving card streaks over its travel, and the
    light's linking holds as above."""
    scene = build(tmp_path)
    light = add_light(scene, kind, shape)
    add_strands()
    layer = bpy.context.view_layer
    for name in ("light", "world"):
        layer.lightgroups.add(name=name)
    light.lightgroup, scene.world.lightgroup = "light", "world"
    layer.use_pass_cryptomatte_object = True
    bpy.data.materials["Layers"].surface_render_method = "BLENDED"
    aov = layer.aovs.add()
    aov.name, aov.type = "mask", "VALUE"
    tree = bpy.data.materials["Plain"].node_tree
    node = tree.nodes.new("ShaderNodeOutputAOV")
    node.aov_name = "mask"
    node.inputs["Value"].default_value = 0.7
    add_mover(scene)
    names = ["Combined", "Combined_light", "Combined_world", "CryptoObject00", "Emit", "mask"]
    passes = render_passes(scene, "BO2_LIGHTING", names, samples=SAMPLES)
    combined = passes["Combined"]
    # what no group holds is the emission of the meshes in none (all of them here)
    left = combined[..., :3] - passes["Combined_light"] - passes["Combined_world"]
    np.testing.assert_allclose(left, passes["Emit"], atol=2e-4 * combined[..., :3].max())
    assert passes["Combined_light"].max() > 0.05
    crypto = passes["CryptoObject00"]  # row 0 at the top; pixel() counts from the bottom
    from bo2_lighting.addon.core.render import cryptomatte

    row, col = pixel(scene, (1.5, -1.6, 0.01))
    centre = crypto[H - 1 - row, col]
    assert centre[0].view(np.uint32) == cryptomatte.name_hash("Plain"), kind
    assert centre[1] == pytest.approx(1.0)
    def colour(co):
        row, col = pixel(scene, co)
        return combined[H - 1 - row - 2:H - row + 2, col - 2:col + 3, :3].mean((0, 1))

    for where, (a, b) in ((HAIR, (0, 2)), (POINTS, (2, 0))):  # orange hair, blue points
        seen, floor = colour((*where, 0.12)), colour((where[0], where[1] - 1.0, 0.0))
        assert seen[a] / seen[b] > 1.1 * floor[a] / floor[b], (kind, where, seen, floor)
    m = measure(scene, kind, combined[::-1])
    assert m["layers_cover"] == pytest.approx(0.75, abs=0.005), (kind, m)
    assert 0.3 < m["layers_floor"] / m["veil_floor"] < 0.75, (kind, m)
    mask = passes["mask"][::-1, :, 0]
    assert patch(mask, pixel(scene, (1.5, -1.6, 0.01)), 1).mean() == pytest.approx(0.7)
    assert patch(mask, pixel(scene, (0.0, -2.5, 0.0)), 1).max() == 0.0
    alpha = combined[::-1, :, 3]
    centre = patch(alpha, pixel(scene, MOVER), 0)[0, 0]
    ahead = patch(alpha, pixel(scene, (MOVER[0] + 0.4, MOVER[1], MOVER[2])), 0)[0, 0]
    assert 0.25 < centre < 0.6 and 0.02 < ahead < 0.4, (kind, centre, ahead)  # 0.4, 0.2
