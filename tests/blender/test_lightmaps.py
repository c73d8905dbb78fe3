"""Lightmaps end to end in Blender: which objects are static, layouts (the object's own map or
one made by the bake), Bake Lightmaps, rendering with them, stale and damaged files, cancel."""

import math

import bpy
import numpy as np
import pytest
from util import add_far_ground, baked, principled, render_extraction, set_world_color

from bo2_lighting.addon.blender import bake as blender_bake
from bo2_lighting.addon.blender import engine, extract, lightmaps
from bo2_lighting.addon.core.bakes import lightmap_bake
from bo2_lighting.addon.core.files import lightmap_file
from bo2_lighting.addon.core.render import pipeline
from bo2_lighting.addon.core.render.job import RenderJob, Warnings


def room(tmp_path):
    """An open box (floor, three walls) with a block on the floor, a sun through the open
    side and a blue sky; saved, so that '//bo2_bake/' is next to the file."""
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 40
    scene.render.resolution_percentage = 100
    set_world_color(scene, (0.3, 0.4, 0.6))
    for name, size, loc, rot in [("Floor", 4, (0, 0, 0), (0, 0, 0)),
                                 ("Back", 4, (0, 2, 1), (math.pi / 2, 0, 0)),
                                 ("Left", 4, (-2, 0, 1), (0, math.pi / 2, 0))]:
        bpy.ops.mesh.primitive_plane_add(size=size, location=loc, rotation=rot)
        bpy.context.object.name = name
        bpy.context.object.data.materials.append(principled(f"M{name}", (0.7, 0.7, 0.7), 0.8))
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.4, 0.6, 0.4))
    bpy.context.object.name = "Block"
    bpy.context.object.data.materials.append(principled("Red", (0.8, 0.1, 0.1), 0.8))
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (math.radians(40), 0, math.radians(-30))
    scene.collection.objects.link(sun)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (2.5, -3.5, 2.5), (math.radians(60), 0, math.radians(35))
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.lightmaps.density = 8.0
    scene.bo2.lightmaps.rays = 32
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "room.blend"))
    return scene


def test_static_objects_follow_the_setting_and_animation(addon, tmp_path):
    scene = room(tmp_path)
    names = [o.name for o in lightmaps.lightmap_objects(scene)]
    assert names == ["Back", "Block", "Floor", "Left"]
    block = scene.objects["Block"]
    block.keyframe_insert("location", frame=1)
    assert not lightmaps.is_static(block)  # animated: dynamic on Auto
    block.bo2.lightmap_mode = "STATIC"
    assert lightmaps.is_static(block)
    scene.objects["Floor"].bo2.lightmap_mode = "DYNAMIC"
    assert "Floor" not in [o.name for o in lightmaps.lightmap_objects(scene)]
    texels, size = lightmaps.estimate(scene, lightmaps.lightmap_objects(scene))
    # three 2 x 2 m planes at 8 texels per metre, with the charts' area and padding
    assert 3 * 16 * 16 < texels < 3 * 40 * 40 and size == texels * 12


def test_bake_and_render_with_lightmaps(addon, tmp_path):
    scene = room(tmp_path)
    floor = scene.objects["Floor"]
    # the floor's own lightmap UV map, laid out by hand: used as it is
    uv = floor.data.uv_layers.new(name="LightmapUV")
    assert bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="ALL") == {"FINISHED"}
    folder = tmp_path / "bo2_bake" / "room" / "lightmaps"
    names = ("Back", "Block", "Floor", "Left")
    assert sorted(p.name for p in folder.iterdir()) == sorted(baked(scene, n).name for n in names)
    assert all(scene.objects[n].bo2.bake.packed_file is not None for n in names)
    meta, lm = lightmap_file.read(baked(scene, "Floor"))
    assert meta["uv_map"] == "LightmapUV" and meta["object"] == "Floor"
    assert np.allclose(lm.uvs.reshape(-1, 2).min(0), 0.0, atol=1e-6)  # the plane's own 0..1
    del uv
    meta, lm = lightmap_file.read(baked(scene, "Block"))
    assert meta["uv_map"] == ""  # the cube's UV map overlaps nothing but has no LightmapUV
    assert np.isfinite(lm.image).all() and lm.image.min() >= 0.0
    # the floor's lightmap is darker beside the block's base than in the open
    _, floor_lm = lightmap_file.read(baked(scene, "Floor"))
    from bo2_lighting.addon.core.lighting import lightmap

    def floor_at(x, y):  # the plane's UVs: (x + 2) / 4, (y + 2) / 4
        return lightmap.sample(floor_lm.image, np.array([[(x + 2) / 4, (y + 2) / 4]]))[0]

    assert floor_at(0.4, 0.15)[1] < 0.9 * floor_at(-1.0, -1.5)[1]
    # the render reads them: its Diffuse Indirect differs from the probes'
    depsgraph = bpy.context.evaluated_depsgraph_get()
    core, warnings = extract.extract_scene(depsgraph, indirect=True)
    assert all(m.lightmap is not None for m in core.meshes), warnings
    assert not any("stale" in w for w in warnings)
    with_maps = pipeline.render_frame(RenderJob(core))["DiffInd"]
    core.settings.lightmaps = False
    without = pipeline.render_frame(RenderJob(core))["DiffInd"]
    assert np.isfinite(with_maps).all()
    assert np.abs(with_maps - without).mean() > 0.01 * without.mean()
    # the scene toggle and the object's own
    scene.bo2.lightmaps.use = False
    core, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), indirect=True)
    assert all(m.lightmap is None for m in core.meshes)
    scene.bo2.lightmaps.use = True
    scene.objects["Left"].bo2.use_lightmap = False
    core, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), indirect=True)
    assert [m.name for m in core.meshes if m.lightmap is None] == ["Left"]


