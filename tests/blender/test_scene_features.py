"""Scene features the engine reads, each checked against Cycles or a closed form.

Textures (sRGB and Non-Color, mipmapped), normal maps, the world's Environment Texture,
render border, holdout, backface culling, passes in the compositor, and bad input (missing
image, unsupported node, empty scene, tiny and huge resolutions).
"""

import math

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, render_pixels, set_world_color

from bo2_lighting.addon.blender import images

RES = 32


def top_view_scene(view=2.0, res=RES):
    """Orthographic camera 1 m above the origin looking down, a sun from straight above."""
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = res
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.cycles.max_bounces = 0
    add_ortho_camera(scene, view)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = math.pi  # a white Lambert surface facing it renders 1.0
    sun.data.angle = 0.0
    scene.collection.objects.link(sun)
    set_world_color(scene)
    return scene


def checker_image(name, size=64, colorspace="sRGB", float_buffer=False):
    img = bpy.data.images.new(name, size, size, alpha=True, float_buffer=float_buffer)
    img.colorspace_settings.name = colorspace
    yy, xx = np.mgrid[0:size, 0:size]
    check = ((xx // 8 + yy // 8) % 2).astype(np.float32)
    px = np.ones((size, size, 4), np.float32)
    px[..., 0] = 0.1 + 0.8 * check
    px[..., 1] = 0.2 + 0.5 * (xx / size)
    px[..., 2] = 0.3
    img.pixels.foreach_set(px.ravel())
    img.pack()
    return img


def lambert_material(name):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.inputs["Roughness"].default_value = 1.0
    node.inputs["Specular IOR Level"].default_value = 0.0
    return mat, node


def add_plane(material, size=2.0, location=(0, 0, 0)):
    bpy.ops.mesh.primitive_plane_add(size=size, location=location)
    obj = bpy.context.object
    obj.data.materials.append(material)
    return obj


@pytest.mark.parametrize("colorspace", ["sRGB", "Non-Color"])
def test_base_color_texture_matches_cycles(addon, colorspace):
    scene = top_view_scene()
    mat, node = lambert_material("Textured")
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = checker_image("checker", colorspace=colorspace)
    mat.node_tree.links.new(tex.outputs["Color"], node.inputs["Base Color"])
    add_plane(mat)
    cycles = render_pixels(scene, "CYCLES", samples=64)[..., :3]
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., :3]
    per_pixel = np.abs(ours - cycles).mean()
    scene.bo2.shade_every_sample = True
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., :3]
    per_sample = np.abs(ours - cycles).mean()
    print(f"{colorspace}: mean absolute difference per pixel {per_pixel:.4f}, "
          f"per sample {per_sample:.4f}")
    assert per_sample < 0.02
    assert per_pixel < 0.04  # one mipmapped lookup per pixel: a blurrier checker
    # sRGB decoding: the dark squares' red is 0.1 encoded, 0.0100 linear.
    low = 0.0100 if colorspace == "sRGB" else 0.1
    assert np.percentile(ours[..., 0], 5) == pytest.approx(low, abs=0.01)


