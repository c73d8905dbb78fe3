"""Bakes that cannot be half-written, probe files that are data from disk, names that never
share a file.

Independent values: the bytes of the previous files (compared before and after), a folder's
free space as the operating system reports it (replaced here by a smaller figure).
"""

import shutil

import numpy as np
import pytest
from test_probe_leaks import run_bake
from test_probes import room
from util import render_pixels

from bo2_lighting.addon.blender import probes
from bo2_lighting.addon.core import capture, probe_file


def files(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


def test_a_folder_at_the_second_probes_path_fails_the_bake_and_keeps_the_first(addon,
                                                                              tmp_path):
    scene = room(tmp_path)
    run_bake(scene)
    folder = probes.bake_folder(scene)
    before = files(folder)
    (folder / "Reflection.exr").unlink()
    (folder / "Reflection.exr").mkdir()  # sorted after Irradiance: the second file
    scene.objects["Irradiance"].location.x += 0.5  # a bake that would change the first file
    with pytest.raises(probes.BakeError, match="the previous bake files are as they were"):
        run_bake(scene)
    assert files(folder) == {"Irradiance.exr": before["Irradiance.exr"]}


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


def test_every_probe_name_has_its_own_file(addon, tmp_path):
    scene = room(tmp_path)
    for name in ("a/b", "a?b", "a_b"):
        obj = scene.objects["Reflection"].copy()
        obj.name = name
        obj.location.x += 0.1 * len(scene.objects)
        scene.collection.objects.link(obj)
    run_bake(scene)
    folder = probes.bake_folder(scene)
    paths = {name: probes.probe_path(folder, name) for name in ("a/b", "a?b", "a_b")}
    assert len(set(paths.values())) == 3 and paths["a_b"].name == "a_b.exr"
    assert all(p.parent == folder and p.exists() for p in paths.values())
    for name in paths:
        assert probes.bake_state(scene.objects[name], folder).state == "BAKED"
    scene.objects["a?b"].name = "renamed"  # the others keep their files
    assert probes.probe_path(folder, "a/b") == paths["a/b"]
    assert probes.bake_state(scene.objects["a/b"], folder).state == "BAKED"
    scene.objects["renamed"].name = "A_B"  # beside a_b
    with pytest.raises(probes.BakeError, match="differ only in case"):
        run_bake(scene)


def test_a_probe_file_of_nan_light_falls_back_to_the_world(addon, tmp_path, capfd):
    scene = room(tmp_path)
    world_only = render_pixels(scene, "BO2_LIGHTING", samples=1)
    run_bake(scene)
    folder = probes.bake_folder(scene)
    for name in ("Reflection", "Irradiance"):  # rewritten with NaN, checksums and all
        meta, sh, mips = probe_file.read(folder / f"{name}.exr")
        sh[:, 0] = np.nan
        probe_file.write(folder / f"{name}.exr", meta, sh, mips or None)
    capfd.readouterr()
    px = render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert np.isfinite(px).all()
    np.testing.assert_allclose(px, world_only, atol=1e-6)
    captured = capfd.readouterr()
    err = captured.out + captured.err
    for name in ("Reflection", "Irradiance"):
        assert err.count(f"{name}.exr: part sh holds NaN or infinite values") == 1, err
