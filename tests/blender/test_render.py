"""The engine renders real scenes through bpy.ops.render.render.

Independent values: Cycles renders of the same scene (a white Lambert plane under one light of
each type), and the closed-form irradiance of each light in Blender's units.
"""

import math

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, engine_available, render_pixels, set_world_color

RES = 16



def lambert_plane_scene(kind, location=(0.0, 0.0, 2.0), view=0.1, **light_settings):
    """A white Lambert plane seen from above by an orthographic camera of width ``view`` m,
    one light at ``location``."""
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    bpy.ops.mesh.primitive_plane_add(size=2 * view)
    mat = bpy.data.materials.new("White")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (1, 1, 1, 1)
    node.inputs["Roughness"].default_value = 1.0
    node.inputs["Specular IOR Level"].default_value = 0.0
    bpy.context.object.data.materials.append(mat)
    add_ortho_camera(scene, view)
    data = bpy.data.lights.new("Light", kind)
    for key, value in light_settings.items():
        setattr(data, key, value)
    light = bpy.data.objects.new("Light", data)
    light.location = location
    scene.collection.objects.link(light)
    set_world_color(scene)
    return scene


def test_engine_registered(addon):
    assert engine_available("BO2_LIGHTING")
    assert bpy.types.Scene.bo2 is not None


def test_unregister_leaves_nothing(empty_scene):
    import bo2_lighting

    assert not engine_available("BO2_LIGHTING")
    bo2_lighting.register()
    bo2_lighting.unregister()
    assert not engine_available("BO2_LIGHTING")
    assert not hasattr(bpy.types.Scene, "bo2")
    assert "BO2_LIGHTING" not in bpy.types.RENDER_PT_format.COMPAT_ENGINES
    bo2_lighting.register()  # and again, in the same session
    assert engine_available("BO2_LIGHTING")
    bo2_lighting.unregister()


# Closed-form irradiance at the plane, 2 m below the light, in Blender's units (W or W/m^2).
LIGHTS = [
    ("POINT", dict(energy=100.0, shadow_soft_size=0.01), 100.0 / (4 * math.pi * 4.0)),
    ("SPOT", dict(energy=100.0, shadow_soft_size=0.01, spot_size=math.radians(100),
                  spot_blend=0.3),
     100.0 / (4 * math.pi * 4.0)),
    ("SUN", dict(energy=2.0), 2.0),
    ("AREA", dict(energy=100.0, size=0.01), 100.0 / (math.pi * 4.0)),
]


@pytest.mark.parametrize(("kind", "settings", "irradiance"), LIGHTS, ids=[x[0] for x in LIGHTS])
def test_lambert_plane_closed_form(addon, kind, settings, irradiance):
    scene = lambert_plane_scene(kind, **settings)
    ours = render_pixels(scene, "BO2_LIGHTING")[..., :3].mean()
    assert ours == pytest.approx(irradiance / math.pi, rel=0.01)  # Lambert radiance, albedo 1


@pytest.mark.parametrize(("kind", "settings", "irradiance"), LIGHTS, ids=[x[0] for x in LIGHTS])
def test_lambert_plane_matches_cycles_per_pixel(addon, kind, settings, irradiance):
    """A 3 m plane under a light 1 m up and off-centre: falloff, cosine and (spot) cone edge
    vary across the image. Mean relative error of the lit pixels against Cycles (direct light
    only, no denoiser, enough samples for < 1% noise) is at most 3%."""
    scene = lambert_plane_scene(kind, location=(0.4, 0.3, 1.0), view=1.5, **settings)
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.cycles.max_bounces = 0
    ours = render_pixels(scene, "BO2_LIGHTING", samples=16)[..., :3]
    cycles = render_pixels(scene, "CYCLES", samples=256)[..., :3]
    lit = cycles.mean(-1) > 0.05 * cycles.mean(-1).max()
    error = np.abs(ours[lit] - cycles[lit]).mean(-1) / cycles[lit].mean(-1)
    print(f"{kind}: mean relative error {error.mean():.4f} over {lit.sum()} lit pixels")
    assert lit.sum() > 200
    assert error.mean() <= 0.03


def test_no_camera_is_one_clear_error(addon):
    scene = bpy.context.scene
    scene.render.engine = "BO2_LIGHTING"
    bpy.ops.mesh.primitive_plane_add()
    with pytest.raises(RuntimeError, match="no camera"):
        bpy.ops.render.render()


def test_panoramic_camera_is_one_clear_error(addon):
    scene = lambert_plane_scene("SUN", energy=1.0)
    scene.camera.data.type = "PANO"
    scene.render.engine = "BO2_LIGHTING"
    with pytest.raises(RuntimeError, match="panoramic") as info:
        bpy.ops.render.render()
    assert "Traceback" not in str(info.value)
    # The session is not broken: the next render works.
    scene.camera.data.type = "ORTHO"
    px = render_pixels(scene, "BO2_LIGHTING", samples=1)
    assert px[..., 0].mean() == pytest.approx(1.0 / math.pi, rel=0.01)


