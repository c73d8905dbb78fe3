"""The add-on's Blender interface, headless: registration hygiene, panels drawn against a
recording layout, operators' poll and execute, undo, and operators' bad input."""

import types

import bpy
import pytest
from panel_walk import PanelProxy, Recorder
from util import bare_material

import bo2_lighting
from bo2_lighting.addon.blender import bake_files, library, node_groups, props, ui

ENGINE = "BO2_LIGHTING"


def snapshot() -> dict:
    """What registration can leave behind."""
    prefs = bpy.context.preferences
    return {
        "types": {name for name in dir(bpy.types)
                  if "bo2" in name.lower() or name == "BO2RenderEngine"},
        "scene_prop": hasattr(bpy.types.Scene, "bo2"),
        "view_layer_prop": hasattr(bpy.types.ViewLayer, "bo2"),
        "shading_prop": hasattr(bpy.types.View3DShading, "bo2_lookdev_view"),
        "compat": sorted(name for name in dir(bpy.types)
                         if ENGINE in (getattr(getattr(bpy.types, name), "COMPAT_ENGINES", None)
                                       or ())),
        "menus": sorted(f"{menu}:{fn.__name__}" for menu in ("TOPBAR_MT_render",
                                                            "VIEW3D_HT_header",
                                                            "NODE_MT_add")
                        for fn in _draw_funcs(getattr(bpy.types, menu, None))
                        if fn.__module__.startswith("bo2_lighting")),
        "handlers": {name: len(getattr(bpy.app.handlers, name))
                     for name in dir(bpy.app.handlers) if not name.startswith("_")
                     and isinstance(getattr(bpy.app.handlers, name), list)},
        "libraries": sorted(lib.name for lib in prefs.filepaths.asset_libraries),
        "addon_prefs": "bo2_lighting" in {cls.bl_idname for cls in
                                          bpy.types.AddonPreferences.__subclasses__()
                                          if getattr(cls, "is_registered", False)},
    }


def _draw_funcs(menu) -> list:
    if menu is None:
        return []
    draw = getattr(menu, "draw", None)
    return list(getattr(draw, "_draw_funcs", []))


def test_register_unregister_reregister_leaves_nothing(empty_scene):
    before = snapshot()
    assert not before["scene_prop"] and not before["compat"]
    bo2_lighting.register()
    on = snapshot()
    assert on["scene_prop"] and on["view_layer_prop"] and on["shading_prop"]
    assert "RENDER_PT_format" in on["compat"] and "DATA_PT_bo2_lightprobe" in on["types"]
    assert {"TOPBAR_MT_render:draw_render_menu",
            "VIEW3D_HT_header:draw_view3d_header"} <= set(on["menus"])
    assert library.LIBRARY_NAME in on["libraries"]
    assert on["addon_prefs"]
    bo2_lighting.unregister()
    assert snapshot() == before
    bo2_lighting.register()
    assert snapshot() == on
    bo2_lighting.unregister()
    assert snapshot() == before


def test_a_library_the_user_added_is_kept(empty_scene):
    libs = bpy.context.preferences.filepaths.asset_libraries
    own = libs.new(name="Mine", directory=str(library.LIBRARY_DIR))
    try:
        bo2_lighting.register()
        bo2_lighting.unregister()
        assert "Mine" in [lib.name for lib in libs]
        assert library.LIBRARY_NAME not in [lib.name for lib in libs]
    finally:
        libs.remove(own)


# ---- panels against a recording layout -------------------------------------------------

def context_for(**kwargs):
    scene = bpy.context.scene
    base = dict(scene=scene, view_layer=bpy.context.view_layer, engine=ENGINE, object=None,
                material=None, space_data=None, lightprobe=None, world=scene.world)
    base.update(kwargs)
    return types.SimpleNamespace(**base)


def draw_all(context) -> list:
    """Draw every panel of the add-on whose poll accepts ``context``; the log."""
    log = []
    for cls in ui.CLASSES:
        if hasattr(cls, "poll") and not cls.poll(context):
            continue
        panel = PanelProxy(cls, log)
        if hasattr(cls, "draw_header"):
            cls.draw_header(panel, context)
        cls.draw(panel, context)
    return log