def test_stale_damaged_and_misfit_lightmaps_are_reported(addon, tmp_path):
    scene = room(tmp_path)
    assert bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="ALL") == {"FINISHED"}
    scene.objects["Sun"].data.energy = 5.0
    core, warnings = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), indirect=True)
    assert any("are stale" in w for w in warnings)
    assert all(m.lightmap is not None for m in core.meshes)  # used until re-baked
    scene.objects["Left"].bo2.bake.unpack(method="REMOVE")  # the file on disk renders
    baked(scene, "Left").write_bytes(b"not an exr")
    bpy.ops.object.select_all(action="DESELECT")
    block = scene.objects["Block"]
    block.modifiers.new("Sub", "SUBSURF")
    core, warnings = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), indirect=True)
    lit = {m.name: m.lightmap is not None for m in core.meshes}
    assert lit == {"Floor": True, "Back": True, "Left": False, "Block": False}
    assert any("'Left'" in w and "not a readable lightmap" in w for w in warnings)
    assert any("'Block' was baked for 12 triangles" in w for w in warnings)
    assert lightmaps.state(scene.objects["Left"], scene)[0] == "DAMAGED"
    assert lightmaps.state(scene.objects["Floor"], scene)[0] == "BAKED"


def test_cancelled_bake_keeps_the_previous_lightmaps(addon, tmp_path, monkeypatch):
    # every step reported (not one a second): a fast machine bakes this room in one step
    monkeypatch.setattr(lightmap_bake, "STEP_SECONDS", 0.0)
    scene = room(tmp_path)
    assert bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="ALL") == {"FINISHED"}
    folder = tmp_path / "bo2_bake" / "room" / "lightmaps"
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    scene.objects["Sun"].data.energy = 9.0
    steps = blender_bake.lightmap_steps(scene, lightmaps.lightmap_objects(scene))
    fractions = [next(steps) for _ in range(2)]  # the files are written after the last
    steps.close()
    assert fractions == sorted(fractions)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before


def test_bad_input_is_one_message(addon, tmp_path):
    scene = room(tmp_path)
    # a flat object: no area
    mesh = bpy.data.meshes.new("Flat")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (2, 0, 0)], [], [(0, 1, 2)])
    flat = bpy.data.objects.new("Flat", mesh)
    scene.collection.objects.link(flat)
    warnings = Warnings()
    steps = blender_bake.lightmap_steps(scene, [flat, scene.objects["Floor"]],
                                        warnings=warnings)
    for _ in steps:
        pass
    assert any("'Flat'" in w and ("no surface area" in w or "no faces" in w) for w in warnings)
    # an overlapping UV map named for the lightmap: refused, laid out anew
    floor = scene.objects["Floor"]
    uv = floor.data.uv_layers.new(name="LightmapUV")
    for loop, corner in zip(uv.uv, [(0, 0), (1, 0), (1, 1), (0.8, 0.2)], strict=True):
        loop.vector = corner  # the second triangle folds back over the first
    warnings = Warnings()
    for _ in blender_bake.lightmap_steps(scene, [floor],
                                         warnings=warnings):
        pass
    assert any("UV map 'LightmapUV'" in w and "a layout is made" in w for w in warnings)
    meta, _ = lightmap_file.read(baked(scene, "Floor"))
    assert meta["uv_map"] == ""
    # a Lightmap UV map the object does not have: said, and a layout is made
    floor.data.uv_layers.remove(floor.data.uv_layers["LightmapUV"])
    floor.bo2.lightmap_uv = "Nope"
    warnings = Warnings()
    for _ in blender_bake.lightmap_steps(scene, [floor], warnings=warnings):
        pass
    assert any("Lightmap UV map 'Nope' is not one of its UV maps" in w for w in warnings)
    floor.bo2.lightmap_uv = ""
    # a density beyond the memory cap
    scene.bo2.lightmaps.density = 1000.0
    scene.bo2.lightmaps.max_resolution = "4096"
    scene.bo2.lightmaps.directional = True
    with pytest.raises(blender_bake.BakeError, match="MiB, more than"):
        for _ in blender_bake.lightmap_steps(scene, lightmaps.lightmap_objects(scene)):
            pass
    # an unwritable folder
    scene.bo2.lightmaps.density = 8.0
    scene.bo2.bake_folder = str(tmp_path / "room.blend")  # a file, not a folder
    with pytest.raises(RuntimeError, match="is a file, not a folder"):
        bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="ALL")