def test_nan_vertices_still_render(addon, capfd):
    scene = lambert_plane_scene("SUN", energy=1.0)
    nan = float("nan")
    mesh = bpy.data.meshes.new("Broken")
    mesh.from_pydata(
        [(nan, 0, 0.1), (0.01, 0, 0.1), (0, 0.01, 0.1),  # a NaN corner
         (0, 0, 0.1), (0.01, 0.01, 0.1), (0.02, 0.02, 0.1)],  # collinear: zero area
        [], [(0, 1, 2), (3, 4, 5)])
    scene.collection.objects.link(bpy.data.objects.new("Broken", mesh))
    px = render_pixels(scene, "BO2_LIGHTING")
    assert np.isfinite(px).all()
    # The white plane around the broken one still renders at its Lambert value.
    assert np.median(px[..., 0]) == pytest.approx(1.0 / math.pi, rel=0.01)
    out = capfd.readouterr()
    assert (out.out + out.err).count(
        "Skipped 1 triangles with NaN or infinite vertices and 1 with zero area") == 1


def test_pass_table_maps_to_blender(addon, tmp_path):
    """Every pass of the core's table has a view layer flag, and the engine writes exactly the
    enabled passes, under the running Blender's names."""
    import OpenEXR

    from bo2_lighting.addon.blender import images, passes
    from bo2_lighting.addon.core.render.passes import PASSES

    scene, layer = bpy.context.scene, bpy.context.view_layer
    assert set(PASSES) | set(passes.CYCLES_COLOR) == set(passes.FLAGS)
    for name in passes.FLAGS:
        passes.set_enabled(layer, name, name in ("Combined", "GlossDir", "Gloss"))
    assert passes.enabled(layer, "Gloss") and not passes.enabled(layer, "Albedo")
    add_ortho_camera(scene, 2.0)
    scene.render.resolution_x, scene.render.resolution_y = 8, 6
    render_pixels(scene, "BO2_LIGHTING", samples=1)
    path = tmp_path / "passes.exr"
    images.save_render_result(scene, path, "OPEN_EXR_MULTILAYER", "32")
    written = {key.split(".")[1] for part in OpenEXR.File(str(path)).parts
               for key in part.channels}
    glossy = "Glossy Direct" if bpy.app.version >= (5, 0, 0) else "GlossDir"
    assert written == {"Combined", glossy, "Gloss"}
    assert passes.readable_name("GlossDir") == "Glossy Direct"


def test_a_foreign_numba_is_one_clear_error(addon, monkeypatch):
    """Another extension's numba in Blender's shared site-packages: the render stops with one
    message that says what is needed and what was found, and Blender goes on."""
    import sys
    import types

    scene = lambert_plane_scene("SUN")
    fake = types.ModuleType("numba")
    fake.__version__, fake.__file__ = "0.60.0", "/other/extension/numba/__init__.py"
    monkeypatch.setitem(sys.modules, "numba", fake)
    with pytest.raises(RuntimeError, match=r"needs numba 0\.68\.1.*found numba 0\.60\.0"):
        render_pixels(scene, "BO2_LIGHTING", samples=1)
    monkeypatch.undo()
    assert render_pixels(scene, "BO2_LIGHTING", samples=1).shape[2] == 4


def test_running_out_of_memory_is_one_message_with_the_figure(addon, monkeypatch):
    """A render that runs out of memory stops with one message that names memory, the
    triangles and what the frame needs (``core.render.memory.frame_bytes``), and Blender goes on."""
    from bo2_lighting.addon.core.render import pipeline

    scene = lambert_plane_scene("SUN")
    real = pipeline.render_tiles

    def starved(*args, **kwargs):
        raise MemoryError()

    monkeypatch.setattr(pipeline, "render_tiles", starved)
    # the sun's map; the world is black: no dome (``core.render.sky``)
    with pytest.raises(RuntimeError, match=r"ran out of memory: 2 triangles and 1 shadow map "
                                           r"need about 17 MiB beside Blender's own"):
        render_pixels(scene, "BO2_LIGHTING", samples=1)
    monkeypatch.setattr(pipeline, "render_tiles", real)
    assert render_pixels(scene, "BO2_LIGHTING", samples=1).shape[2] == 4
    from bo2_lighting.addon.blender import extract

    monkeypatch.setattr(extract, "to_world", lambda *args: starved())  # reading the scene
    with pytest.raises(RuntimeError, match=r"ran out of memory reading the scene: its 2 "
                                           r"triangles need about 0 MiB"):
        render_pixels(scene, "BO2_LIGHTING", samples=1)


def test_contact_occlusion_is_searched_without_indirect_light_only_for_its_pass(addon,
                                                                                monkeypatch):
    """A black world and no probe: the frame has no indirect light to occlude, so the engine
    searches contact occlusion only while the view layer's AO pass is on."""
    from bo2_lighting.addon.blender import passes
    from bo2_lighting.addon.core.render import pipeline

    scene = lambert_plane_scene("SUN")
    searched = []
    real = pipeline.tile_ambient
    monkeypatch.setattr(pipeline, "tile_ambient",
                        lambda *args: searched.append(1) or real(*args))
    layer = bpy.context.view_layer
    for wanted in (False, True):
        passes.set_enabled(layer, "AO", wanted)
        searched.clear()
        render_pixels(scene, "BO2_LIGHTING", samples=1)
        assert bool(searched) == wanted
