"""Each Properties tab as an artist sees it with BO2 Lighting picked: every panel the tab shows
(Blender's own that opt in, and the add-on's) drawn into a recording layout. The same walk runs
in a real window (``tests/gui``); here a stand-in context plays the Properties editor's."""

import types

import bpy
import panel_walk
import pytest

ENGINE = "BO2_LIGHTING"


def context_for(scene, obj=None, **extra):
    """The Properties editor's context members for ``obj`` (its data under its type's name)."""
    data = getattr(obj, "data", None)
    members = dict(
        engine=ENGINE, scene=scene, view_layer=scene.view_layers[0], world=scene.world,
        object=obj, active_object=obj, preferences=bpy.context.preferences,
        space_data=types.SimpleNamespace(type="PROPERTIES", context="DATA", pin_id=None,
                                         use_pin_id=False),
        light=data if isinstance(data, bpy.types.Light) else None,
        lightprobe=data if isinstance(data, bpy.types.LightProbe) else None,
        camera=data if isinstance(data, bpy.types.Camera) else None,
        mesh=data if isinstance(data, bpy.types.Mesh) else None,
        material=obj.active_material if obj is not None and obj.type == "MESH" else None,
        material_slot=None, texture=None, collection=None, curve=None, meta_ball=None,
        lattice=None, armature=None, speaker=None, volume=None, pointcloud=None,
        curves=None, grease_pencil=None, bone=None, edit_bone=None, pose_bone=None,
        particle_system=None, brush=None, line_style=None, texture_slot=None,
        workspace=bpy.context.workspace, mode="OBJECT", texture_user=None,
        texture_user_property=None, region=None, area=None,
    )
    members.update(extra)
    ns = types.SimpleNamespace(**members)
    ns.path_resolve = lambda path, coerce=True: eval("ns." + path, {"ns": ns})  # noqa: S307
    return ns


@pytest.fixture
def studio(addon):
    """A scene with a mesh and material, a camera, a light of each type and both probe kinds."""
    scene = bpy.context.scene
    scene.render.engine = ENGINE
    scene.world = bpy.data.worlds.new("World")
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    cube.data.materials.append(bpy.data.materials.new("Paint"))
    objs = {"MESH": cube}
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    objs["CAMERA"] = cam
    for kind in ("POINT", "SPOT", "SUN", "AREA"):
        obj = bpy.data.objects.new(kind, bpy.data.lights.new(kind, kind))
        scene.collection.objects.link(obj)
        objs[kind] = obj
    for kind in ("SPHERE", "VOLUME"):
        bpy.ops.object.lightprobe_add(type=kind)
        objs[kind] = bpy.context.object
    return scene, objs


def tab(scene, name, obj=None):
    panels = panel_walk.shown(context_for(scene, obj), name)
    assert panels, f"the {name} tab shows nothing"
    assert panel_walk.duplicate_titles(panels) == [], name
    props = panel_walk.shown_properties(panels)
    return panels, props


def test_light_tabs_show_what_bo2_renders(studio):
    scene, objs = studio
    wanted = {"POINT": {"shadow_soft_size"}, "SPOT": {"shadow_soft_size", "spot_size",
                                                      "spot_blend"},
              "SUN": {"angle"}, "AREA": {"shape", "size"}}
    for kind, own in wanted.items():
        panels, props = tab(scene, "data", objs[kind])
        names = {p.split(".")[1] for p in props if p.startswith(type(objs[kind].data).__name__)}
        assert {"type", "color", "energy", "exposure", "normalize", "use_temperature",
                "temperature", "use_shadow", *own} <= names, (kind, names)
        drawn = [p for p in props if not p.startswith("BO2SceneSettings")]
        assert len(drawn) == len(set(drawn)), f"{kind}: a setting drawn twice: {drawn}"
        labels = [e[2].get("text", "") for _, log in panels for e in log if e[0] == "label"]
        assert "Not used by BO2 Lighting:" in labels, kind


def test_probe_tab_shows_each_setting_once(studio):
    scene, objs = studio
    for kind in ("SPHERE", "VOLUME"):
        panels, props = tab(scene, "data", objs[kind])
        assert len(props) == len(set(props)), f"{kind}: drawn twice: {props}"
        titles = [c.bl_label for c, _ in panels
                  if c.bl_label and not getattr(c, "bl_parent_id", "")]
        expected = ["Probe", "Custom Parallax", "Viewport Display", "BO2 Bake", "Animation"]
        if kind == "VOLUME":
            expected.remove("Custom Parallax")
        assert titles == expected, titles  # the probe first, its bake after its settings
        names = {p.split(".")[1] for p in props}
        assert {"influence_distance", "clip_start"} <= names
        if kind == "VOLUME":
            assert {"resolution_x", "dilation_threshold", "validity_threshold"} <= names
        operators = {e[1][0] for _, log in panels for e in log if e[0] == "operator"}
        assert "bo2.bake_probes" in operators


def test_every_tab_draws(studio):
    scene, objs = studio
    _, props = tab(scene, "render")
    assert {"BO2SceneSettings.samples", "BO2SceneSettings.shadow_resolution",
            "RenderSettings.preview_pixel_size", "ColorManagedViewSettings.view_transform",
            "RenderSettings.motion_blur_shutter", "CyclesRenderSettings.rolling_shutter_type",
            "CyclesRenderSettings.rolling_shutter_duration", "BO2SceneSettings.bake_on"
            } <= set(props)
    assert "BO2SceneSettings.scheduler" not in props  # (baking here)
    scene.bo2.bake_on = "CLUSTER"
    assert "BO2SceneSettings.scheduler" in tab(scene, "render")[1]
    scene.bo2.bake_on = "LOCAL"
    _, props = tab(scene, "output")
    assert "RenderSettings.resolution_x" in props
    _, props = tab(scene, "view_layer")
    assert "BO2ViewLayerSettings.use_pass_albedo" in props
    tab(scene, "world")
    _, props = tab(scene, "object", objs["MESH"])
    assert {"Object.visible_camera", "Object.visible_shadow", "Object.is_holdout",
            "Object.hide_probe_volume", "Object.hide_probe_sphere",
            "BO2ObjectSettings.lightmap_mode", "BO2ObjectSettings.lightmap_uv",
            "BO2ObjectSettings.lightmap_density"} <= set(props)
    _, props = tab(scene, "data", objs["CAMERA"])
    assert "Camera.lens" in props
    panels, props = tab(scene, "material", objs["MESH"])
    assert {"Material.pass_index", "Material.use_backface_culling"} <= set(props)
    assert "Preview" in [c.bl_label for c, _ in panels]


def test_engine_uses_blender_shader_trees_and_previews(studio):
    """Blender's shader tree poll refuses engines that draw their own node trees: with
    ``bl_use_shading_nodes_custom`` False the Shader Editor shows the material's tree (seen
    in the window by ``tests/gui``); previews are the engine's own."""
    engine = bpy.types.RenderEngine.bl_rna_get_subclass_py(ENGINE)
    assert engine.bl_use_shading_nodes_custom is False
    assert engine.bl_use_preview is True