def test_normal_map_matches_cycles(addon):
    scene = top_view_scene()
    scene.objects["Sun"].rotation_euler = (math.radians(40), 0, math.radians(30))
    mat, node = lambert_material("Bumpy")
    node.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1)
    img = bpy.data.images.new("normals", 64, 64, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    yy, xx = np.mgrid[0:64, 0:64]
    angle = np.where((xx // 16) % 2 == 0, 0.4, -0.4)  # stripes tilted +-23 degrees about y
    px = np.stack([0.5 + 0.5 * np.sin(angle), np.full_like(angle, 0.5),
                   0.5 + 0.5 * np.cos(angle), np.ones_like(angle)], -1).astype(np.float32)
    img.pixels.foreach_set(px.ravel())
    img.pack()
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    tex.image = img
    tex.interpolation = "Closest"
    nmap = mat.node_tree.nodes.new("ShaderNodeNormalMap")
    mat.node_tree.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    mat.node_tree.links.new(nmap.outputs["Normal"], node.inputs["Normal"])
    add_plane(mat)
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., 0]
    cycles = render_pixels(scene, "CYCLES", samples=64)[..., 0]
    flat = 0.8 * math.cos(math.radians(40))
    assert abs(ours.mean() - flat) > 0.02 or ours.std() > 0.05  # the map changes the shading
    assert np.abs(ours - cycles).mean() < 0.03


@pytest.mark.parametrize("rotation", [None, (0.3, -0.2, 0.7)])
def test_environment_background_matches_cycles(addon, rotation):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 64, 32
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.lens = 12
    cam.rotation_euler = (math.radians(80), 0, math.radians(20))
    scene.collection.objects.link(cam)
    scene.camera = cam
    world = bpy.data.worlds.new("Env")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = checker_image("sky", size=128, colorspace="Linear Rec.709", float_buffer=True)
    background = world.node_tree.nodes["Background"]
    background.inputs["Strength"].default_value = 2.0
    world.node_tree.links.new(env.outputs["Color"], background.inputs["Color"])
    if rotation is not None:
        coords = world.node_tree.nodes.new("ShaderNodeTexCoord")
        mapping = world.node_tree.nodes.new("ShaderNodeMapping")
        mapping.inputs["Rotation"].default_value = rotation
        world.node_tree.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        world.node_tree.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    scene.world = world
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., :3]
    cycles = render_pixels(scene, "CYCLES", samples=64)[..., :3]
    assert ours.max() > 1.0  # strength applied
    assert np.abs(ours - cycles).mean() < 0.03


def test_missing_image_and_unsupported_node_warn_once(addon, capfd):
    scene = top_view_scene()
    mat, node = lambert_material("Missing")
    tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
    missing = bpy.data.images.new("gone", 4, 4)
    missing.source = "FILE"
    missing.filepath = "//no/such/file.png"
    tex.image = missing
    mat.node_tree.links.new(tex.outputs["Color"], node.inputs["Base Color"])
    noise = mat.node_tree.nodes.new("ShaderNodeTexNoise")
    mat.node_tree.links.new(noise.outputs["Fac"], node.inputs["Roughness"])
    node.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1)
    add_plane(mat)
    other, _ = lambert_material("Toon")
    other.node_tree.nodes.remove(other.node_tree.nodes["Principled BSDF"])
    toon = other.node_tree.nodes.new("ShaderNodeBsdfToon")
    other.node_tree.links.new(toon.outputs[0],
                              other.node_tree.nodes["Material Output"].inputs["Surface"])
    add_plane(other, size=0.5, location=(0, 0, 0.1))
    px = render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert np.isfinite(px).all()
    # a missing image renders Cycles' magenta
    assert px[2, 2, :3] == pytest.approx((1.0, 0.0, 1.0), rel=0.02, abs=1e-3)
    text = capfd.readouterr().out
    assert text.count("could not be loaded") == 1
    assert text.count("Noise Texture") == 1
    assert text.count("(ShaderNodeBsdfToon) feeding 'Surface' is not supported") == 1


@pytest.mark.parametrize("crop", [False, True])
def test_render_border(addon, crop):
    scene = top_view_scene()
    mat, _ = lambert_material("White")
    add_plane(mat)
    full = render_pixels(scene, "BO2_LIGHTING", samples=4)
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.25, 0.75
    scene.render.border_min_y, scene.render.border_max_y = 0.5, 1.0
    scene.render.use_crop_to_border = crop
    inside = (slice(16, 32), slice(8, 24))  # rows from the bottom, as Blender stores them
    if crop:
        scene.render.resolution_x = scene.render.resolution_y = RES  # cropped result size
        part = render_pixels(scene, "BO2_LIGHTING", samples=4, size=(16, 16))
        np.testing.assert_allclose(part, full[inside], atol=1e-6)
        return
    part = render_pixels(scene, "BO2_LIGHTING", samples=4)
    np.testing.assert_allclose(part[inside], full[inside], atol=1e-6)
    outside = np.ones((RES, RES), bool)
    outside[inside] = False
    assert np.abs(part[outside]).max() == 0.0


