"""Bakes that belong to their .blend: each file's own folder, kept across renames, packed into
the .blend or declared as external files that Blender Asset Tracer moves with it, and the
bakes of earlier versions adopted on load."""

import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest
from test_probes import bake, room
from util import render_pixels

from bo2_lighting.addon.blender import adoption, bake_files, probes
from bo2_lighting.addon.core.files import probe_file


def render(scene):
    return render_pixels(scene, "BO2_LIGHTING", samples=1)[..., :3]


def digests(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): hashlib.sha1(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*.exr"))}


def test_two_files_of_one_folder_keep_their_own_bakes(addon, tmp_path, capfd):
    """Two shots side by side with probes of the same names: baking the second leaves the
    first's files and light as they were."""
    scene = room(tmp_path)  # room.blend
    scene.objects["Sun"].data.energy = 1.0
    bake(scene)
    first = render(scene)
    first_files = digests(tmp_path / "bo2_bake")
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot_020.blend"))
    scene = bpy.context.scene
    scene.objects["Sun"].data.energy = 8.0  # another shot, another light
    bake(scene)
    assert bake_files.path(scene.objects["Reflection"]).parent == tmp_path / "bo2_bake" / \
        "shot_020"
    second = render(scene)
    assert not np.allclose(first, second, atol=1e-3)
    after = digests(tmp_path / "bo2_bake")
    assert {k: v for k, v in after.items() if k.startswith("room/")} == first_files
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "room.blend"))
    scene = bpy.context.scene
    scene.bo2.bake_pack = False
    for obj in probes.probe_objects(scene):  # the files, not only the packed copies
        assert bake_files.unpack(scene, [obj]) == 1
    np.testing.assert_array_equal(render(scene), first)


def test_renaming_a_probe_keeps_its_bake(addon, tmp_path):
    scene = room(tmp_path)
    bake(scene)
    before = render(scene)
    scene.objects["Reflection"].name = "Kitchen reflection"
    scene.objects["Irradiance"].name = "Kitchen volume"
    assert {probes.bake_state(o).state for o in probes.probe_objects(scene)} == {"BAKED"}
    np.testing.assert_array_equal(render(scene), before)


def test_a_duplicate_gets_its_own_bake(addon, tmp_path):
    scene = room(tmp_path)
    bake(scene)
    original = scene.objects["Reflection"]
    copy = original.copy()  # as Shift+D does: the same bake datablock
    copy.location.x -= 1.0
    scene.collection.objects.link(copy)
    bpy.context.view_layer.update()
    assert bake_files.shared_with(copy) == ["Reflection"]
    state = probes.bake_state(copy)  # baked where the original is
    assert state.state == "STALE" and "shares its bake with 'Reflection'" in state.message
    path = bake_files.path(original)
    bake(scene)
    assert bake_files.path(original) == path  # re-baked in its place
    assert bake_files.path(copy) != path and bake_files.path(copy).is_file()
    assert probes.bake_state(copy).state == probes.bake_state(original).state == "BAKED"


def test_packed_bakes_travel_in_the_blend_and_unpack_back(addon, tmp_path, capfd):
    scene = room(tmp_path)
    scene.bo2.bake_pack = True
    bake(scene)
    before = render(scene)
    files = digests(tmp_path / "bo2_bake")
    bpy.ops.wm.save_mainfile()
    moved = tmp_path / "farm"
    moved.mkdir()
    shutil.copyfile(tmp_path / "room.blend", moved / "room.blend")  # the .blend alone
    bpy.ops.wm.open_mainfile(filepath=str(moved / "room.blend"))
    scene = bpy.context.scene
    assert {probes.bake_state(o).state for o in probes.probe_objects(scene)} == {"BAKED"}
    np.testing.assert_array_equal(render(scene), before)
    assert bpy.ops.bo2.unpack_bakes() == {"FINISHED"}
    assert digests(moved / "bo2_bake") == files  # the same bytes, where they were declared
    assert not any(bake_files.packed(o) for o in probes.probe_objects(scene))
    np.testing.assert_array_equal(render(scene), before)
    assert bpy.ops.bo2.pack_bakes() == {"FINISHED"}
    assert all(bake_files.packed(o) for o in probes.probe_objects(scene))


