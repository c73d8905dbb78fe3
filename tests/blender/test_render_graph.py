"""Reading the scene as a final render evaluates it (``blender.render_graph``): what bakes read,
and what they leave as it was (the last render, the scene's settings)."""

import bpy
import pytest

from bo2_lighting.addon.blender import images, render_graph


def triangles(obj, depsgraph) -> int:
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    mesh.calc_loop_triangles()
    count = len(mesh.loop_triangles)
    evaluated.to_mesh_clear()
    return count


def test_the_render_levels_and_render_only_objects_are_read(addon):
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.object
    cube.modifiers.new("Subdivision", "SUBSURF")  # Levels Viewport 1, Render 2
    bpy.ops.mesh.primitive_plane_add(location=(3, 0, 0))
    shown_in_renders = bpy.context.object
    shown_in_renders.hide_viewport = True
    viewport = bpy.context.evaluated_depsgraph_get()
    assert triangles(cube, viewport) == 48
    assert shown_in_renders.name not in {o.name for o in viewport.objects}

    def read(depsgraph):
        return (depsgraph.mode, triangles(cube, depsgraph),
                shown_in_renders.name in {o.name for o in depsgraph.objects})

    assert scene.camera is None  # a bake needs no camera
    assert render_graph.evaluate(scene, read) == ("RENDER", 192, True)
    assert scene.camera is None and not bpy.data.images  # nothing left behind


def test_the_last_render_and_the_settings_are_kept(addon):
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_cube_add()
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location, cam.rotation_euler = (0, -6, 0), (1.5708, 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    r = scene.render
    r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage = "CYCLES", 48, 32, 100
    scene.cycles.samples = 1
    assert bpy.ops.render.render() == {"FINISHED"}
    last = images.render_result_pixels(scene).copy()
    bpy.context.view_layer.use = False  # off for renders: still the layer a bake reads
    r.use_border = True
    result = next(i for i in bpy.data.images if i.type == "RENDER_RESULT")
    slot = result.render_slots.active_index
    for _ in range(2):
        assert render_graph.evaluate(scene, lambda depsgraph: depsgraph.mode) == "RENDER"
    assert (r.engine, r.resolution_percentage, r.use_border) == ("CYCLES", 100, True)
    assert bpy.context.view_layer.use is False
    assert result.render_slots.active_index == slot
    assert sum(s.name == render_graph.SLOT for s in result.render_slots) == 1
    assert (images.render_result_pixels(scene) == last).all()


def test_what_the_reading_raises_is_raised(addon):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"

    def fail(depsgraph):
        raise ValueError("no such thing")

    with pytest.raises(ValueError, match="no such thing"):
        render_graph.evaluate(scene, fail)
    assert scene.render.engine == "CYCLES"
    assert render_graph.evaluate(scene, lambda depsgraph: 7) == 7  # nothing stays pending
