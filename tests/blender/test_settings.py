"""The scene's settings in their groups, and files saved while they were flat."""

import shutil
from pathlib import Path

import bpy
import pytest

from bo2_lighting.addon.blender import props, settings

# Saved by the version before the groups, with non-default values (Blender 4.5).
FLAT = Path(__file__).parent / "data" / "flat_settings.blend"


def test_a_file_with_flat_settings_opens_with_its_values(addon, tmp_path):
    blend = tmp_path / "earlier.blend"
    shutil.copy(FLAT, blend)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    scene = bpy.data.scenes["Earlier"]
    s = scene.bo2
    assert (s.samples, s.bake_pack, s.bake_folder) == (7, False, "")
    assert (s.indirect.use, s.indirect.normalization, s.indirect.prefilter,
            s.indirect.env_brdf, s.indirect.sky_directions) == (False, "bo1", "bo1", "bo1", "64")
    assert s.indirect.ao_distance == pytest.approx(0.5)
    assert s.indirect.use_ambient_occlusion  # never set: the default
    assert (s.probes.backend, s.probes.face_size, s.probes.bounces) == ("CYCLES", "64", 5)
    assert (s.lightmaps.use, s.lightmaps.max_resolution, s.lightmaps.directional) == \
        (False, "256", True)
    assert s.lightmaps.density == pytest.approx(8.0)
    assert s.viewport.samples == 3
    assert (s.lookdev.report_source, s.lookdev.report_old_methods, s.lookdev.compare_folder) \
        == ("FOLDER", True, "//looks/")
    assert not set(s.keys()) & set(props.MOVED)  # nothing is left flat
    render = settings.render_settings(scene)
    assert (render.normalization, render.sky_directions) == ("bo1", 64)
    # saved again and reopened, the values stay where they moved
    bpy.ops.wm.save_mainfile()
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    s = bpy.data.scenes["Earlier"].bo2
    assert (s.indirect.normalization, s.probes.bounces, s.viewport.samples) == ("bo1", 5, 3)


def test_upgrade_keeps_a_value_already_in_its_group(addon):
    scene = bpy.context.scene
    scene.bo2.indirect.env_brdf = "bo1"
    scene.bo2["env_brdf"] = 2  # a stale flat value ("bo2") beside the grouped one
    assert props.upgrade(scene) == 1
    assert scene.bo2.indirect.env_brdf == "bo1" and "env_brdf" not in scene.bo2.keys()
    assert props.upgrade(scene) == 0


def test_set_setting_by_path_and_by_earlier_name(addon):
    scene = bpy.context.scene
    props.set_setting(scene, "indirect.env_brdf", "bo1")
    props.set_setting(scene, "lightmap_rays", 64)  # an earlier version's flat name
    props.set_setting(scene, "samples", 9)
    assert (scene.bo2.indirect.env_brdf, scene.bo2.lightmaps.rays, scene.bo2.samples) == \
        ("bo1", 64, 9)
    for path in ("indirect.nothing", "nothing", "rna_type", "probes.rna_type"):
        with pytest.raises(AttributeError, match="no scene setting"):
            props.set_setting(scene, path, 1)


def test_each_group_is_drawn_by_its_panel(addon):
    groups = {"indirect": "RENDER_PT_bo2_indirect", "probes": "RENDER_PT_bo2_bake",
              "lightmaps": "RENDER_PT_bo2_lightmaps", "viewport": "RENDER_PT_bo2_viewport",
              "lookdev": "RENDER_PT_bo2_lookdev"}
    scene_props = bpy.types.Scene.bl_rna.properties["bo2"].fixed_type.properties
    assert set(groups) == {n for n, p in scene_props.items()
                           if p.type == "POINTER" and n != "rna_type"}
    for group, panel in groups.items():
        assert hasattr(bpy.types, panel)
        assert scene_props[group].name == getattr(bpy.types, panel).bl_label