def test_render_border_between_pixels(addon):
    """A border whose edges fall inside pixels: Blender's result holds the pixels from
    trunc(min * size) to trunc(max * size), each product in float32 (its render pipeline's
    disprect); the tiles fill exactly that (an 8K frame's 2% border had failed with one row
    and column too many) and match the full render there."""
    scene = top_view_scene()
    mat, _ = lambert_material("White")
    add_plane(mat)
    full = render_pixels(scene, "BO2_LIGHTING", samples=4)
    r = scene.render
    r.use_border, r.use_crop_to_border = True, False
    r.border_min_x, r.border_max_x = 0.31, 0.77
    r.border_min_y, r.border_max_y = 0.43, 0.91
    part = render_pixels(scene, "BO2_LIGHTING", samples=4)
    edge = [int(np.float32(f) * np.float32(RES)) for f in (r.border_min_x, r.border_max_x,
                                                           r.border_min_y, r.border_max_y)]
    inside = (slice(edge[2], edge[3]), slice(edge[0], edge[1]))  # rows from the bottom
    np.testing.assert_allclose(part[inside], full[inside], atol=1e-6)
    outside = np.ones((RES, RES), bool)
    outside[inside] = False
    assert np.abs(part[outside]).max() == 0.0


def test_holdout_and_backface_culling(addon):
    scene = top_view_scene()
    scene.objects["Sun"].data.use_shadow = False  # culled faces still cast shadows
    mat, _ = lambert_material("White")
    add_plane(mat)
    hole = add_plane(mat, size=0.5, location=(0.5, 0.5, 0.2))
    holdouts = bpy.data.collections.new("Holdouts")  # holdout set on the view layer
    scene.collection.children.link(holdouts)
    scene.collection.objects.unlink(hole)
    holdouts.objects.link(hole)
    bpy.context.view_layer.layer_collection.children["Holdouts"].holdout = True
    culled, _ = lambert_material("Culled")
    culled.use_backface_culling = True
    back = add_plane(culled, size=0.5, location=(-0.5, -0.5, 0.2))
    back.rotation_euler = (math.pi, 0, 0)  # facing away from the camera
    px = render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert px[24, 24, 3] == 0.0 and px[24, 24, :3].max() == 0.0  # holdout: nothing, alpha 0
    assert px[8, 8, 0] == pytest.approx(0.8, rel=0.02)  # culled plane shows the floor
    assert px[16, 4, 3] == 1.0


def test_camera_and_shadow_ray_visibility_as_cycles(addon):
    """A card above the floor in the sun: the Object > Visibility toggles change the picture as
    they change Cycles' (camera off: the floor shows, in the card's shadow; shadow off: the
    card shows and the floor beside it is lit)."""
    scene = top_view_scene()
    mat, node = lambert_material("White")
    node.inputs["Base Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    add_plane(mat)
    card_mat, card_node = lambert_material("Card")
    card = add_plane(card_mat, size=1.0, location=(0.0, 0.0, 0.3))
    for camera, shadow in ((True, True), (False, True), (True, False), (False, False)):
        card.visible_camera, card.visible_shadow = camera, shadow
        got = [render_pixels(scene, engine, samples=16)[16, 16, 0]
               for engine in ("BO2_LIGHTING", "CYCLES")]
        assert got[0] == pytest.approx(got[1], abs=0.03), (camera, shadow, got)


def test_passes_reach_the_compositor(addon):
    scene = top_view_scene()
    view_layer = bpy.context.view_layer
    view_layer.use_pass_z = True
    view_layer.use_pass_diffuse_direct = True
    view_layer.bo2.use_pass_gloss = True
    scene.render.engine = "BO2_LIGHTING"
    if bpy.app.version >= (5, 0, 0):
        tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
        scene.compositing_node_group = tree
    else:
        scene.use_nodes = True
        tree = scene.node_tree
    layers = tree.nodes.new("CompositorNodeRLayers")
    layers.scene = scene
    outputs = {s.name for s in layers.outputs if s.enabled}
    diffuse = "DiffDir" if bpy.app.version < (5, 0, 0) else "Diffuse Direct"
    assert {"Image", "Depth", diffuse, "Gloss"} <= outputs
    assert "Albedo" not in outputs


def test_empty_scene_tiny_resolution(addon):
    scene = top_view_scene(res=4)
    scene.render.resolution_percentage = 25  # 1 x 1 pixel
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.3, 0.4, 1)
    px = render_pixels(scene, "BO2_LIGHTING", samples=4)
    assert px.shape == (1, 1, 4)
    np.testing.assert_allclose(px[0, 0], [0.2, 0.3, 0.4, 1.0], rtol=1e-5)


