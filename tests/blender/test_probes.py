"""Light probes end to end: bake Blender's Sphere and Volume probes, render with them, and
keep previous bakes safe from cancelled bakes and corrupt files."""

import math
from pathlib import Path

import bpy
import numpy as np
import pytest
from util import add_far_ground, baked, principled, render_pixels, set_world_color

from bo2_lighting.addon.blender import bake as blender_bake
from bo2_lighting.addon.blender import bake_files, probes
from bo2_lighting.addon.core.files import probe_file
from bo2_lighting.addon.core.render.job import Warnings
from bo2_lighting.addon.core.scene import World

RES = 48


def lambert(name, color):
    return principled(name, color, roughness=0.6)


def room(tmp_path):
    """A floor, a red wall, a white wall, a sun over the floor, a grey sky; a reflection probe
    and a 3 x 3 x 2 irradiance volume; saved, so that '//bo2_bake/' is next to the file."""
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    set_world_color(scene, (0.05, 0.05, 0.08))
    for size, loc, rot, color in [
        (6, (0, 0, 0), (0, 0, 0), (0.7, 0.7, 0.7)),
        (6, (0, 2, 1.5), (math.pi / 2, 0, 0), (0.8, 0.05, 0.05)),
        (6, (-2, 0, 1.5), (0, math.pi / 2, 0), (0.8, 0.8, 0.8)),
    ]:
        bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
        bpy.context.object.data.materials.append(lambert(f"M{color}", color))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0.3, 0.4, 0.5))
    bpy.ops.object.shade_smooth()
    chrome = lambert("Chrome", (0.9, 0.9, 0.9))
    chrome.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0
    chrome.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.15
    bpy.context.object.data.materials.append(chrome)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(35), 0, math.radians(20))  # onto both walls
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (1.5, -3.5, 2.2), (math.radians(65), 0, math.radians(20))
    scene.collection.objects.link(cam)
    scene.camera = cam
    sphere = bpy.data.objects.new("Reflection", bpy.data.lightprobes.new("Reflection", "SPHERE"))
    sphere.location = (0.3, 0.4, 0.8)
    sphere.data.influence_distance = 4.0
    scene.collection.objects.link(sphere)
    volume = bpy.data.objects.new("Irradiance", bpy.data.lightprobes.new("Irradiance", "VOLUME"))
    volume.location, volume.scale = (0, 0, 1.0), (2.5, 2.5, 1.0)
    volume.data.resolution_x = volume.data.resolution_y = 3
    volume.data.resolution_z = 2
    scene.collection.objects.link(volume)
    scene.bo2.probes.face_size = "32"
    scene.bo2.probes.volume_face_size = "8"
    scene.bo2.probes.samples = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "room.blend"))
    return scene


def bake(scene, **kw):
    assert bpy.ops.bo2.bake_probes(**kw) == {"FINISHED"}
    return bake_files.file_folder(scene)


def test_bake_writes_one_file_per_probe(addon, tmp_path):
    scene = room(tmp_path)
    folder = bake(scene)
    assert folder == tmp_path / "bo2_bake" / "room"  # the .blend's own folder
    assert sorted(p.name for p in folder.iterdir()) == sorted(
        baked(scene, n).name for n in ("Irradiance", "Reflection"))
    for name in ("Irradiance", "Reflection"):  # declared as packed image datablocks
        image = scene.objects[name].bo2.bake
        assert image.filepath == f"//bo2_bake/room/{baked(scene, name).name}"
        assert image.packed_file.data == baked(scene, name).read_bytes()
        assert baked(scene, name).name.startswith(name + "-")
    meta, sh, mips = probe_file.read(baked(scene, "Reflection"))
    assert meta["probe"] == "Reflection" and meta["kind"] == "reflection"
    assert meta["face_size"] == 32 and meta["version"] and meta["bake_time"]
    assert set(mips) == {"bo2", "bo1"} and [m.shape[1] for m in mips["bo2"]] == [32, 16, 8, 4,
                                                                               2, 1]
    assert sh.shape == (1, 9, 3) and sh[0, 0].min() > 0
    meta, sh, mips = probe_file.read(baked(scene, "Irradiance"))
    assert meta["resolution"] == [3, 3, 2] and sh.shape == (18, 9, 3)
    # the samples' depth moments (the Visibility Test): the sample at (-5/3, 0, 0.5) sees the
    # white wall (x = -2) 1/3 m away along -X, the floor 0.5 m below it: the lobes around the
    # four central texels (7 degrees off the axis) average at most 6% more than the distance
    assert set(mips) == {probe_file.DEPTH}
    depth = mips[probe_file.DEPTH][0]
    assert depth.shape == (18, 6, 8, 8, 2)
    for face, distance in ((1, 1 / 3), (5, 0.5)):  # -X, -Z
        centre = depth[2, face, 3:5, 3:5, 0]
        assert (centre > distance).all() and (centre < 1.06 * distance).all(), centre
    assert (depth[..., 1] >= depth[..., 0] ** 2 * (1 - 1e-5)).all()
    loaded = probes.load_probes(scene, World(color=np.zeros(3, np.float32)), Warnings())
    np.testing.assert_array_equal(loaded.volumes[0].moments.reshape(depth.shape), depth)
    # The red wall tints the volume's samples next to it (y = +2 side): red over green.
    grid = sh.reshape(3, 3, 2, 9, 3)
    near_red, far = grid[:, 2, 0, 0], grid[:, 0, 0, 0]
    assert (near_red[:, 0] / near_red[:, 1]).mean() > (far[:, 0] / far[:, 1]).mean()


