"""Bakes that cannot be half-written, probe files that are data from disk, names that never
share a file.

Independent values: the bytes of the previous files (compared before and after), a folder's
free space as the operating system reports it (replaced here by a smaller figure).
"""

import shutil

import bpy
import numpy as np
import pytest
from test_probe_leaks import run_bake
from test_probes import room
from util import baked, render_pixels

from bo2_lighting.addon.blender import bake_files, probes
from bo2_lighting.addon.core.bakes import capture
from bo2_lighting.addon.core.files import probe_file


def files(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_a_folder_at_the_second_probes_path_fails_the_bake_and_keeps_the_first(addon,
                                                                              tmp_path):
    scene = room(tmp_path)
    run_bake(scene)
    folder = bake_files.file_folder(scene)
    before = files(folder)
    second = baked(scene, "Reflection")  # written after Irradiance's
    second.unlink()
    second.mkdir()
    scene.objects["Irradiance"].location.x += 0.5  # a bake that would change the first file
    with pytest.raises(probes.BakeError, match="the previous bake files are as they were"):
        run_bake(scene)
    first = baked(scene, "Irradiance").name
    assert files(folder) == {first: before[first]}


def test_no_room_is_found_before_capturing(addon, tmp_path, monkeypatch):
    scene = room(tmp_path)
    real = shutil.disk_usage
    monkeypatch.setattr(shutil, "disk_usage",
                        lambda path: real(path)._replace(free=100_000))
    captured = []
    monkeypatch.setattr(capture.Capture, "cube", lambda *a: captured.append(a))
    monkeypatch.setattr(capture.Capture, "surfaces", lambda *a: captured.append(a))
    with pytest.raises(probes.BakeError, match=r"0\.1 MiB free, the bake needs up to"):
        run_bake(scene)
    assert not captured and not probes.bake_folder(scene).exists()
    assert not bpy.data.images  # nothing declared


def test_every_probe_name_has_its_own_file(addon, tmp_path):
    scene = room(tmp_path)
    for name in ("a/b", "a?b", "a_b"):
        obj = scene.objects["Reflection"].copy()
        obj.name = name
        obj.location.x += 0.1 * len(scene.objects)
        scene.collection.objects.link(obj)
    run_bake(scene)
    folder = bake_files.file_folder(scene)
    paths = {name: baked(scene, name) for name in ("a/b", "a?b", "a_b")}
    assert len({p.name.lower() for p in paths.values()}) == 3  # case-insensitive disks too
    assert paths["a/b"].name.startswith("a_b-") and paths["a_b"].name.startswith("a_b-")
    assert all(p.parent == folder and p.exists() for p in paths.values())
    for name in paths:
        assert probes.bake_state(scene.objects[name]).state == "BAKED"
    scene.objects["a?b"].name = "A_B"  # beside a_b: every one keeps its file
    run_bake(scene)
    assert {n: baked(scene, n) for n in ("a/b", "A_B", "a_b")} == {
        "a/b": paths["a/b"], "A_B": paths["a?b"], "a_b": paths["a_b"]}
    assert all(probes.bake_state(o).state == "BAKED" for o in probes.probe_objects(scene))


def test_a_probe_file_of_nan_light_falls_back_to_the_world(addon, tmp_path, capfd):
    scene = room(tmp_path)
    scene.bo2.bake_pack = False  # the files on disk render
    world_only = render_pixels(scene, "BO2_LIGHTING", samples=1)
    run_bake(scene)
    for name in ("Reflection", "Irradiance"):  # rewritten with NaN, checksums and all
        meta, sh, mips = probe_file.read(baked(scene, name))
        sh[:, 0] = np.nan
        probe_file.write(baked(scene, name), meta, sh, mips or None)
    capfd.readouterr()
    px = render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert np.isfinite(px).all()
    np.testing.assert_allclose(px, world_only, atol=1e-6)
    captured = capfd.readouterr()
    err = captured.out + captured.err
    for name in ("Reflection", "Irradiance"):
        assert err.count(f"{baked(scene, name).name}: part sh holds NaN or infinite "
                         "values") == 1, err
