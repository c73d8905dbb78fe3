"""Compare with Cycles (``bo2.compare_cycles``) on a small scene, with the real ``bpy``.

Checked: the operator (EXEC, as scripts run it) writes both EXRs, the three pictures and
metrics.json with the documented keys; picture sizes; the scene's engine and passes are put
back; the view transform is applied (Standard and AgX pictures differ, and Standard equals the
sRGB encoding of IEC 61966-2-1 of the linear pixels); a resolution mismatch between the two
renders and a scene without a camera fail with one clear message; the UI entries exist.
"""

import json

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, set_world_color

from bo2_lighting.addon.blender import images

W, H = 48, 32


def build(scene):
    set_world_color(scene, (0.05, 0.06, 0.08))
    bpy.ops.mesh.primitive_plane_add(size=4)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.5, location=(0, 0, 0.5))
    mat = bpy.data.materials.new("Red")
    if mat.node_tree is None:
        mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.8, 0.1, 0.1,
                                                                                   1)
    bpy.context.object.data.materials.append(mat)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.5, 0.2, 0.0)
    scene.collection.objects.link(sun)
    add_ortho_camera(scene, 3.0, height=3.0)
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    scene.render.engine = "BO2_LIGHTING"
    scene.bo2.samples = 1
    scene.cycles.samples = 4
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False


def load_png(path):
    """(H, W, 3) encoded values in [0, 1], row 0 at the top, as Blender reads the PNG."""
    return images.read_file(path)[..., :3]


@pytest.fixture
def scene(addon, empty_scene):
    build(empty_scene)
    return empty_scene


def test_operator_writes_everything(scene, tmp_path):
    scene.bo2.lookdev.compare_folder = str(tmp_path / "cmp")
    view_layer = bpy.context.view_layer
    view_layer.use_pass_diffuse_color = False
    settings = scene.render.image_settings
    settings.file_format = "JPEG"
    assert bpy.ops.bo2.compare_cycles() == {"FINISHED"}
    folder = tmp_path / "cmp"
    assert sorted(p.name for p in folder.iterdir()) == sorted(
        ["bo2.exr", "cycles.exr", "side_by_side.png", "split.png", "difference.png",
         "metrics.json"])
    # the scene is as it was
    assert scene.render.engine == "BO2_LIGHTING" and not view_layer.use_pass_diffuse_color
    assert settings.file_format == "JPEG"
    metrics = json.loads((folder / "metrics.json").read_text())
    for key in ("scene", "frame", "blender_version", "resolution", "engines", "image", "passes",
                "cycles_times_color", "color_management", "definitions", "heat_map"):
        assert key in metrics, key
    assert metrics["cycles_times_color"] is True
    assert metrics["resolution"] == [W, H]
    assert metrics["blender_version"] == bpy.app.version_string
    for key, samples in (("bo2", 1), ("cycles", 4)):
        engine = metrics["engines"][key]
        assert engine["samples"] == samples and engine["resolution"] == [W, H]
        assert engine["render_seconds"] > 0
    image = metrics["image"]
    assert set(image) == {"rmse", "mean_relative_error", "psnr_db", "ssim"}
    assert 0 < image["ssim"] <= 1 and image["psnr_db"] > 10 and image["rmse"] < 0.5
    for name in ("Diffuse Direct", "Glossy Direct", "Diffuse Indirect", "Glossy Indirect",
                 "Emission"):
        assert set(metrics["passes"][name]) == {"rmse", "mean_relative_error", "psnr_db",
                                                "ssim"}
    # a sunlit Lambert-like plane: BO2's Diffuse Direct is close to Cycles' DiffDir x DiffCol
    assert metrics["passes"]["Diffuse Direct"]["ssim"] > 0.8
    assert metrics["passes"]["Material Index"]["fraction_equal"] > 0.9
    assert set(metrics["passes"]["Normal"]) == {"rmse", "mean_abs_error", "pixels"}
    assert metrics["passes"]["Normal"]["rmse"] < 0.1
    # picture sizes
    s = max(1, round(H / 180))
    assert load_png(folder / "split.png").shape == (H, W, 3)
    assert load_png(folder / "side_by_side.png").shape == (H + 8 * s + 4 * s, 2 * W + 2 * s, 3)
    diff = load_png(folder / "difference.png")
    assert diff.shape[0] > H and diff.shape[1] >= W