def test_8k_renders_in_tiles(addon):
    scene = top_view_scene()
    mat, _ = lambert_material("White")
    add_plane(mat, size=1.0)
    scene.render.resolution_x, scene.render.resolution_y = 7680, 4320
    scene.render.resolution_percentage = 100
    px = render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert px.shape == (4320, 7680, 4)
    assert px[2160, 3840, 0] == pytest.approx(0.8, rel=0.02)
    assert px[0, 0, 3] == 1.0 and px[0, 0, 0] == 0.0


def test_antialiased_edges_match_cycles(addon):
    """A white emitter over black, its edges at arbitrary angles: Cycles' Blackman-Harris
    filter and ours give the same edge pixels."""
    scene = top_view_scene(view=2.0, res=48)
    scene.objects["Sun"].data.energy = 0.0
    mat = bpy.data.materials.new("Emitter")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(emission.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    square = add_plane(mat, size=1.1)
    square.rotation_euler = (0, 0, math.radians(17))
    ours = render_pixels(scene, "BO2_LIGHTING", samples=64)[..., 0]
    cycles = render_pixels(scene, "CYCLES", samples=256)[..., 0]
    edge = (cycles > 0.02) & (cycles < 0.98)
    difference = np.abs(ours - cycles)[edge]
    print(f"edges: {edge.sum()} pixels, mean difference {difference.mean():.4f}, "
          f"max {difference.max():.4f}")
    assert edge.sum() > 40
    assert difference.mean() < 0.03


def render_passes(scene, engine: str, samples: int) -> dict[str, np.ndarray]:
    """Render and read every pass from a multilayer EXR: {name: (H, W, C)}, channels in
    Blender's order (X Y Z, U V A, R G B A), row 0 at the top."""
    import tempfile
    from pathlib import Path

    import OpenEXR

    render_pixels(scene, engine, samples=samples)
    order = "XYZUVRGBA"
    channels: dict[str, dict[str, np.ndarray]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "passes.exr")
        images.save_render_result(scene, path, "OPEN_EXR_MULTILAYER", "32")
        for part in OpenEXR.File(path, separate_channels=True).parts:
            for full, channel in part.channels.items():
                _, name, letter = full.split(".")  # ViewLayer.<pass>.<channel>
                channels.setdefault(name, {})[letter] = channel.pixels
    return {name: np.stack([c[k] for k in sorted(c, key=order.index)], -1)
            for name, c in channels.items()}


def test_gbuffer_passes_match_cycles(addon):
    """Position, UV, Normal, Depth and material index: the same G-buffer as Cycles writes."""
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 48, 36
    scene.render.resolution_percentage = 100
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (0.5, -4.0, 2.5), (math.radians(60), 0, math.radians(5))
    scene.collection.objects.link(cam)
    scene.camera = cam
    set_world_color(scene)
    floor_mat, _ = lambert_material("Floor")
    floor_mat.pass_index = 2
    ball_mat, _ = lambert_material("Ball")
    ball_mat.pass_index = 5
    add_plane(floor_mat, size=6.0).rotation_euler = (0.1, 0.2, 0.3)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(0.3, 0.2, 0.8))
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(ball_mat)
    layer = bpy.context.view_layer
    for flag in ("use_pass_position", "use_pass_uv", "use_pass_material_index",
                 "use_pass_normal", "use_pass_z"):
        setattr(layer, flag, True)
    ours = render_passes(scene, "BO2_LIGHTING", 16)
    cycles = render_passes(scene, "CYCLES", 16)
    index_name = "IndexMA" if bpy.app.version < (5, 0, 0) else "Material Index"
    names = {"Combined", "Position", "UV", index_name, "Normal", "Depth"}
    assert set(ours) == names and names <= set(cycles)
    index = ours[index_name][..., 0]
    assert {2.0, 5.0} <= set(np.unique(index)) <= {0.0, 2.0, 5.0}  # 0: the background
    # Interior pixels: the 3 x 3 neighbourhood sees one material in both engines. The index
    # may differ only next to a boundary (each engine takes it from one of the pixel's samples).
    same = np.ones_like(index, bool)
    padded = [np.pad(im, 1, mode="edge") for im in (index, cycles[index_name][..., 0])]
    h, w = index.shape
    for dy in range(3):
        for dx in range(3):
            for image in padded:
                same &= image[dy:dy + h, dx:dx + w] == index
    assert np.all(index[same] == cycles[index_name][..., 0][same])
    assert same.mean() > 0.7
    for name, tol in (("Position", 2e-3), ("UV", 2e-3), ("Normal", 2e-2), ("Depth", 2e-3)):
        diff = np.abs(ours[name] - cycles[name])[same].mean()
        print(f"{name}: mean |BO2 - Cycles| over interior pixels {diff:.2e}")
        assert diff < tol, name


