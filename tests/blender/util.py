"""Helpers shared by the Blender tests."""

import bpy
import numpy as np

from bo2_lighting.addon.blender import images


def engine_available(identifier: str) -> bool:
    """True when ``identifier`` is in the scene's render engine list (what the UI offers)."""
    render = bpy.context.scene.render
    previous = render.engine
    try:
        render.engine = identifier
    except TypeError:
        return False
    render.engine = previous
    return bpy.types.RenderEngine.bl_rna_get_subclass_py(identifier) is not None


def set_world_color(scene, color=(0.0, 0.0, 0.0)) -> None:
    """Give ``scene`` a new world whose Background node has ``color``."""
    world = bpy.data.worlds.new("World")
    world.color = color
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (*color, 1.0)
    scene.world = world


def film(scene, width: int, height: int, transparent: bool = True) -> None:
    """``scene`` renders ``width`` x ``height`` pixels at 100%, its film transparent or not,
    the Standard view transform, and a black world."""
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = transparent
    scene.view_settings.view_transform = "Standard"
    set_world_color(scene)


def render_on_devices(scene, names, samples: int = 8) -> dict | None:
    """BO2's ``render_passes`` of ``scene`` with Device CPU and with Device GPU: {"CPU": its
    passes, "GPU": its passes}, or None where there is no GPU context (the GPU's frame then
    rendered on the CPU, saying so); fails when the GPU's frame did not render there."""
    from bo2_lighting.addon.blender import engine

    out = {}
    for device in ("CPU", "GPU"):
        scene.bo2.device = device
        with engine.listening() as said:
            out[device] = render_passes(scene, "BO2_LIGHTING", names, samples=samples)
    if any("no GPU context" in t for t in said.texts()):
        return None
    assert any("Rendered on the GPU" in t for t in said.texts()), said.texts()
    return out


def add_ortho_camera(scene, scale: float, height: float = 1.0):
    """An orthographic camera ``scale`` m wide at (0, 0, height) looking down; the scene's."""
    data = bpy.data.cameras.new("Camera")
    data.type = "ORTHO"
    data.ortho_scale = scale
    cam = bpy.data.objects.new("Camera", data)
    cam.location = (0.0, 0.0, height)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam


def render_pixels(scene, engine: str, samples: int = 4, size=None) -> np.ndarray:
    """Render ``scene`` with ``engine`` and return the Combined pass, (H, W, 4) float32 linear,
    row 0 at the bottom as Blender stores it. ``size``: (width, height) of the result when it
    is not the scene's resolution (a cropped render border)."""
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.samples = samples
        scene.cycles.device = "CPU"
        scene.cycles.use_denoising = False
    else:
        scene.bo2.samples = samples
    assert bpy.ops.render.render() == {"FINISHED"}
    px = images.render_result_pixels(scene)[::-1]
    if size is not None:
        assert px.shape[:2] == (size[1], size[0])
    return np.ascontiguousarray(px)


def principled(name: str, color=(0.8, 0.8, 0.8), roughness: float = 0.5, alpha: float = 1.0):
    """A new material with its Principled BSDF's Base Color, Roughness and Alpha set."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    node = mat.node_tree.nodes["Principled BSDF"]
    node.inputs["Base Color"].default_value = (*color, 1.0)
    node.inputs["Roughness"].default_value = roughness
    node.inputs["Alpha"].default_value = alpha
    return mat


def bare_material(name: str):
    """A new material whose node tree holds only its Material Output; returns (material, tree)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    tree = mat.node_tree
    for node in list(tree.nodes):
        if node.bl_idname != "ShaderNodeOutputMaterial":
            tree.nodes.remove(node)
    return mat, tree


def render_passes(scene, engine: str, names, samples: int = 16) -> dict:
    """Render ``scene`` with ``engine`` with passes ``names`` (pipeline names, ``blender.passes``)
    turned on; returns {name: (H, W, C) float32, row 0 at the top} of those it wrote."""
    import tempfile
    from pathlib import Path

    from bo2_lighting.addon.blender import passes

    layer = bpy.context.view_layer
    for name in names:
        if name in passes.FLAGS:  # (a light group's or a Cryptomatte pass is the layer's)
            passes.set_enabled(layer, name, True)
    scene.render.engine = engine
    if engine == "CYCLES":
        scene.cycles.samples = samples
        scene.cycles.device = "CPU"
        scene.cycles.use_denoising = False
        scene.cycles.use_adaptive_sampling = False
    else:
        scene.bo2.samples = samples
    assert bpy.ops.render.render() == {"FINISHED"}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "passes.exr"
        images.save_render_result(scene, path, "OPEN_EXR_MULTILAYER", "32", "RGBA",
                                  follow_scene=True)
        return images.read_exr_passes(path, layer.name, list(names))


def camera_of(scene, width: int, height: int):
    """The scene camera as the viewport's region camera would be in camera view, for a region
    of ``width`` x ``height`` pixels (``core.render.viewport.view_camera``)."""
    from bo2_lighting.addon.core.render import viewport

    depsgraph = bpy.context.evaluated_depsgraph_get()
    cam = scene.camera.evaluated_get(depsgraph)
    proj = cam.calc_matrix_camera(depsgraph, x=width, y=height)
    return viewport.view_camera(cam.matrix_world.inverted(), proj, width, height)


def baked(scene, name: str):
    """The bake file (a light probe's or a lightmap) of object ``name``, as its datablock
    declares it."""
    from bo2_lighting.addon.blender import bake_files

    return bake_files.path(scene.objects[name])


def add_far_ground(scene, size: float = 10000.0, depth: float = 50.0):
    """A ``size`` m square ground (terrain, ocean) ``depth`` m below the scene, dynamic (no
    lightmap of its own): what made every ray offset of a bake a metre long."""
    bpy.ops.mesh.primitive_plane_add(size=size, location=(0.0, 0.0, -depth))
    ground = bpy.context.object
    ground.name = "Far Ground"
    ground.data.materials.append(principled("Far Ground", (0.5, 0.5, 0.5), 0.8))
    ground.bo2.lightmap_mode = "DYNAMIC"
    return ground


def render_extraction(scene, **kw):
    """``extract.extract_scene`` of ``scene`` as a final render evaluates it (Render levels,
    render-only modifiers): (core scene, warnings)."""
    from bo2_lighting.addon.blender import extract, render_graph

    return render_graph.evaluate(scene, lambda depsgraph: extract.extract_scene(depsgraph, **kw))
