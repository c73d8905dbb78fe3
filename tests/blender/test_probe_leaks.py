"""Volume probes' leak settings reach the bake, and odd probes bake with one warning each.

Independent values: which volume sample lies inside a box placed around it (the sample
positions (i + 0.5) / res * 2 - 1 of the object's box), and the dilated sample's light, the
mean of its valid neighbours one spacing away (equal weights).
"""

import bpy
import numpy as np
from test_probes import room
from util import baked, render_pixels

from bo2_lighting.addon.blender import bake as blender_bake
from bo2_lighting.addon.blender import bake_files, probes
from bo2_lighting.addon.core.files import probe_file
from bo2_lighting.addon.core.render.job import Warnings

SAMPLE = (5.0 / 3.0, -5.0 / 3.0, 1.5)  # the 3 x 3 x 2 volume's sample (2, 0, 1)


def run_bake(scene, objs=None) -> list[str]:
    warnings = Warnings()
    bpy.context.view_layer.update()
    objs = objs or probes.probe_objects(scene)
    for _ in blender_bake.bake_steps(scene, objs,
                                     warnings=warnings):
        pass
    return warnings


def volume_sh(scene) -> tuple[dict, np.ndarray]:
    meta, sh, _ = probe_file.read(baked(scene, "Irradiance"))
    return meta, sh.reshape(3, 3, 2, 9, 3)


def test_volume_leak_settings_reach_the_bake(addon, tmp_path):
    scene = room(tmp_path)
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=SAMPLE)  # 0.4 m around the sample
    volume = scene.objects["Irradiance"]
    run_bake(scene, [volume])
    meta, grid = volume_sh(scene)
    assert meta["invalid_samples"] == [] and meta["escaped_samples"] == 0
    neighbours = grid[1, 0, 1], grid[2, 1, 1], grid[2, 0, 0]  # one spacing away, all valid
    np.testing.assert_allclose(grid[2, 0, 1], np.mean(neighbours, axis=0), rtol=1e-5,
                               atol=1e-6)
    volume.data.normal_bias = 0.6  # a look-up setting: the bake stays
    assert probes.bake_state(volume).state == "BAKED"
    volume.data.dilation_radius = 2.0  # a bake setting: the bake is stale
    assert probes.bake_state(volume).state == "STALE"
    volume.data.dilation_radius = 1.0

    volume.data.dilation_threshold = 0.0  # nothing is invalid: the sample keeps its capture
    run_bake(scene, [volume])
    _, kept = volume_sh(scene)
    assert np.abs(kept[2, 0, 1] - np.mean(neighbours, axis=0)).max() > 0.05

    volume.data.dilation_threshold = 0.5
    volume.data.escape_bias = 0.5  # half a spacing (0.83 m) reaches out of the 0.4 m box
    run_bake(scene, [volume])
    meta, _ = volume_sh(scene)
    assert meta["escaped_samples"] == 1 and meta["invalid_samples"] == []

    volume.data.escape_bias = 0.0
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    bpy.ops.mesh.primitive_cube_add(size=4.0, location=(1.5, -1.5, 1.0))  # swallows a corner
    warnings = run_bake(scene, [volume])
    meta, _ = volume_sh(scene)
    assert meta["invalid_samples"]
    (line,) = [w for w in warnings if "inside geometry" in w]
    assert f"{len(meta['invalid_samples'])} of 18 samples" in line
    assert np.isfinite(render_pixels(scene, "BO2_LIGHTING", samples=1)).all()


def test_odd_probes_bake_with_one_warning_each(addon, tmp_path):
    scene = room(tmp_path)
    volume = scene.objects["Irradiance"]
    volume.data.resolution_x = 1
    twin = scene.objects["Reflection"].copy()
    twin.data = scene.objects["Reflection"].data.copy()
    twin.name = "Reflection twin"
    scene.collection.objects.link(twin)
    empty = bpy.data.objects.new("No influence", bpy.data.lightprobes.new("None", "SPHERE"))
    empty.location = (-1.0, -1.0, 1.0)
    empty.data.influence_distance = 0.0
    scene.collection.objects.link(empty)
    boxed = bpy.data.objects.new("Boxed", bpy.data.lightprobes.new("Boxed", "VOLUME"))
    boxed.location, boxed.scale = (1.0, -1.0, 0.6), (0.2, 0.2, 0.2)
    scene.collection.objects.link(boxed)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(1.0, -1.0, 0.6))  # closed around it
    warnings = run_bake(scene)
    assert sum("one sample along x" in w and "'Irradiance'" in w for w in warnings) == 1
    assert sum("exactly where 'Reflection'" in w for w in warnings) == 1
    assert sum("'No influence' has no influence" in w for w in warnings) == 1
    n = boxed.data.resolution_x * boxed.data.resolution_y * boxed.data.resolution_z
    assert sum(f"'Boxed': {n} of {n} samples are inside geometry" in w for w in warnings) == 1
    names = ("Irradiance", "Reflection", "Reflection twin", "No influence", "Boxed")
    assert {p.name for p in bake_files.file_folder(scene).iterdir()} == {
        baked(scene, n).name for n in names}
    assert np.isfinite(render_pixels(scene, "BO2_LIGHTING", samples=1)).all()
