"""The Device setting through Blender (5.2 LTS's bpy, background mode): F12 drawn on the GPU
matches the CPU's render, Auto leaves a software rasterizer to the CPU, and a frame the GPU
does not draw yet renders on the CPU with one message; the child-process probe."""

import sys

import bpy
import compare
import numpy as np
import pytest

import bo2_lighting
from bo2_lighting.addon.gpu_backend import device


@pytest.fixture
def scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bo2_lighting.register()
    s = bpy.context.scene
    s.render.engine = "BO2_LIGHTING"
    s.render.resolution_x, s.render.resolution_y = 240, 136
    s.render.resolution_percentage = 100
    bpy.ops.mesh.primitive_plane_add(size=10)
    bpy.ops.mesh.primitive_uv_sphere_add(location=(0, 0, 1))
    bpy.ops.object.shade_smooth()
    bpy.ops.object.light_add(type="SUN", rotation=(0.6, 0.2, 0.0))
    bpy.ops.object.light_add(type="SPOT", location=(2, -2, 3), rotation=(0.7, 0.0, 0.8))
    bpy.context.object.data.energy = 500
    bpy.ops.object.camera_add(location=(6, -6, 4), rotation=(1.1, 0, 0.785))
    s.camera = bpy.context.object
    yield s
    bo2_lighting.unregister()


def _render(scene, choice):
    from bo2_lighting.addon.blender import engine

    scene.bo2.device = choice
    with engine.listening() as sink:
        bpy.ops.render.render()
    image = bpy.data.images["Render Result"]
    # the Combined pass through the compositor-less result: read via a saved EXR
    path = bpy.app.tempdir + f"bo2_gpu_{choice}.exr"
    scene.render.image_settings.file_format = "OPEN_EXR"
    image.save_render(path)
    loaded = bpy.data.images.load(path)
    pixels = np.array(loaded.pixels[:], np.float32).reshape(loaded.size[1], loaded.size[0], 4)
    bpy.data.images.remove(loaded)
    return pixels, sink.texts()


def _gpu_matches_cpu(scene, what: str) -> None:
    """F12 with Device GPU renders on the GPU, Device CPU on the CPU, 40 dB or more apart."""
    gpu_pixels, said = _render(scene, "GPU")
    assert any(text.startswith("Rendered on the GPU") for text in said), said
    cpu_pixels, said_cpu = _render(scene, "CPU")
    assert not any("GPU" in text for text in said_cpu), said_cpu
    value = compare.psnr(gpu_pixels, cpu_pixels)
    print(f"{what}: {value:.1f} dB")
    assert value >= 40.0


def test_f12_on_the_gpu_matches_the_cpu(scene):
    scene.bo2.indirect.use = True
    _gpu_matches_cpu(scene, "F12 GPU vs CPU")


def test_auto_leaves_a_software_rasterizer_to_the_cpu(scene):
    found = device.probe(device.probe_command(bpy.app.binary_path))
    _, said = _render(scene, "AUTO")
    if found.software:
        assert any("software rasterizer" in text for text in said), said
    else:
        assert any(text.startswith("Rendered on the GPU") for text in said), said


def test_a_node_graph_material_renders_on_the_gpu(scene):
    """A Principled BSDF whose colour comes from Generated coordinates through a Color Ramp,
    and whose roughness from a Noise-free Math chain: the GPU draws its program."""
    mat = bpy.data.materials.new("Gradient")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    coords = nodes.new("ShaderNodeTexCoord")
    xyz = nodes.new("ShaderNodeSeparateXYZ")
    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.8, 0.1, 0.05, 1.0)
    ramp.color_ramp.elements[1].color = (0.05, 0.3, 0.9, 1.0)
    rough = nodes.new("ShaderNodeMath")
    rough.operation = "MULTIPLY"
    rough.inputs[1].default_value = 0.7
    links.new(coords.outputs["Generated"], xyz.inputs[0])
    links.new(xyz.outputs["Z"], ramp.inputs["Fac"])
    links.new(xyz.outputs["X"], rough.inputs[0])
    bsdf = nodes["Principled BSDF"]
    links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(rough.outputs["Value"], bsdf.inputs["Roughness"])
    bpy.data.objects["Sphere"].data.materials.append(mat)
    _gpu_matches_cpu(scene, "F12 of a node graph, GPU vs CPU")


def test_a_transparent_material_renders_on_the_gpu(scene):
    """Alpha 0.4 on the sphere, dithered on both devices with the same thresholds."""
    mat = bpy.data.materials.new("Glass")
    mat.use_nodes = True
    mat.node_tree.nodes["Principled BSDF"].inputs["Alpha"].default_value = 0.4
    bpy.data.objects["Sphere"].data.materials.append(mat)
    scene.bo2.samples = 8
    _gpu_matches_cpu(scene, "F12 of a transparent material, GPU vs CPU")


def test_what_the_gpu_does_not_draw_renders_on_the_cpu_with_one_message(scene):
    """A material reading more colour attributes than the GPU's vertex inputs hold."""
    from bo2_lighting.addon.gpu_backend import materials

    sphere = bpy.data.objects["Sphere"]
    mat = bpy.data.materials.new("Painted")
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    total = None
    for k in range(materials.MAX_STREAMS + 1):
        sphere.data.color_attributes.new(f"paint{k}", "FLOAT_COLOR", "CORNER")
        read = nodes.new("ShaderNodeAttribute")
        read.attribute_name = f"paint{k}"
        if total is None:
            total = read.outputs["Color"]
            continue
        add = nodes.new("ShaderNodeVectorMath")
        links.new(total, add.inputs[0])
        links.new(read.outputs["Color"], add.inputs[1])
        total = add.outputs["Vector"]
    links.new(total, nodes["Principled BSDF"].inputs["Base Color"])
    sphere.data.materials.append(mat)
    _, said = _render(scene, "GPU")
    notes = [text for text in said if text.startswith("Rendered on the CPU")]
    assert len(notes) == 1 and "attributes" in notes[0], said


def test_the_probe_names_why_there_is_no_gpu():
    """A Blender that aborts opening a context (no display, no EGL) is a reason, not a crash."""
    aborted = device.probe([sys.executable, "-c", "import os; os.abort()"])
    assert not aborted.ok and "exit" in aborted.reason
    missing = device.probe(["/nonexistent/blender"])
    assert not missing.ok and "could not run" in missing.reason


def test_a_frame_too_large_for_the_gpu_renders_on_the_cpu(scene):
    """An 8K frame's targets would take about 11 GiB of GPU memory: one message, the CPU
    (a small render border keeps the CPU's share short)."""
    scene.render.resolution_x, scene.render.resolution_y = 7680, 4320
    scene.render.use_border = True
    scene.render.border_min_x, scene.render.border_max_x = 0.5, 0.52
    scene.render.border_min_y, scene.render.border_max_y = 0.5, 0.52
    _, said = _render(scene, "GPU")
    notes = [text for text in said if text.startswith("Rendered on the CPU")]
    assert len(notes) == 1 and "GiB of GPU memory" in notes[0], said