@pytest.fixture
def scene_with_everything(addon, tmp_path):
    scene = bpy.context.scene
    scene.render.engine = ENGINE
    scene.bo2.bake_folder = str(tmp_path)
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    mat = bpy.data.materials.new("Principled")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    cube.data.materials.append(mat)
    bo2 = node_groups.new_material(node_groups.MATERIAL_GROUP)
    probes = {}
    for kind in ("SPHERE", "VOLUME"):
        probes[kind] = bpy.data.objects.new(kind, bpy.data.lightprobes.new(kind, kind))
        scene.collection.objects.link(probes[kind])
    return scene, cube, mat, bo2, probes


def test_every_panel_draws_existing_properties(scene_with_everything):
    scene, cube, mat, bo2, probes = scene_with_everything
    drawn = set()
    contexts = [context_for(), context_for(object=cube, material=mat),
                context_for(object=cube, material=bo2),
                context_for(object=probes["SPHERE"], lightprobe=probes["SPHERE"].data),
                context_for(object=probes["VOLUME"], lightprobe=probes["VOLUME"].data)]
    for context in contexts:
        log = draw_all(context)
        drawn |= {entry[1][1] for entry in log if entry[0] == "prop"}
        drawn |= {entry[1][0] for entry in log if entry[0] == "operator"}
    # what each panel is for shows up
    assert {"samples", "normalization", "bake_folder", "face_size", "density",
            "dilation_threshold", "clip_start", "bo2.bake_probes", "material.bo2_convert",
            "bo2.compare_cycles"} <= drawn
    labels = [str(entry[2].get("text", "")) for entry in draw_all(contexts[1])
              if entry[0] == "label"]
    assert "Albedo: 0.800, 0.800, 0.800" in labels  # Principled default base, dielectric
    assert any(text.startswith("Gloss: ") for text in labels)


def test_other_engines_hide_the_panels(scene_with_everything):
    context = context_for(engine="CYCLES")
    assert not any(cls.poll(context) for cls in ui.CLASSES if hasattr(cls, "poll"))


def test_menu_entries_draw(scene_with_everything):
    log = []
    shading = next(a.spaces[0].shading for s in bpy.data.screens for a in s.areas
                   if a.type == "VIEW_3D")
    shading.type = "RENDERED"
    ctx = context_for(space_data=types.SimpleNamespace(type="VIEW_3D", shading=shading))
    ui.draw_view3d_header(types.SimpleNamespace(layout=Recorder(log)), ctx)
    ui.draw_render_menu(types.SimpleNamespace(layout=Recorder(log)), ctx)
    assert ("prop", ("View3DShading", "bo2_lookdev_view"), {"text": ""}) in log
    assert any(entry[0] == "operator" and entry[1] == ("bo2.compare_cycles",) for entry in log)
    log.clear()
    shading.type = "SOLID"
    ui.draw_view3d_header(types.SimpleNamespace(layout=Recorder(log)), ctx)
    assert log == []


def test_enum_identifiers_are_stable(addon):
    """Saved files store these identifiers: renaming one loses the user's choice."""
    scene = bpy.types.Scene.bl_rna.properties["bo2"].fixed_type.properties
    s = {name: prop for group in ("indirect", "probes", "lightmaps") for name, prop in
         scene[group].fixed_type.properties.items()}
    views = bpy.types.View3DShading.bl_rna.properties["bo2_lookdev_view"]
    assert list(views.enum_items.keys()) == [
        "COMBINED", "ALBEDO", "SPECULAR_COLOR", "GLOSS", "NORMAL", "DIFFUSE_DIRECT",
        "GLOSSY_DIRECT", "DIFFUSE_INDIRECT", "GLOSSY_INDIRECT", "REFLECTION_PROBES",
        "IRRADIANCE_VOLUMES", "AMBIENT_OCCLUSION", "LIGHTMAP", "LIGHTMAP_TEXELS"]
    assert list(s["backend"].enum_items.keys()) == ["DEFAULT", "BO2", "CYCLES"]
    assert list(s["max_resolution"].enum_items.keys()) == [
        "128", "256", "512", "1024", "2048", "4096"]
    o = bpy.types.Object.bl_rna.properties["bo2"].fixed_type.properties
    assert list(o["lightmap_mode"].enum_items.keys()) == ["AUTO", "STATIC", "DYNAMIC"]
    assert list(s["normalization"].enum_items.keys()) == ["none", "bo1", "bo2"]
    assert list(s["prefilter"].enum_items.keys()) == ["bo1", "bo2"]
    every = {f"scene.bo2.{name}": prop for name, prop in scene.items()}
    for group in ("indirect", "probes", "lightmaps", "viewport", "lookdev"):
        every |= {f"scene.bo2.{group}.{name}": prop
                  for name, prop in scene[group].fixed_type.properties.items()}
    for path, prop in every.items():
        if not path.endswith("rna_type"):
            assert prop.description, f"{path} has no description"