def test_objects_hidden_from_light_probes_are_not_baked(addon, tmp_path, capfd):
    """Object > Visibility > Light Probes: the red wall hidden from Sphere probes leaves the
    reflection probe's light and keeps the volume's; hidden from Volume probes, it leaves the
    volume's light and the reflection probe still sees it.
    (The chrome ball the reflection probe sits in is hidden from Sphere probes throughout, as
    an artist hides an object from the probe at its centre: no warning that it is inside.)"""
    scene = room(tmp_path)
    wall = next(o for o in scene.objects if o.type == "MESH" and o.location.y == 2)
    scene.objects["Sphere"].hide_probe_sphere = True
    scene.bo2.probes.bounces = 1  # the volume's captures lit by the world alone

    def redness():
        bake(scene)
        return [float(sh[:, 0, 0].mean() / sh[:, 0, 1].mean())
                for sh in (probe_file.read(baked(scene, name))[1]
                           for name in ("Reflection", "Irradiance"))]

    seen = redness()
    wall.hide_probe_sphere = True
    no_sphere = redness()
    wall.hide_probe_sphere, wall.hide_probe_volume = False, True
    no_volume = redness()
    assert no_sphere[0] < seen[0] - 0.1 and no_sphere[1] == pytest.approx(seen[1], rel=1e-4)
    assert no_volume[1] < seen[1] - 0.1 and no_volume[0] > no_sphere[0] + 0.1  # still seen
    assert "inside object" not in capfd.readouterr().out


def test_baked_probes_bring_the_render_closer_to_cycles(addon, tmp_path):
    """World light alone, then the baked probes (the floor's and walls' bounce, the red wall's
    colour on the floor): each step closer to Cycles' global illumination."""
    scene = room(tmp_path)
    scene.cycles.max_bounces = 4
    cycles = render_pixels(scene, "CYCLES", samples=64)[..., :3]
    scene.bo2.indirect.use = False
    direct = render_pixels(scene, "BO2_LIGHTING", samples=4)[..., :3]
    scene.bo2.indirect.use = True
    world_only = render_pixels(scene, "BO2_LIGHTING", samples=4)[..., :3]
    bake(scene)
    baked = render_pixels(scene, "BO2_LIGHTING", samples=4)[..., :3]
    errors = [float(np.abs(img - cycles).mean()) for img in (direct, world_only, baked)]
    print("mean |BO2 - Cycles|: direct {:.4f}, world {:.4f}, baked probes {:.4f}".format(*errors))
    assert errors[2] < errors[1] < errors[0]
    assert np.isfinite(baked).all()