def test_cycles_backend_agrees_and_leaves_nothing_behind(addon, tmp_path):
    scene = room(tmp_path)
    scene.bo2.lightmaps.density = 4.0
    scene.bo2.probes.cycles_samples = 16
    objs = [scene.objects["Floor"], scene.objects["Block"]]
    objs[1].modifiers.new("Bevel", "BEVEL")  # baked as its evaluated copy
    floor = scene.objects["Floor"]
    nodes_before = {m.name: len(m.node_tree.nodes) for m in bpy.data.materials if m.node_tree}
    uv_before = [uv.name for uv in floor.data.uv_layers]
    for _ in blender_bake.lightmap_steps(scene, objs,
                                         backend="CYCLES"):
        pass
    meta, cycles = lightmap_file.read(baked(scene, "Floor"))
    assert meta["backend"] == "CYCLES"
    scene.bo2.lightmaps.rays = 128
    for _ in blender_bake.lightmap_steps(scene, objs):
        pass
    _, ours = lightmap_file.read(baked(scene, "Floor"))
    inside = cycles.image[..., 1] > 0
    ratio = ours.image[inside, 1].mean() / cycles.image[inside, 1].mean()
    assert 0.75 < ratio < 1.25, ratio
    assert [uv.name for uv in floor.data.uv_layers] == uv_before
    assert {m.name: len(m.node_tree.nodes) for m in bpy.data.materials
            if m.node_tree} == nodes_before
    assert not any(i.name.startswith("BO2 Lightmap Bake") for i in bpy.data.images)
    assert not any(o.name.startswith("BO2 Lightmap Bake") for o in bpy.data.objects)
    assert not any(o.hide_render for o in scene.objects)
    _, block = lightmap_file.read(baked(scene, "Block"))
    assert len(block.uvs) > 12 and np.isfinite(block.image).all()  # the bevelled triangles


def test_the_viewport_sees_a_new_bake_and_nothing_else(addon, tmp_path):
    from bo2_lighting.addon.blender import viewport

    scene = room(tmp_path)
    scene.bo2.lightmaps.rays = 16
    assert bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="ALL") == {"FINISHED"}
    cache = extract.SceneCache()

    def extraction():
        return extract.extract_scene(bpy.context.evaluated_depsgraph_get(), indirect=True,
                                     cache=cache)[0]

    first = extraction()
    again = extraction()
    assert all(m.lightmap is not None for m in again.meshes)
    assert "geometry" not in viewport._differences(first, again)  # nothing re-prepared
    scene.bo2.lightmaps.rays = 32
    for obj in scene.objects:
        obj.select_set(obj.name == "Floor")
    assert bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="SELECTED") == {"FINISHED"}
    assert "geometry" in viewport._differences(again, extraction())  # the new floor lightmap


def test_subdivided_objects_are_baked_as_they_render(addon, tmp_path):
    """A Subdivision Surface at Blender's defaults (Levels Viewport 1, Render 2): the bake reads
    the render's mesh, so renders use every lightmap and call none stale; the viewport, whose
    mesh differs, lights that object with the probes and says why, the others still fresh.
    Cycles' bake of the same objects (its stand-in is the render's mesh too) agrees."""
    scene = room(tmp_path)
    block = scene.objects["Block"]
    sub = block.modifiers.new("Subdivision", "SUBSURF")
    assert (sub.levels, sub.render_levels) == (1, 2)
    warnings = Warnings()
    steps = blender_bake.lightmap_steps(scene, lightmaps.lightmap_objects(scene),
                                        warnings=warnings)
    for _ in steps:
        pass
    meta, lm = lightmap_file.read(baked(scene, "Block"))
    assert len(lm.uvs) == 12 * 16 and meta["viewport_triangles"] == 12 * 4
    core, warnings = render_extraction(scene, indirect=True)
    assert all(m.lightmap is not None for m in core.meshes), warnings
    assert not any("stale" in w or "was baked for" in w for w in warnings), warnings
    # F12 says nothing either
    with engine.listening() as said:
        assert bpy.ops.render.render() == {"FINISHED"}
    assert not any("stale" in w or "was baked for" in w for w in said.texts())
    assert any(m.kind == "INFO" and m.text.startswith("Frame rendered in")
               for m in said.messages)
    # the viewport: the block by the probes, the rest by their lightmaps, nothing stale
    core, warnings = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), indirect=True)
    lit = {m.name: m.lightmap is not None for m in core.meshes}
    assert lit == {"Floor": True, "Back": True, "Left": True, "Block": False}
    assert any("'Block' are baked for the render's meshes" in w for w in warnings), warnings
    assert not any("stale" in w or "was baked for" in w for w in warnings), warnings
    # Cycles' bake of the same objects, at the render's subdivision
    ours = lm.image
    scene.bo2.probes.cycles_samples = 16
    for _ in blender_bake.lightmap_steps(scene, [block], backend="CYCLES"):
        pass
    _, cycles = lightmap_file.read(baked(scene, "Block"))
    assert len(cycles.uvs) == 12 * 16
    inside = cycles.image[..., 1] > 0
    ratio = ours[inside, 1].mean() / cycles.image[inside, 1].mean()
    assert 0.8 < ratio < 1.25, ratio