def test_undo_restores_a_bo2_setting(addon):
    scene = bpy.context.scene
    scene.bo2.samples = 4
    scene.bo2.indirect.normalization = "bo2"
    bpy.ops.ed.undo_push(message="before")
    scene.bo2.samples = 33
    scene.bo2.indirect.normalization = "bo1"
    bpy.ops.ed.undo_push(message="change")
    assert bpy.ops.ed.undo() == {"FINISHED"}
    assert bpy.context.scene.bo2.samples == 4
    assert bpy.context.scene.bo2.indirect.normalization == "bo2"
    assert bpy.ops.ed.redo() == {"FINISHED"}
    assert bpy.context.scene.bo2.samples == 33


def test_preferences_defaults_reach_the_scene(addon, tmp_path):
    from bo2_lighting.addon.blender import probes

    scene = bpy.context.scene
    scene.bo2.bake_folder = ""
    assert props.preferences().bake_folder == "//bo2_bake/"
    scene.bo2.probes.backend = "DEFAULT"
    assert probes.capture_backend(scene) == "BO2"
    scene.bo2.probes.backend = "CYCLES"
    assert probes.capture_backend(scene) == "CYCLES"
    scene.bo2.bake_folder = str(tmp_path)
    assert probes.bake_folder(scene) == tmp_path


# ---- operators: poll and execute, and bad input -----------------------------------------

def run(op, **kwargs):
    """Run operator ``op`` (a ``bpy.ops`` function); the reports it printed come back in the
    RuntimeError Blender raises for a cancelled operator with an error."""
    return op(**kwargs)


def test_operators_poll_and_execute(scene_with_everything, tmp_path):
    scene, cube, mat, bo2, probes = scene_with_everything
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    # the bake of the active probe writes its file; clear removes it
    bpy.context.view_layer.objects.active = probes["SPHERE"]
    scene.bo2.probes.face_size = "32"
    scene.bo2.probes.samples = 1
    assert bpy.ops.bo2.bake_probes.poll()
    assert bpy.ops.bo2.bake_probes(mode="ACTIVE") == {"FINISHED"}
    sphere = bake_files.path(probes["SPHERE"])
    assert sphere.parent == bake_files.file_folder(scene) and sphere.exists()  # absolute: a digest
    assert sphere.parent.name.startswith("scene-") and sphere.parent.parent == tmp_path
    assert bake_files.path(probes["VOLUME"]) is None
    assert bpy.ops.bo2.unpack_bakes() == {"FINISHED"}
    assert bpy.ops.bo2.pack_bakes() == {"FINISHED"} and bake_files.packed(probes["SPHERE"])
    assert bpy.ops.bo2.clear_probes(mode="ACTIVE") == {"FINISHED"}
    assert not sphere.exists() and bake_files.image(probes["SPHERE"]) is None
    # materials
    bpy.context.view_layer.objects.active = cube
    assert bpy.ops.material.bo2_new() == {"FINISHED"}
    assert any(node_groups.is_bo2_material_node(n) for n in cube.active_material.node_tree.nodes)
    mat = bpy.data.materials["Principled"]
    with bpy.context.temp_override(material=mat):
        assert bpy.ops.material.bo2_convert.poll()
        assert bpy.ops.material.bo2_convert(direction="TO_BO2") == {"FINISHED"}
        assert bpy.ops.material.bo2_convert(direction="TO_PRINCIPLED") == {"FINISHED"}
    with bpy.context.temp_override(material=None):
        assert not bpy.ops.material.bo2_convert.poll()
    assert bpy.ops.bo2.compare_cycles.poll()