def test_every_normalization_and_prefilter_renders(addon, tmp_path):
    scene = room(tmp_path)
    bake(scene)
    images = {}
    for norm in ("none", "bo1", "bo2"):
        for pre in ("bo1", "bo2"):
            scene.bo2.indirect.normalization, scene.bo2.indirect.prefilter = norm, pre
            images[norm, pre] = render_pixels(scene, "BO2_LIGHTING", samples=1)[..., :3]
            assert np.isfinite(images[norm, pre]).all()
    # The old/new pairs differ (on the chrome ball's reflections).
    assert np.abs(images["bo1", "bo2"] - images["bo2", "bo2"]).max() > 1e-3
    assert np.abs(images["bo2", "bo1"] - images["bo2", "bo2"]).max() > 1e-3
    assert np.abs(images["none", "bo2"] - images["bo2", "bo2"]).max() > 1e-3


def test_cancelled_bake_keeps_the_previous_files_byte_identical(addon, tmp_path):
    scene = room(tmp_path)
    folder = bake(scene)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    scene.objects["Sun"].data.energy = 10.0  # a different bake would differ
    steps = blender_bake.bake_steps(scene, probes.probe_objects(scene))
    assert 0 < next(steps) < 1
    next(steps)
    steps.close()  # cancelled halfway
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before


def test_corrupt_or_stale_bake_warns_and_falls_back_to_the_world(addon, tmp_path, capfd):
    scene = room(tmp_path)
    scene.bo2.indirect.use = True
    scene.bo2.bake_pack = False  # the files on disk are what renders
    world_only = render_pixels(scene, "BO2_LIGHTING", samples=1)
    bake(scene)
    reflection, irradiance = baked(scene, "Reflection"), baked(scene, "Irradiance")
    reflection.write_bytes(b"not an exr at all")
    irradiance.unlink()
    capfd.readouterr()
    px = render_pixels(scene, "BO2_LIGHTING", samples=1)
    np.testing.assert_allclose(px, world_only, atol=1e-6)
    captured = capfd.readouterr()
    err = captured.out + captured.err  # Blender prints operator reports on stdout
    assert f"{reflection.name}: not a readable probe file" in err
    assert f"{irradiance}: the bake file is missing" in err
    # Moving a probe after its bake makes the bake stale.
    bake(scene)
    scene.objects["Reflection"].location.x += 1.0
    capfd.readouterr()
    render_pixels(scene, "BO2_LIGHTING", samples=1)
    captured = capfd.readouterr()
    assert "the bake is stale" in captured.out + captured.err


def test_unsaved_file_and_no_probes_are_clear_errors(addon):
    with pytest.raises(RuntimeError, match="No Sphere or Volume light probes"):
        bpy.ops.bo2.bake_probes()
    probe = bpy.data.objects.new("P", bpy.data.lightprobes.new("P", "SPHERE"))
    bpy.context.scene.collection.objects.link(probe)
    with pytest.raises(RuntimeError, match="Save the .blend file first"):
        bpy.ops.bo2.bake_probes()


def test_clear_deletes_the_bakes(addon, tmp_path):
    scene = room(tmp_path)
    folder = bake(scene)
    assert bpy.ops.bo2.clear_probes() == {"FINISHED"}
    assert list(Path(folder).iterdir()) == []
    assert not [i for i in bpy.data.images if i.name.startswith("BO2 bake")]
    assert all(probes.bake_state(o).state == "MISSING" for o in probes.probe_objects(scene))


def test_sphere_probe_parallax_follows_its_influence_or_custom_parallax(addon):
    data = bpy.data.lightprobes.new("P", "SPHERE")
    obj = bpy.data.objects.new("P", data)
    bpy.context.scene.collection.objects.link(obj)
    obj.location, obj.scale = (1.0, 2.0, 0.5), (2.0, 1.0, 1.0)
    bpy.context.view_layer.update()
    data.influence_distance = 3.0
    s = probes.spec(obj)
    assert (s.proxy, s.proxy_distance) == ("sphere", 3.0)
    data.influence_type = "BOX"
    assert probes.spec(obj).proxy == "box"
    data.use_custom_parallax = True
    data.parallax_type, data.parallax_distance = "ELIPSOID", 1.5
    s = probes.spec(obj)
    assert (s.proxy, s.proxy_distance) == ("sphere", 1.5)
    probe = s.probe(np.zeros((1, 9, 3), np.float32), {"bo2": [], "bo1": []})
    # the proxy is the object's frame scaled by the distance: x half-extent 2 * 1.5 = 3 m
    np.testing.assert_allclose(probe.proxy_to_world[:3, :3], np.diag([3.0, 1.5, 1.5]))
    np.testing.assert_allclose(probe.proxy_to_world[:3, 3], [1.0, 2.0, 0.5])
    volume = bpy.data.objects.new("V", bpy.data.lightprobes.new("V", "VOLUME"))
    assert probes.spec(volume).proxy == "none"