def test_a_far_ground_keeps_shadows_and_bounces(addon, tmp_path):
    """A 10 km ground 50 m below the room (a terrain, an ocean) changes its lightmaps as
    little as Cycles' bake says it does: ray offsets follow the float precision at each
    texel, not the scene's size, and the direct light the bounces carry is ray traced, not
    read from shadow maps spread over 10 km."""
    scene = room(tmp_path)
    scene.bo2.lightmaps.rays = 64
    scene.bo2.probes.cycles_samples = 32
    objs = [scene.objects[n] for n in ("Back", "Floor", "Left")]
    means = {}
    for ground in (False, True):
        if ground:
            add_far_ground(scene)
        for backend in ("CYCLES", "BO2"):
            for _ in blender_bake.lightmap_steps(scene, objs, backend=backend):
                pass
            _, floor = lightmap_file.read(baked(scene, "Floor"))
            if backend == "CYCLES":  # the texels Cycles bakes (its margin is black)
                inside = floor.image[..., 1] > 0
            means[ground, backend] = floor.image[inside, 1].mean()
            if backend == "BO2" and ground:
                # the block's shadow and contact darkening are still there
                assert floor.image[..., 1].min() < 0.3 * floor.image[..., 1].mean()
    for ground in (False, True):
        floor_ratio = means[ground, "BO2"] / means[ground, "CYCLES"]
        assert 0.93 < floor_ratio < 1.07, (ground, means)
    # what the ground changes, as Cycles sees it
    change = means[True, "BO2"] / means[False, "BO2"]
    truth = means[True, "CYCLES"] / means[False, "CYCLES"]
    assert abs(change - truth) < 0.04, (change, truth)


def test_a_deleted_lightmap_file_is_said(addon, tmp_path):
    """Lightmaps kept beside the .blend (not packed): a file deleted since is one warning and
    the probes light that object, as a deleted probe file is."""
    scene = room(tmp_path)
    scene.bo2.bake_pack = False
    assert bpy.ops.bo2.bake_lightmaps("EXEC_DEFAULT", mode="ALL") == {"FINISHED"}
    baked(scene, "Left").unlink()
    core, warnings = extract.extract_scene(bpy.context.evaluated_depsgraph_get(), indirect=True)
    assert [m.name for m in core.meshes if m.lightmap is None] == ["Left"]
    assert sum("Lightmap of 'Left'" in w and "is missing" in w for w in warnings) == 1
    assert lightmaps.state(scene.objects["Left"], scene)[0] == "MISSING"


def test_the_memory_a_bake_takes_is_said_up_front(addon, tmp_path, monkeypatch):
    """A big bake says how much memory it takes before it starts; one that the machine cannot
    hold is refused with that figure, the previous lightmaps kept."""
    from bo2_lighting.addon.core.system import machine

    scene = room(tmp_path)
    objs = lightmaps.lightmap_objects(scene)
    monkeypatch.setattr(blender_bake, "BAKE_NOTE", 0)
    warnings = Warnings()
    for _ in blender_bake.lightmap_steps(scene, objs, warnings=warnings):
        pass
    [said] = [w for w in warnings if "takes about" in w]
    assert "M texels" in said and "of memory" in said
    before = baked(scene, "Floor").read_bytes() if baked(scene, "Floor").exists() else None
    monkeypatch.setattr(machine, "physical", lambda: 1 << 20)
    with pytest.raises(blender_bake.BakeError, match="more than this machine's 1 MiB"):
        for _ in blender_bake.lightmap_steps(scene, objs):
            pass
    assert before is None or baked(scene, "Floor").read_bytes() == before