def test_view_transform_is_applied(scene, tmp_path):
    from bo2_lighting.addon.core.formulas import texture

    pictures = {}
    for view in ("Standard", "AgX"):
        scene.view_settings.view_transform = view
        scene.bo2.lookdev.compare_folder = str(tmp_path / view)
        # invoked without a window (background mode) it runs as from a script
        how = "INVOKE_DEFAULT" if view == "AgX" else "EXEC_DEFAULT"
        assert bpy.ops.bo2.compare_cycles(how) == {"FINISHED"}
        pictures[view] = load_png(tmp_path / view / "split.png")
    assert np.abs(pictures["Standard"] - pictures["AgX"]).mean() > 0.01
    # Standard is the sRGB encoding of the linear values (16-bit round trip)
    scene.view_settings.view_transform = "Standard"
    linear = np.random.default_rng(3).random((8, 16, 3)).astype(np.float32) * 1.2
    (display,) = images.to_display(scene, [linear])
    np.testing.assert_allclose(display, texture.linear_to_srgb(np.minimum(linear, 1)), atol=1e-4)


def test_resolution_mismatch_keeps_both_renders(scene, tmp_path):
    from bo2_lighting.addon.blender import compare

    job = compare.Comparison(scene, bpy.context.view_layer, tmp_path)
    try:
        job.finish("bo2", compare.render_sync(job, "bo2"))
        scene.render.resolution_x = W + 2  # as a crop or border of other size would
        job.finish("cycles", compare.render_sync(job, "cycles"))
        with pytest.raises(compare.CompareError, match=r"resolution mismatch: BO2 Lighting "
                           rf"rendered {W}x{H}, Cycles {W + 2}x{H}"):
            job.analyse()
    finally:
        job.restore()
    assert (tmp_path / "bo2.exr").is_file() and (tmp_path / "cycles.exr").is_file()
    assert not (tmp_path / "metrics.json").exists()


def test_bad_inputs(scene, tmp_path):
    scene.bo2.lookdev.compare_folder = "//bo2_compare/"  # relative to an unsaved file
    with pytest.raises(RuntimeError, match="save the .blend file first"):
        bpy.ops.bo2.compare_cycles()
    blocker = tmp_path / "file"
    blocker.write_text("")
    scene.bo2.lookdev.compare_folder = str(blocker / "sub")
    with pytest.raises(RuntimeError, match="cannot create the output folder"):
        bpy.ops.bo2.compare_cycles()
    scene.bo2.lookdev.compare_folder = str(tmp_path / "cmp")
    scene.camera = None
    with pytest.raises(RuntimeError, match="has no active camera"):
        bpy.ops.bo2.compare_cycles()
    assert not (tmp_path / "cmp").exists()


def test_ui_entries(empty_scene):
    import bo2_lighting
    from bo2_lighting.addon.blender import props, ui

    bo2_lighting.register()
    try:
        assert hasattr(bpy.types, "RENDER_PT_bo2_lookdev")
        assert ui.draw_render_menu in bpy.types.TOPBAR_MT_render._dyn_ui_initialize()
        prop = props.BO2LookDevSettings.bl_rna.properties["compare_folder"]
        assert prop.subtype == "DIR_PATH" and prop.default == "//bo2_compare/"
    finally:
        bo2_lighting.unregister()
    assert ui.draw_render_menu not in bpy.types.TOPBAR_MT_render._dyn_ui_initialize()
    assert not hasattr(bpy.types, "RENDER_PT_bo2_lookdev")