def test_a_probe_inside_an_object_is_named(addon, tmp_path):
    scene = room(tmp_path)
    bpy.ops.mesh.primitive_cube_add(size=0.6, location=scene.objects["Reflection"].location)
    bpy.context.object.name = "Crate"
    warnings = Warnings()
    bpy.context.view_layer.update()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    steps = blender_bake.bake_steps(scene, [scene.objects["Reflection"]],
                                    warnings=warnings)
    next(steps)
    steps.close()
    # the room's probe sits inside the chrome sphere too
    assert "Light probe 'Reflection' seems to be inside object 'Crate', 'Sphere'" in " ".join(
        warnings)
    assert blender_bake.enclosing_objects(scene, depsgraph, (0.0, 0.0, 3.0)) == []
    # a room modelled as a closed box with outward normals around the probe is not a prop
    for name in ("Crate", "Sphere"):
        bpy.data.objects.remove(bpy.data.objects[name])
    bpy.ops.mesh.primitive_cube_add(size=12.0, location=(0.0, 0.0, 1.0))
    bpy.context.view_layer.update()
    warnings = Warnings()
    steps = blender_bake.bake_steps(scene, [scene.objects["Reflection"]], warnings=warnings)
    next(steps)
    steps.close()
    assert not any("inside object" in w for w in warnings)


def _volume_irradiance(scene, backend: str) -> np.ndarray:
    """(K,) the Irradiance volume's samples' constant SH term (green), baked by ``backend``."""
    for _ in blender_bake.bake_steps(scene, [scene.objects["Irradiance"]], backend):
        pass
    _, sh, _ = probe_file.read(baked(scene, "Irradiance"))
    return sh[:, 0, 1]


def test_a_far_ground_keeps_the_captures_shadows(addon, tmp_path):
    """A 10 km ground 50 m below the room changes the volume's samples as Cycles' captures
    say (a few percent): the suns' shadow maps of a bake cover the region the probes see, not
    every caster (over 10 km the room's shadows were gone: +50% in the sphere's shadow)."""
    scene = room(tmp_path)
    # a shelf between the sun and the volume's middle sample, whose shadow it sits in
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.2, -0.54, 1.3))
    bpy.context.object.data.materials.append(lambert("Shelf", (0.6, 0.6, 0.6)))
    scene.bo2.probes.bounces = 1  # as Cycles' backend: the world and one bounce of the lights
    scene.bo2.probes.cycles_samples = 16
    before = {b: _volume_irradiance(scene, b) for b in ("BO2", "CYCLES")}
    add_far_ground(scene)
    after = {b: _volume_irradiance(scene, b) for b in ("BO2", "CYCLES")}
    change = after["BO2"] / before["BO2"]
    truth = after["CYCLES"] / before["CYCLES"]
    assert np.abs(change - truth).max() < 0.08, (change, truth)


def test_captures_see_the_scene_as_renders_do(addon, tmp_path):
    """An object shown in renders only (disabled in viewports) and a Subdivision Surface at
    its Render level are in the probes' captures, as in F12."""
    scene = room(tmp_path)
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(0.3, -1.2, 0.8),
                                     rotation=(math.pi / 2, 0, 0))
    panel = bpy.context.object
    glow = bpy.data.materials.new("Glow")
    if glow.node_tree is None:
        glow.use_nodes = True
    bsdf = glow.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Emission Color" if "Emission Color" in bsdf.inputs else "Emission"] \
        .default_value = (0.0, 0.0, 1.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 20.0
    panel.data.materials.append(glow)

    def blue():
        for _ in blender_bake.bake_steps(scene, [scene.objects["Reflection"]]):
            pass
        _, sh, _ = probe_file.read(baked(scene, "Reflection"))
        return sh[0, 0, 2] / sh[0, 0, 0]

    shown = blue()
    panel.hide_viewport = True  # the monitor icon: not in the viewport's evaluation at all
    assert blue() == pytest.approx(shown, rel=1e-3)
    panel.hide_render = True
    assert blue() < 0.5 * shown