def add_instances(material):
    """A collection instance, geometry-nodes instances and particle instances (their emitter
    hidden in renders), all made of small white shapes seen from above."""
    scene = bpy.context.scene
    source = bpy.data.collections.new("Source")  # not linked to the scene: only instanced
    bpy.ops.mesh.primitive_cube_add(size=0.3)
    cube = bpy.context.object
    cube.data.materials.append(material)
    for coll in list(cube.users_collection):
        coll.objects.unlink(cube)
    source.objects.link(cube)
    empty = bpy.data.objects.new("CollectionInstance", None)
    empty.instance_type = "COLLECTION"
    empty.instance_collection = source
    empty.location = (-0.6, 0.6, 0.0)
    scene.collection.objects.link(empty)

    tree = bpy.data.node_groups.new("Instances", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    grid = tree.nodes.new("GeometryNodeMeshGrid")
    grid.inputs["Size X"].default_value = grid.inputs["Size Y"].default_value = 0.6
    grid.inputs["Vertices X"].default_value = grid.inputs["Vertices Y"].default_value = 3
    box = tree.nodes.new("GeometryNodeMeshCube")
    box.inputs["Size"].default_value = (0.12, 0.12, 0.12)
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    set_material = tree.nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = material
    out = tree.nodes.new("NodeGroupOutput")
    tree.links.new(grid.outputs["Mesh"], on_points.inputs["Points"])
    tree.links.new(box.outputs["Mesh"], set_material.inputs["Geometry"])
    tree.links.new(set_material.outputs["Geometry"], on_points.inputs["Instance"])
    tree.links.new(on_points.outputs["Instances"], out.inputs["Geometry"])
    bpy.ops.mesh.primitive_plane_add(size=0.1, location=(0.6, 0.6, 0.0))
    bpy.context.object.modifiers.new("Instances", "NODES").node_group = tree

    bpy.ops.mesh.primitive_ico_sphere_add(radius=0.05, location=(0, 0, -5))
    ball = bpy.context.object
    ball.data.materials.append(material)
    ball.hide_render = True  # only its particle instances render
    bpy.ops.mesh.primitive_plane_add(size=0.8, location=(0.0, -0.5, 0.0))
    emitter = bpy.context.object
    emitter.data.materials.append(material)
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.count, settings.frame_start, settings.frame_end = 12, 1, 1
    settings.physics_type = "NO"
    settings.render_type = "OBJECT"
    settings.instance_object = ball
    settings.particle_size = 1.0
    emitter.show_instancer_for_render = False
    scene.frame_set(1)


def test_instances_match_cycles(addon):
    """Collection, geometry-nodes and particle instances appear where Cycles draws them, and an
    emitter hidden for renders does not."""
    scene = top_view_scene(view=2.0, res=64)
    scene.render.film_transparent = True
    mat, _ = lambert_material("White")
    add_instances(mat)
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., 3]
    cycles = render_pixels(scene, "CYCLES", samples=16)[..., 3]
    print(f"instances: coverage BO2 {ours.sum():.1f} px, Cycles {cycles.sum():.1f} px, "
          f"mean |difference| {np.abs(ours - cycles).mean():.4f}")
    assert cycles.sum() > 100  # the scene shows its instances
    assert abs(ours.sum() / cycles.sum() - 1.0) < 0.03
    assert np.abs(ours - cycles).mean() < 0.01


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_clip_end_before_clip_start_sees_nothing_as_in_cycles(addon, capfd, kind):
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 16, 12
    set_world_color(scene, (0.2, 0.3, 0.4))
    bpy.ops.mesh.primitive_plane_add(size=4.0)
    cam = add_ortho_camera(scene, 2.0)
    cam.data.type = kind
    cam.data.clip_start, cam.data.clip_end = 2.0, 0.5  # the plane is 1 m away
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    capfd.readouterr()
    bo2 = render_pixels(scene, "BO2_LIGHTING", samples=1)
    out = capfd.readouterr()
    assert "Clip End is not beyond Clip Start" in out.out + out.err
    cycles = render_pixels(scene, "CYCLES", samples=1)
    np.testing.assert_allclose(cycles[..., :3], np.broadcast_to([0.2, 0.3, 0.4], (12, 16, 3)),
                               atol=1e-4)
    np.testing.assert_allclose(bo2, cycles, atol=1e-4)
    cam.data.clip_start, cam.data.clip_end = 0.1, 10.0  # and with a range, the plane shows
    assert np.abs(render_pixels(scene, "BO2_LIGHTING", samples=1)[..., :3] - 0.3).max() > 0.05