def test_damaged_packed_bake_is_reported_and_the_world_lights(addon, tmp_path, capfd):
    scene = room(tmp_path)
    scene.bo2.indirect.use = True
    world_only = render(scene)
    bake(scene)
    obj = scene.objects["Reflection"]
    data = bytearray(obj.bo2.bake.packed_file.data)
    data[len(data) // 2: len(data) // 2 + 64] = bytes(64)  # pixels zeroed: checksum fails
    obj.bo2.bake.unpack(method="REMOVE")
    obj.bo2.bake.pack(data=bytes(data), data_len=len(data))
    state = probes.bake_state(obj)
    assert state.state == "DAMAGED" and state.message.startswith("its packed bake:")
    scene.objects["Irradiance"].bo2.bake = None  # only the damaged one
    capfd.readouterr()
    np.testing.assert_allclose(render(scene), world_only, atol=1e-6)
    out = capfd.readouterr()
    assert "Light probe 'Reflection': its packed bake" in out.out + out.err


def test_bakes_of_earlier_versions_are_adopted_on_load(addon, tmp_path, capfd):
    """Files named after the probes in the shared bake folder (earlier versions) are copied
    into the .blend's folder when it is opened, once, with a message; the originals stay."""
    scene = room(tmp_path)
    scene.bo2.bake_pack = False
    bake(scene)
    before = render(scene)
    for obj in probes.probe_objects(scene):  # as an earlier version left them
        shutil.copyfile(bake_files.path(obj), tmp_path / "bo2_bake" / f"{obj.name}.exr")
        bake_files.forget(scene, obj)
    bpy.ops.wm.save_mainfile()
    shutil.rmtree(tmp_path / "bo2_bake" / "room")
    capfd.readouterr()
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "room.blend"))
    scene = bpy.context.scene
    out = capfd.readouterr().out
    assert "The bake of 'Reflection' was copied from" in out
    assert len(adoption.notices) == 2
    for obj in probes.probe_objects(scene):
        assert bake_files.path(obj).parent == tmp_path / "bo2_bake" / "room"
        assert (tmp_path / "bo2_bake" / f"{obj.name}.exr").is_file()  # other files may read it
    np.testing.assert_array_equal(render(scene), before)
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "room.blend"))
    assert adoption.notices == []  # once


def test_blender_asset_tracer_packs_the_bakes_with_the_blend(addon, tmp_path):
    """External bakes in an absolute bake folder outside the project: ``bat pack`` copies
    them and rewrites their paths, and the pack renders the same with the originals gone."""
    project = tmp_path / "project"
    project.mkdir()
    scene = room(project)
    scene.bo2.bake_pack = False
    scene.bo2.bake_folder = str(tmp_path / "shared_bakes")
    bake(scene)
    before = render(scene)
    bpy.ops.wm.save_mainfile()
    bat = Path(sys.executable).parent / "bat"
    if not bat.exists():
        pytest.skip("Blender Asset Tracer is not installed (pip install blender-asset-tracer)")
    listed = subprocess.run([str(bat), "list", str(project / "room.blend")],
                            capture_output=True, text=True, check=True).stdout
    for obj in probes.probe_objects(scene):
        assert bake_files.path(obj).name in listed
    subprocess.run([str(bat), "pack", str(project / "room.blend"), str(tmp_path / "pack")],
                   capture_output=True, text=True, check=True)
    shutil.rmtree(tmp_path / "shared_bakes")
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "pack" / "room.blend"))
    scene = bpy.context.scene
    for obj in probes.probe_objects(scene):
        assert bake_files.path(obj).is_relative_to(tmp_path / "pack")
        probe_file.read(bake_files.path(obj))
    np.testing.assert_array_equal(render(scene), before)


def test_a_copy_never_changes_the_originals_files(addon, tmp_path):
    """Saved under another name beside it, a file reads its original's bakes; its Unpack writes
    into its own folder and its Clear deletes nothing of the original's."""
    scene = room(tmp_path)
    bake(scene)
    bpy.ops.wm.save_mainfile()
    original = digests(tmp_path / "bo2_bake" / "room")
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "copy.blend"))
    scene = bpy.context.scene
    assert {probes.bake_state(o).state for o in probes.probe_objects(scene)} == {"BAKED"}
    assert bpy.ops.bo2.unpack_bakes() == {"FINISHED"}
    for obj in probes.probe_objects(scene):
        assert bake_files.path(obj).parent == bake_files.file_folder(scene)
    assert bake_files.file_folder(scene).name == "copy"
    assert bpy.ops.bo2.clear_probes() == {"FINISHED"}
    assert digests(tmp_path / "bo2_bake" / "room") == original
    assert not list((tmp_path / "bo2_bake" / "copy").iterdir())


def test_an_absolute_bake_folder_rebakes_in_place(addon, tmp_path):
    """Two .blend files of one name in two folders share an absolute bake folder without
    sharing bakes; a re-bake replaces its files rather than adding new ones."""
    shared = tmp_path / "farm_bakes"
    (tmp_path / "a").mkdir()
    scene = room(tmp_path / "a")
    scene.bo2.bake_folder = str(shared)
    bake(scene)
    first = bake_files.file_folder(scene)
    assert first.parent == shared and first.name.startswith("room-")
    names = sorted(p.name for p in first.iterdir())
    bake(scene)
    assert sorted(p.name for p in first.iterdir()) == names
    (tmp_path / "b").mkdir()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "b" / "room.blend"))
    scene = bpy.context.scene
    assert bake_files.file_folder(scene) != first
    before = digests(first)
    bake(scene)
    assert digests(first) == before
    assert bake_files.path(scene.objects["Reflection"]).parent == bake_files.file_folder(scene)


def test_a_cleared_bake_is_not_adopted_again(addon, tmp_path):
    scene = room(tmp_path)
    scene.bo2.bake_pack = False
    bake(scene)
    reflection = scene.objects["Reflection"]
    shutil.copyfile(bake_files.path(reflection), tmp_path / "bo2_bake" / "Reflection.exr")
    bake_files.forget(scene, reflection)
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "room.blend"))
    scene = bpy.context.scene
    assert bake_files.path(scene.objects["Reflection"]) is not None  # adopted, once
    assert bpy.ops.bo2.clear_probes() == {"FINISHED"}
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "room.blend"))
    assert bake_files.path(bpy.context.scene.objects["Reflection"]) is None
    assert adoption.notices == []