@pytest.mark.parametrize("case", ["nothing selected", "not a probe", "unsaved", "read-only",
                                  "folder is a file", "during a bake"])
def test_bake_bad_input_is_one_clear_message(scene_with_everything, tmp_path, case):
    scene, cube, mat, bo2, probes = scene_with_everything
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    kwargs, expected = {"mode": "ALL"}, ""
    if case == "nothing selected":
        for obj in scene.objects:
            obj.select_set(False)
        kwargs["mode"], expected = "SELECTED", "No Sphere or Volume light probes among"
    elif case == "not a probe":
        bpy.context.view_layer.objects.active = cube
        kwargs["mode"], expected = "ACTIVE", "The active object is not a light probe"
    elif case == "unsaved":
        bpy.ops.wm.read_homefile(use_empty=True)
        bo2_lighting.unregister()
        bo2_lighting.register()
        probe = bpy.data.objects.new("P", bpy.data.lightprobes.new("P", "SPHERE"))
        bpy.context.scene.collection.objects.link(probe)
        bpy.context.scene.bo2.bake_folder = ""
        expected = "Save the .blend file first"
    elif case == "read-only":
        scene.bo2.bake_folder = "/proc/bo2_bake"
        expected = "is not writable"
    elif case == "folder is a file":
        (tmp_path / "file").write_text("x")
        scene.bo2.bake_folder = str(tmp_path / "file" / "bake")
        expected = "is a file, not a folder"
    else:
        from bo2_lighting.addon.blender import bake_operators
        bake_operators._ModalBake.running = True
        expected = "A bake is running"
    files = sorted(p.name for p in tmp_path.iterdir())
    try:
        with pytest.raises(RuntimeError, match=expected):
            bpy.ops.bo2.bake_probes(**kwargs)
    finally:
        from bo2_lighting.addon.blender import bake_operators
        bake_operators._ModalBake.running = False
    assert sorted(p.name for p in tmp_path.iterdir()) == files  # nothing changed


def test_convert_bad_input(scene_with_everything):
    scene, cube, mat, bo2, probes = scene_with_everything
    emission, tree = bare_material("Glow")
    node = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    with bpy.context.temp_override(material=emission):
        with pytest.raises(RuntimeError, match="not a Principled BSDF"):
            bpy.ops.material.bo2_convert(direction="TO_BO2")
        with pytest.raises(RuntimeError, match="not a BO2 Material"):
            bpy.ops.material.bo2_convert(direction="TO_PRINCIPLED")
    # a BO2 Material with a texture on its albedo cannot be inverted
    image = bo2.node_tree.nodes.new("ShaderNodeTexImage")
    node = next(n for n in bo2.node_tree.nodes if node_groups.is_bo2_material_node(n))
    bo2.node_tree.links.new(image.outputs["Color"], node.inputs["Albedo"])
    with bpy.context.temp_override(material=bo2):
        with pytest.raises(RuntimeError, match="Albedo linked"):
            bpy.ops.material.bo2_convert(direction="TO_PRINCIPLED")
    assert node_groups.is_bo2_material_node(node)  # unchanged


def test_convert_with_an_edited_group_changes_nothing(scene_with_everything):
    scene, cube, mat, bo2, probes = scene_with_everything
    group = node_groups.ensure_group(node_groups.MATERIAL_GROUP)
    group.interface.remove(next(i for i in group.interface.items_tree
                                if i.item_type == "SOCKET" and i.name == "Alpha"))
    names = sorted(n.name for n in mat.node_tree.nodes)
    with bpy.context.temp_override(material=mat):
        with pytest.raises(RuntimeError, match="has no socket Alpha"):
            bpy.ops.material.bo2_convert(direction="TO_BO2")
    assert sorted(n.name for n in mat.node_tree.nodes) == names
