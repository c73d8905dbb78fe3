"""The look-dev review from Blender (``bo2.review_report``), with the real ``bpy``.

Checked: the open file's scenes with a camera are rendered by both engines (and with the
talk's old methods) into the report folder and ranked on the page; Compare with Cycles folders
are read back without rendering, the page linking their EXRs; the scene's settings are put back;
the colour management recorded in metrics.json is the one the pictures go through; nothing to
review and an unsaved file with a relative folder fail with one message; the panel shows the
settings.
"""

import json

import bpy
import numpy as np
import pytest
from test_compare_cycles import build

from bo2_lighting.addon.blender import images
from bo2_lighting.addon.blender import report as blender_report
from bo2_lighting.addon.core.review import flip


@pytest.fixture
def scene(addon, empty_scene):
    build(empty_scene)
    return empty_scene


def read_report(folder):
    return json.loads((folder / "report.json").read_text())


def test_this_files_scenes(scene, tmp_path):
    second = scene.copy()  # a linked copy with its own settings, camera included
    second.name = "Second"
    second.bo2.indirect.normalization = "none"
    bpy.data.scenes.new("No camera")
    scene.bo2.lookdev.report_folder = str(tmp_path / "review")
    scene.bo2.lookdev.report_old_methods = True
    assert bpy.ops.bo2.review_report() == {"FINISHED"}
    data = read_report(tmp_path / "review")
    assert sorted(s["name"] for s in data["scenes"]) == sorted([scene.name, "Second"])
    for s in data["scenes"]:
        assert set(s["variants"]) == {"bo2", "bo2_old"}
        m = s["variants"]["bo2"]["metrics"]
        assert "Combined" in m and "Diffuse Direct" in m
        assert m["Combined"]["ssim"] > 0
        assert (m["Combined"]["flip_ldr"] is None) == (flip.unavailable() is not None)
        assert s["resolution"] == [48, 32] and s["seconds"]["cycles"] > 0
        folder = tmp_path / "review" / "scenes" / s["folder"]
        assert (folder / "bo2.exr").exists() and (folder / "old" / "bo2.exr").exists()
        assert s["links"]["bo2_old"] == f"scenes/{s['folder']}/old/bo2.exr"
    # the settings are the scenes' own again: old methods were for one render only
    indirect = scene.bo2.indirect
    assert (indirect.env_brdf, indirect.normalization, indirect.prefilter) == ("bo2", "bo2", "bo2")
    assert second.bo2.indirect.normalization == "none" and scene.render.engine == "BO2_LIGHTING"
    assert data["flip"] == flip.unavailable()
    html = (tmp_path / "review" / "index.html").read_text()
    assert "Second" in html and "<script" in html and "http" not in html.split("<body>")[1]


def test_a_second_review_replaces_the_first(scene, tmp_path):
    """Old methods in the first review only: the second shows no stale old-methods render."""
    scene.bo2.lookdev.report_folder = str(tmp_path / "review")
    scene.bo2.lookdev.report_old_methods = True
    assert bpy.ops.bo2.review_report() == {"FINISHED"}
    assert set(read_report(tmp_path / "review")["scenes"][0]["variants"]) == {"bo2", "bo2_old"}
    scene.bo2.lookdev.report_old_methods = False
    assert bpy.ops.bo2.review_report() == {"FINISHED"}
    [s] = read_report(tmp_path / "review")["scenes"]
    assert set(s["variants"]) == {"bo2"}
    assert not (tmp_path / "review" / "scenes" / s["folder"] / "old").exists()


def test_compare_folders_read_back(scene, tmp_path):
    scene.view_settings.view_transform = "Standard"
    scene.bo2.lookdev.compare_folder = str(tmp_path / "cmp" / "a")
    assert bpy.ops.bo2.compare_cycles() == {"FINISHED"}
    scene.view_settings.view_transform = "AgX"  # the report uses the one in metrics.json
    scene.bo2.lookdev.report_source = "FOLDER"
    scene.bo2.lookdev.report_source_folder = str(tmp_path / "cmp")
    scene.bo2.lookdev.report_folder = str(tmp_path / "review")
    assert bpy.ops.bo2.review_report() == {"FINISHED"}
    data = read_report(tmp_path / "review")
    [s] = data["scenes"]
    assert s["name"] == "a" and set(s["variants"]) == {"bo2"}
    assert s["links"] == {"bo2": "../cmp/a/bo2.exr", "cycles": "../cmp/a/cycles.exr"}
    assert s["color_management"]["view_transform"] == "Standard"
    # the page's Cycles picture is the EXR through Standard: the sRGB encoding of IEC 61966-2-1
    linear = images.read_exr_passes(tmp_path / "cmp" / "a" / "cycles.exr",
                                    bpy.context.view_layer.name, ["Combined"])["Combined"]
    v = np.clip(linear[..., :3], 0, 1)
    encoded = np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)
    picture = images.read_file(tmp_path / "review" / s["cycles_pictures"]["cycles"],
                               colorspace="Non-Color")[..., :3]
    assert np.abs(picture - encoded).max() <= 1.0 / 255 + 1e-4
    metrics = json.loads((tmp_path / "cmp" / "a" / "metrics.json").read_text())
    assert s["variants"]["bo2"]["metrics"]["Combined"]["psnr_db"] == pytest.approx(
        metrics["image"]["psnr_db"], abs=0.05)  # 8-bit pictures, 16-bit in compare


def test_nothing_to_review(scene, tmp_path):
    scene.bo2.lookdev.report_folder = "//review/"
    with pytest.raises(RuntimeError, match="save the .blend file first"):
        bpy.ops.bo2.review_report()
    scene.bo2.lookdev.report_folder = str(tmp_path / "review")
    scene.bo2.lookdev.report_source = "FOLDER"
    scene.bo2.lookdev.report_source_folder = str(tmp_path)
    with pytest.raises(RuntimeError, match="holds no Compare with Cycles folder"):
        bpy.ops.bo2.review_report()
    scene.bo2.lookdev.report_source = "SCENES"
    bpy.data.objects.remove(scene.camera)
    with pytest.raises(RuntimeError, match="no scene of this file has a camera"):
        bpy.ops.bo2.review_report()


def test_a_damaged_comparison_is_one_message(scene, tmp_path):
    folder = tmp_path / "cmp"
    folder.mkdir()
    (folder / "metrics.json").write_text("{not json")
    with pytest.raises(Exception, match="not a comparison's metrics.json"):
        blender_report.read_comparison(folder)
    (folder / "metrics.json").write_text(json.dumps({"view_layer": "ViewLayer",
                                                     "engines": {}}))
    (folder / "bo2.exr").write_bytes(b"not an exr")
    with pytest.raises(Exception, match="bo2.exr: cannot be read"):
        blender_report.read_comparison(folder)


def test_panel_settings(addon):
    from bo2_lighting.addon.blender.props import BO2LookDevSettings

    props = BO2LookDevSettings.bl_rna.properties
    assert props["report_folder"].default == "//bo2_report/"
    assert {i.identifier for i in props["report_source"].enum_items} == {"SCENES", "FOLDER"}
    assert hasattr(bpy.types, "BO2_OT_review_report")