def add_node_instances(material):
    """Geometry-nodes instances only (read at once with their instancer): a 4 x 4 grid of
    cubes, every other one mirrored and rotated, and a 3 x 3 grid of instances of an object
    (Object Info) that instances a ball on its tip itself."""
    tree = bpy.data.node_groups.new("Instances", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    grid = nodes.new("GeometryNodeMeshGrid")
    grid.inputs["Size X"].default_value = grid.inputs["Size Y"].default_value = 1.2
    grid.inputs["Vertices X"].default_value = grid.inputs["Vertices Y"].default_value = 4
    box = nodes.new("GeometryNodeMeshCube")
    box.inputs["Size"].default_value = (0.2, 0.12, 0.1)
    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = material
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    index = nodes.new("GeometryNodeInputIndex")
    modulo = nodes.new("ShaderNodeMath")
    modulo.operation = "MODULO"
    modulo.inputs[1].default_value = 2.0
    scale = nodes.new("GeometryNodeScaleInstances")
    scale.inputs["Scale"].default_value = (-1.0, 1.0, 1.0)  # mirrored
    rotate = nodes.new("GeometryNodeRotateInstances")
    rotate.inputs["Rotation"].default_value = (0.0, 0.0, 0.6)
    links.new(grid.outputs["Mesh"], on_points.inputs["Points"])
    links.new(box.outputs["Mesh"], set_material.inputs["Geometry"])
    links.new(set_material.outputs["Geometry"], on_points.inputs["Instance"])
    links.new(index.outputs[0], modulo.inputs[0])
    links.new(on_points.outputs["Instances"], scale.inputs["Instances"])
    links.new(modulo.outputs[0], scale.inputs["Selection"])
    links.new(scale.outputs["Instances"], rotate.inputs["Instances"])

    bpy.ops.mesh.primitive_cone_add(radius1=0.06, depth=0.1, location=(0, 0, -5))
    cone = bpy.context.object
    cone.data.materials.append(material)
    cone.hide_render = True  # only its instances render
    tip = bpy.data.node_groups.new("Tip", "GeometryNodeTree")  # the cone instances a ball
    tip.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tip.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    point = tip.nodes.new("GeometryNodePoints")
    point.inputs["Position"].default_value = (0.0, 0.0, 0.07)
    ball = tip.nodes.new("GeometryNodeMeshIcoSphere")
    ball.inputs["Radius"].default_value = 0.025
    ball_material = tip.nodes.new("GeometryNodeSetMaterial")
    ball_material.inputs["Material"].default_value = material
    on_tip = tip.nodes.new("GeometryNodeInstanceOnPoints")
    tip.links.new(point.outputs[0], on_tip.inputs["Points"])
    tip.links.new(ball.outputs["Mesh"], ball_material.inputs["Geometry"])
    tip.links.new(ball_material.outputs[0], on_tip.inputs["Instance"])
    both = tip.nodes.new("GeometryNodeJoinGeometry")
    tip.links.new(tip.nodes.new("NodeGroupInput").outputs[0], both.inputs[0])
    tip.links.new(on_tip.outputs["Instances"], both.inputs[0])
    tip.links.new(both.outputs[0], tip.nodes.new("NodeGroupOutput").inputs[0])
    cone.modifiers.new("Tip", "NODES").node_group = tip
    info = nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = cone
    info.inputs["As Instance"].default_value = True
    few = nodes.new("GeometryNodeMeshGrid")
    few.inputs["Size X"].default_value = few.inputs["Size Y"].default_value = 1.6
    few.inputs["Vertices X"].default_value = few.inputs["Vertices Y"].default_value = 3
    cones = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(few.outputs["Mesh"], cones.inputs["Points"])
    links.new(info.outputs["Geometry"], cones.inputs["Instance"])
    join = nodes.new("GeometryNodeJoinGeometry")
    links.new(rotate.outputs["Instances"], join.inputs[0])
    links.new(cones.outputs["Instances"], join.inputs[0])
    links.new(join.outputs[0], nodes.new("NodeGroupOutput").inputs["Geometry"])
    bpy.ops.mesh.primitive_plane_add(size=0.1, location=(0.0, 0.0, 0.1))
    bpy.context.object.modifiers.new("Instances", "NODES").node_group = tree
    bpy.context.view_layer.update()


def object_coordinates_material(name):
    """A Lambert material whose colour is its Object texture coordinates (per instance)."""
    mat, node = lambert_material(name)
    tree = mat.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    scale = tree.nodes.new("ShaderNodeVectorMath")
    scale.operation = "MULTIPLY_ADD"
    scale.inputs[1].default_value = (2.0, 2.0, 2.0)
    scale.inputs[2].default_value = (0.5, 0.5, 0.5)
    tree.links.new(coords.outputs["Object"], scale.inputs[0])
    tree.links.new(scale.outputs[0], node.inputs["Base Color"])
    return mat


def test_geometry_node_instances_read_at_once_match_cycles(addon, monkeypatch):
    """Geometry-nodes instances read at once (matrices in bulk, one batch per instanced mesh,
    mirrored and rotated ones, instances of an object, Object coordinates per instance) draw
    what Cycles draws, and what reading them one by one draws."""
    from bo2_lighting.addon.blender import extract

    scene = top_view_scene(view=2.0, res=64)
    scene.render.film_transparent = True
    add_node_instances(object_coordinates_material("Per instance"))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    core_scene, _ = extract.extract_scene(depsgraph)
    batches = {len(m.positions): m for m in core_scene.meshes}  # (and the cone itself: the
    assert batches[16 * 12].world_to_object.shape == (16, 4, 4)  # view layer's depsgraph
    assert batches[9 * 62].world_to_object.shape == (9, 4, 4)  # shows hidden_render objects)
    assert batches[9 * 20].world_to_object.shape == (9, 4, 4)  # the balls on the cones' tips
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)
    cycles = render_pixels(scene, "CYCLES", samples=16)
    monkeypatch.setattr(extract, "_readable_at_once", lambda *args: False)
    one_by_one = render_pixels(scene, "BO2_LIGHTING", samples=16)
    d = np.abs(ours - cycles)
    print(f"instances at once: coverage BO2 {ours[..., 3].sum():.1f} px, Cycles "
          f"{cycles[..., 3].sum():.1f} px, mean |d| {d.mean():.4f}")
    assert cycles[..., 3].sum() > 300
    assert abs(ours[..., 3].sum() / cycles[..., 3].sum() - 1.0) < 0.03
    # edges differ by the engines' sample positions (16 samples): coverage to 0.02 a pixel
    assert d[..., 3].mean() < 0.02 and d[..., :3].mean() < 0.01
    np.testing.assert_allclose(ours, one_by_one, atol=2e-3)
