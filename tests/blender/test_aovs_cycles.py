"""Shader AOVs (View Layer > Shader AOV, the AOV Output node) against Cycles: a sphere whose
material writes its object-space position as a colour AOV and its facing (Layer Weight) as a
value AOV, beside a cube whose material writes none, over the empty world. Cycles writes the
same nodes' values averaged over its samples (alpha 1 where a colour AOV is written), so the
passes are compared pixel by pixel.
"""

import bpy
import numpy as np
from util import add_ortho_camera, principled, render_on_devices, render_passes, set_world_color

W, H = 96, 64


def build():
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = W, H
    scene.render.resolution_percentage = 100
    set_world_color(scene, (0.1, 0.1, 0.1))
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.8, location=(-0.6, 0.0, 0.0), segments=64,
                                         ring_count=32)
    bpy.ops.object.shade_smooth()
    mat = principled("Writes", (0.5, 0.5, 0.5))
    tree = mat.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    facing = tree.nodes.new("ShaderNodeLayerWeight")
    color = tree.nodes.new("ShaderNodeOutputAOV")
    color.aov_name = "position"
    tree.links.new(coords.outputs["Object"], color.inputs["Color"])
    value = tree.nodes.new("ShaderNodeOutputAOV")
    value.aov_name = "facing"
    tree.links.new(facing.outputs["Facing"], value.inputs["Value"])
    bpy.context.object.data.materials.append(mat)
    bpy.ops.mesh.primitive_cube_add(size=0.9, location=(0.9, 0.0, 0.0))
    bpy.context.object.data.materials.append(principled("Silent"))
    add_ortho_camera(scene, 3.0, height=3.0)
    layer = bpy.context.view_layer
    for name, kind in (("position", "COLOR"), ("facing", "VALUE")):
        aov = layer.aovs.add()
        aov.name, aov.type = name, kind
    return scene


def test_shader_aovs_match_cycles(addon):
    """Inside the sphere (fully covered in both, 3 pixels in from its silhouette, where the
    facing changes fast and the engines' sample positions differ) each AOV within 0.015 of
    Cycles' at 99% of the pixels; over the frame its mean within 0.005; 0 on the cube and
    the world; the colour's alpha the coverage."""
    scene = build()
    names = ["Combined", "position", "facing"]
    ours = render_passes(scene, "BO2_LIGHTING", names, samples=16)
    cycles = render_passes(scene, "CYCLES", names, samples=64)
    inside = (ours["position"][..., 3] == 1.0) & (cycles["position"][..., 3] > 0.9999)
    for _ in range(3):
        inside[1:-1, 1:-1] &= (inside[:-2, 1:-1] & inside[2:, 1:-1] & inside[1:-1, :-2]
                               & inside[1:-1, 2:])
    assert inside.sum() > 0.2 * W * H
    for name, channels in (("position", 4), ("facing", 1)):
        a, b = ours[name], cycles[name]
        assert a.shape == b.shape == (H, W, channels), (name, a.shape, b.shape)
        d = np.abs(a - b)[inside]
        print(f"{name}: inside mean |d| {d.mean():.4f}, 99% {np.percentile(d, 99):.4f}; "
              f"frame mean BO2 {a.mean():.4f}, Cycles {b.mean():.4f}")
        assert np.percentile(d, 99) < 0.015 and abs(a.mean() - b.mean()) < 0.005, name
    cube = (H // 2, int(W * (0.5 + 0.9 / 3.0)))
    assert not ours["position"][cube].any() and not ours["facing"][cube].any()
    assert not cycles["position"][cube].any()


def test_the_gpu_writes_them_as_the_cpu(addon):
    """Device GPU: the same AOV passes as the CPU's (where there is no GPU context: the CPU,
    said so)."""
    images = render_on_devices(build(), ["position", "facing"])
    if images is None:
        return
    for name in ("position", "facing"):
        d = np.abs(images["GPU"][name] - images["CPU"][name])
        assert d.mean() < 1e-3, (name, d.mean())
