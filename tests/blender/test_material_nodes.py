"""The material compiler against Cycles, node family by node family.

Each case builds a node chain on a flat plane seen by an orthographic camera from above and
feeds it into a Diffuse BSDF (or a Glossy BSDF, an Emission, a shader mix), so that the
comparison is exact: BO2 Lighting's Albedo pass against Cycles' Diffuse Color pass (the
diffuse closure's weight, which is the chain's value), its Specular Color pass against Cycles'
Glossy Color pass for a Glossy BSDF, Emission against Emission, Normal against Normal. Both
engines filter the same smooth signals over the pixel, so the bound is a rounding bound, except
where a case has hard edges (stated per case).
"""

import math

import bpy
import numpy as np
import pytest
from util import add_ortho_camera, bare_material, render_passes, set_world_color

RES = 24


def plane_scene(mat, size=2.0):
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.render.filter_size = scene.cycles.filter_width = 0.01  # samples at pixel centres
    scene.cycles.max_bounces = 0
    set_world_color(scene)
    bpy.ops.mesh.primitive_plane_add(size=size)
    plane = bpy.context.object
    plane.data.materials.append(mat)
    add_ortho_camera(scene, size)
    return scene, plane


def _node(tree, kind, **props):
    node = tree.nodes.new(kind)
    for key, value in props.items():
        setattr(node, key, value)
    return node


def sock(sockets, identifier):
    """A socket by identifier, available or not (name look-ups skip unavailable sockets)."""
    return next(s for s in sockets if s.identifier == identifier)


def _link(tree, out, into):
    tree.links.new(out, into)


def uv_parts(tree):
    coords = _node(tree, "ShaderNodeTexCoord")
    sep = _node(tree, "ShaderNodeSeparateXYZ")
    _link(tree, coords.outputs["UV"], sep.inputs[0])
    return coords.outputs["UV"], sep.outputs["X"], sep.outputs["Y"]


def to_unit(tree, value, lo=-4.0, hi=4.0, vector=False):
    """A value mapped from [lo, hi] to [0, 1] by a clamped Map Range (colours stay in range)."""
    node = _node(tree, "ShaderNodeMapRange", data_type="FLOAT_VECTOR" if vector else "FLOAT",
                 clamp=True)
    if vector:
        ins = {s.identifier: s for s in node.inputs}
        _link(tree, value, ins["Vector"])
        ins["From_Min_FLOAT3"].default_value = (lo,) * 3
        ins["From_Max_FLOAT3"].default_value = (hi,) * 3
        return node.outputs["Vector"]
    _link(tree, value, node.inputs["Value"])
    node.inputs["From Min"].default_value = lo
    node.inputs["From Max"].default_value = hi
    return node.outputs["Result"]


def gradient(tree, u, v, hue=0.0):
    """A smooth colour over the plane: (u, v, 1 - u / 2) shifted by ``hue``."""
    comb = _node(tree, "ShaderNodeCombineXYZ")
    _link(tree, u, comb.inputs[0])
    _link(tree, v, comb.inputs[1])
    comb.inputs[2].default_value = 0.5 + hue
    return comb.outputs[0]


def diffuse_with(tree, value):
    bsdf = _node(tree, "ShaderNodeBsdfDiffuse")
    _link(tree, value, bsdf.inputs["Color"])
    _link(tree, bsdf.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    return bsdf


def compare_albedo(mat, mean=2e-3, worst=1e-2):
    scene, _ = plane_scene(mat)
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., :3]
    d = np.abs(ours - cycles)
    print(f"{mat.name}: mean |d| {d.mean():.2e}, max {d.max():.2e}, "
          f"range {cycles.min():.3f}..{cycles.max():.3f}")
    assert np.isfinite(ours).all()
    assert d.mean() <= mean and np.percentile(d, 99) <= worst, (d.mean(), d.max())
    return ours, cycles


MATH_OPS = ["ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM",
            "SQRT", "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN",
            "GREATER_THAN", "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "ROUND", "FLOOR",
            "CEIL", "TRUNC", "FRACT", "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG",
            "SINE", "COSINE", "TANGENT", "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH",
            "COSH", "TANH", "RADIANS", "DEGREES"]
# operations with steps inside the plane: the filtered edge pixels differ, the rest agree
STEPPED = {"LESS_THAN", "GREATER_THAN", "SIGN", "COMPARE", "ROUND", "FLOOR", "CEIL", "TRUNC",
           "FRACT", "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "TANGENT"}


@pytest.mark.parametrize("operation", MATH_OPS)
def test_math(addon, operation):
    mat, tree = bare_material(f"math {operation}")
    _, u, v = uv_parts(tree)
    a = _node(tree, "ShaderNodeMath", operation="MULTIPLY_ADD")  # a = 4u - 2 in [-2, 2]
    _link(tree, u, a.inputs[0])
    a.inputs[1].default_value, a.inputs[2].default_value = 4.0, -2.0
    b = _node(tree, "ShaderNodeMath", operation="MULTIPLY_ADD")  # b = 3v - 1.2
    _link(tree, v, b.inputs[0])
    b.inputs[1].default_value, b.inputs[2].default_value = 3.0, -1.2
    node = _node(tree, "ShaderNodeMath", operation=operation)
    _link(tree, a.outputs[0], node.inputs[0])
    _link(tree, b.outputs[0], node.inputs[1])
    node.inputs[2].default_value = 0.3
    comb = _node(tree, "ShaderNodeCombineColor")
    _link(tree, to_unit(tree, node.outputs[0]), comb.inputs[0])
    clamped = _node(tree, "ShaderNodeMath", operation=operation, use_clamp=True)
    _link(tree, a.outputs[0], clamped.inputs[0])
    _link(tree, b.outputs[0], clamped.inputs[1])
    clamped.inputs[2].default_value = 0.3
    _link(tree, clamped.outputs[0], comb.inputs[1])
    _link(tree, u, comb.inputs[2])
    diffuse_with(tree, comb.outputs[0])
    if operation in STEPPED:
        compare_albedo(mat, mean=0.03, worst=0.6)
    else:
        compare_albedo(mat)


VECTOR_OPS = ["ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "CROSS_PRODUCT",
              "PROJECT", "REFLECT", "REFRACT", "FACEFORWARD", "DOT_PRODUCT", "DISTANCE",
              "LENGTH", "SCALE", "NORMALIZE", "ABSOLUTE", "MINIMUM", "MAXIMUM", "SINE",
              "COSINE", "WRAP", "SNAP", "FLOOR", "CEIL", "MODULO", "FRACTION"]


@pytest.mark.parametrize("operation", VECTOR_OPS)
def test_vector_math(addon, operation):
    mat, tree = bare_material(f"vector math {operation}")
    uv, u, v = uv_parts(tree)
    scaled = _node(tree, "ShaderNodeVectorMath", operation="MULTIPLY_ADD")
    _link(tree, uv, scaled.inputs[0])
    scaled.inputs[1].default_value = (3.0, 2.5, 1.0)
    scaled.inputs[2].default_value = (-1.5, -1.0, 0.4)
    node = _node(tree, "ShaderNodeVectorMath", operation=operation)
    _link(tree, scaled.outputs[0], node.inputs[0])
    node.inputs[1].default_value = (0.7, -0.4, 0.9)
    node.inputs[2].default_value = (0.2, 0.5, -0.3)
    node.inputs[3].default_value = 0.8  # scale, or the IOR ratio of REFRACT
    value = operation in ("DOT_PRODUCT", "DISTANCE", "LENGTH")
    out = node.outputs["Value" if value else "Vector"]
    diffuse_with(tree, to_unit(tree, out, vector=not value))
    stepped = operation in ("WRAP", "SNAP", "FLOOR", "CEIL", "MODULO", "FRACTION")
    compare_albedo(mat, mean=0.03 if stepped else 2e-3, worst=0.6 if stepped else 1e-2)


BLENDS = ["MIX", "DARKEN", "MULTIPLY", "BURN", "LIGHTEN", "SCREEN", "DODGE", "ADD", "OVERLAY",
          "SOFT_LIGHT", "LINEAR_LIGHT", "DIFFERENCE", "EXCLUSION", "SUBTRACT", "DIVIDE", "HUE",
          "SATURATION", "COLOR", "VALUE"]


@pytest.mark.parametrize("blend", BLENDS)
@pytest.mark.parametrize("legacy", [False, True])
def test_mix_color(addon, blend, legacy):
    mat, tree = bare_material(f"mix {blend} {legacy}")
    _, u, v = uv_parts(tree)
    a = gradient(tree, u, v)
    inv = _node(tree, "ShaderNodeInvert")
    _link(tree, gradient(tree, v, u, 0.3), inv.inputs["Color"])
    inv.inputs["Fac"].default_value = 0.8
    if legacy:
        node = _node(tree, "ShaderNodeMixRGB", blend_type=blend, use_clamp=True)
        node.inputs["Fac"].default_value = 0.7
        _link(tree, a, node.inputs[1])
        _link(tree, inv.outputs[0], node.inputs[2])
        out = node.outputs[0]
    else:
        node = _node(tree, "ShaderNodeMix", data_type="RGBA", blend_type=blend,
                     clamp_result=blend in ("DODGE", "ADD"))
        ins = {s.identifier: s for s in node.inputs}
        _link(tree, u, ins["Factor_Float"])
        _link(tree, a, ins["A_Color"])
        _link(tree, inv.outputs[0], ins["B_Color"])
        out = sock(node.outputs, "Result_Color")
    diffuse_with(tree, out)
    compare_albedo(mat, mean=3e-3, worst=2e-2)


@pytest.mark.parametrize("data_type", ["FLOAT", "VECTOR", "VECTOR_NON_UNIFORM"])
def test_mix_float_and_vector(addon, data_type):
    mat, tree = bare_material(f"mix {data_type}")
    uv, u, v = uv_parts(tree)
    node = _node(tree, "ShaderNodeMix", data_type=data_type.removesuffix("_NON_UNIFORM"),
                 clamp_factor=True)
    if data_type.endswith("NON_UNIFORM"):
        node.factor_mode = "NON_UNIFORM"
    ins = {s.identifier: s for s in node.inputs}
    if data_type == "FLOAT":
        _link(tree, u, ins["Factor_Float"])
        _link(tree, v, ins["A_Float"])
        ins["B_Float"].default_value = 0.9
        out = sock(node.outputs, "Result_Float")
    else:
        _link(tree, uv, ins["Factor_Vector" if "NON" in data_type else "Factor_Float"]
              if "NON" in data_type else ins["Factor_Float"]) if "NON" in data_type else \
            _link(tree, v, ins["Factor_Float"])
        _link(tree, gradient(tree, u, v), ins["A_Vector"])
        ins["B_Vector"].default_value = (0.1, 0.9, 0.3)
        out = sock(node.outputs, "Result_Vector")
    diffuse_with(tree, out)
    compare_albedo(mat)


@pytest.mark.parametrize("mode", ["RGB", "HSV", "HSL"])
def test_separate_combine_color(addon, mode):
    mat, tree = bare_material(f"color {mode}")
    _, u, v = uv_parts(tree)
    sep = _node(tree, "ShaderNodeSeparateColor", mode=mode)
    _link(tree, gradient(tree, u, v, 0.2), sep.inputs[0])
    comb = _node(tree, "ShaderNodeCombineColor", mode=mode)
    _link(tree, sep.outputs[0], comb.inputs[1])  # the channels rotated
    _link(tree, sep.outputs[1], comb.inputs[2])
    _link(tree, sep.outputs[2], comb.inputs[0])
    diffuse_with(tree, comb.outputs[0])
    compare_albedo(mat, mean=3e-3, worst=3e-2)


def adjust_case(tree, kind, u, v):
    col = gradient(tree, u, v, 0.1)
    if kind == "invert":
        node = _node(tree, "ShaderNodeInvert")
        _link(tree, u, node.inputs["Fac"])
        _link(tree, col, node.inputs["Color"])
    elif kind == "gamma":
        node = _node(tree, "ShaderNodeGamma")
        _link(tree, col, node.inputs["Color"])
        node.inputs["Gamma"].default_value = 2.2
    elif kind == "bright_contrast":
        node = _node(tree, "ShaderNodeBrightContrast")
        _link(tree, col, node.inputs["Color"])
        node.inputs["Bright"].default_value = 0.1
        node.inputs["Contrast"].default_value = 0.4
    elif kind == "hue_saturation":
        node = _node(tree, "ShaderNodeHueSaturation")
        _link(tree, col, node.inputs["Color"])
        node.inputs["Hue"].default_value = 0.3
        node.inputs["Saturation"].default_value = 1.4
        node.inputs["Value"].default_value = 0.9
        _link(tree, v, node.inputs["Fac"])
    elif kind == "hue_saturation_linked":  # constant colour, textured saturation
        node = _node(tree, "ShaderNodeHueSaturation")
        node.inputs["Color"].default_value = (0.8, 0.3, 0.2, 1.0)
        _link(tree, u, node.inputs["Saturation"])
    elif kind == "rgb_to_bw":
        node = _node(tree, "ShaderNodeRGBToBW")
        _link(tree, col, node.inputs["Color"])
    elif kind.startswith("ramp"):
        node = _node(tree, "ShaderNodeValToRGB")
        ramp = node.color_ramp
        ramp.interpolation = kind[5:].upper()
        ramp.elements[0].color = (0.9, 0.2, 0.1, 1.0)
        ramp.elements[1].position = 0.8
        mid = ramp.elements.new(0.35)
        mid.color = (0.1, 0.6, 0.9, 1.0)
        _link(tree, u, node.inputs["Fac"])
    elif kind == "curves":
        node = _node(tree, "ShaderNodeRGBCurve")
        node.mapping.curves[3].points.new(0.4, 0.7)
        node.mapping.curves[0].points.new(0.5, 0.2)
        node.mapping.update()
        _link(tree, col, node.inputs["Color"])
    elif kind == "clamp":
        node = _node(tree, "ShaderNodeClamp", clamp_type="RANGE")
        _link(tree, u, node.inputs["Value"])
        node.inputs["Min"].default_value, node.inputs["Max"].default_value = 0.7, 0.2
    elif kind.startswith("map_range"):
        node = _node(tree, "ShaderNodeMapRange", interpolation_type=kind[10:].upper(),
                     clamp=False)
        _link(tree, u, node.inputs["Value"])
        node.inputs["From Min"].default_value = 0.8
        node.inputs["From Max"].default_value = 0.1
        node.inputs["To Min"].default_value = 0.1
        node.inputs["To Max"].default_value = 0.9
        sock(node.inputs, "Steps").default_value = 3.0
        return node.outputs["Result"]
    return node.outputs[0]


ADJUSTMENTS = ["invert", "gamma", "bright_contrast", "hue_saturation",
               "hue_saturation_linked", "rgb_to_bw",
               "ramp_linear", "ramp_constant", "ramp_ease", "ramp_b_spline", "ramp_cardinal",
               "curves", "clamp", "map_range_linear", "map_range_stepped",
               "map_range_smoothstep", "map_range_smootherstep"]


@pytest.mark.parametrize("kind", ADJUSTMENTS)
def test_colour_adjustments(addon, kind):
    mat, tree = bare_material(kind)
    _, u, v = uv_parts(tree)
    diffuse_with(tree, adjust_case(tree, kind, u, v))
    hard = kind in ("ramp_constant", "map_range_stepped")
    compare_albedo(mat, mean=0.02 if hard else 3e-3, worst=0.5 if hard else 2e-2)


@pytest.mark.parametrize("output", ["UV", "Generated", "Object", "Normal", "Window",
                                    "Reflection", "Camera"])
@pytest.mark.parametrize("mapping", [None, "POINT", "TEXTURE", "VECTOR", "NORMAL"])
def test_coordinates_and_mapping(addon, output, mapping):
    mat, tree = bare_material(f"coords {output} {mapping}")
    coords = _node(tree, "ShaderNodeTexCoord")
    out = coords.outputs[output]
    if mapping is not None:
        node = _node(tree, "ShaderNodeMapping", vector_type=mapping)
        _link(tree, out, node.inputs["Vector"])
        sock(node.inputs, "Location").default_value = (0.2, -0.1, 0.3)
        node.inputs["Rotation"].default_value = (0.3, -0.2, 0.5)
        sock(node.inputs, "Scale").default_value = (1.5, 0.7, 1.2)
        out = node.outputs[0]
    diffuse_with(tree, to_unit(tree, out, -2.0, 2.0, vector=True))
    scene, plane = plane_scene(mat)
    plane.rotation_euler = (0.0, 0.0, 0.4)
    plane.scale = (1.3, 1.0, 1.0)
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., :3]
    covered = cycles.max(-1) > 0  # the rotated plane leaves corners empty
    d = np.abs(ours - cycles)[covered]
    print(f"{output} {mapping}: mean |d| {d.mean():.2e}, max {d.max():.2e}")
    # pixels along the plane's edge are part plane, part background in both
    assert d.mean() < 4e-3 and np.percentile(d, 95) < 2e-2


def image_material(name, interpolation="Linear", extension="REPEAT", colorspace="sRGB",
                   alpha=False):
    rng = np.random.default_rng(3)
    px = np.concatenate([rng.random((8, 8, 3)), np.ones((8, 8, 1))], -1).astype(np.float32)
    if alpha:
        px[..., 3] = rng.random((8, 8))
    image = bpy.data.images.new(f"img {name}", 8, 8, alpha=True, float_buffer=False)
    image.colorspace_settings.name = colorspace  # before the pixels: it regenerates the image
    image.pixels.foreach_set(px.ravel())
    assert abs(image.pixels[0] - px[0, 0, 0]) < 1e-2
    mat, tree = bare_material(name)
    uv, u, v = uv_parts(tree)
    scale = _node(tree, "ShaderNodeMapping", vector_type="POINT")
    _link(tree, uv, scale.inputs["Vector"])
    scale.inputs["Scale"].default_value = (1.7, 1.3, 1.0)
    scale.inputs["Location"].default_value = (-0.3, -0.2, 0.0)
    tex = _node(tree, "ShaderNodeTexImage", interpolation=interpolation, extension=extension)
    tex.image = image
    _link(tree, scale.outputs[0], tex.inputs["Vector"])
    return mat, tree, tex


@pytest.mark.parametrize("extension", ["REPEAT", "EXTEND", "CLIP", "MIRROR"])
@pytest.mark.parametrize("interpolation", ["Linear", "Closest", "Cubic"])
@pytest.mark.parametrize("colorspace", ["sRGB", "Non-Color"])
def test_image_texture(addon, extension, interpolation, colorspace):
    mat, tree, tex = image_material(f"tex {extension} {interpolation} {colorspace}",
                                    interpolation, extension, colorspace)
    diffuse_with(tree, tex.outputs["Color"])
    # closest: a pixel centre on a texel edge may round to either texel
    compare_albedo(mat, mean=1e-3, worst=0.02)


@pytest.mark.parametrize("interpolation", ["Linear", "Closest"])
@pytest.mark.parametrize("colorspace", ["sRGB", "Non-Color"])
@pytest.mark.parametrize("extension", ["REPEAT", "CLIP"])
def test_image_with_alpha_premultiplied(addon, interpolation, colorspace, extension):
    """An image with alpha whose Alpha output is not used: Cycles' Color is colour times alpha,
    filtered so (a Non-Color image's is not associated)."""
    mat, tree, tex = image_material(f"premultiplied {interpolation} {colorspace} {extension}",
                                    interpolation, extension, colorspace, alpha=True)
    diffuse_with(tree, tex.outputs["Color"])
    compare_albedo(mat, mean=0.01, worst=0.05)


@pytest.mark.parametrize("interpolation", ["Linear", "Closest"])
@pytest.mark.parametrize("colorspace", ["sRGB", "Non-Color"])
def test_image_alpha_and_channels(addon, interpolation, colorspace):
    """An image with alpha: its Alpha output, and its Color output then divided by the
    filtered alpha again (before the sRGB decoding, as Cycles)."""
    mat, tree, tex = image_material(f"alpha {interpolation} {colorspace}", interpolation,
                                    colorspace=colorspace, alpha=True)
    sep = _node(tree, "ShaderNodeSeparateColor")
    _link(tree, tex.outputs["Color"], sep.inputs[0])
    comb = _node(tree, "ShaderNodeCombineColor")
    _link(tree, tex.outputs["Alpha"], comb.inputs[0])
    _link(tree, sep.outputs["Green"], comb.inputs[1])
    _link(tree, sep.outputs["Red"], comb.inputs[2])
    diffuse_with(tree, comb.outputs[0])
    # Cycles keeps colour times alpha in 8 bits before it divides by alpha again: about 1%
    compare_albedo(mat, mean=0.01, worst=0.05)


def test_groups_reroutes_and_muted_nodes(addon):
    mat, tree = bare_material("groups")
    inner = bpy.data.node_groups.new("Inner", "ShaderNodeTree")
    inner.interface.new_socket("Value", in_out="INPUT", socket_type="NodeSocketFloat")
    inner.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    gi, go = inner.nodes.new("NodeGroupInput"), inner.nodes.new("NodeGroupOutput")
    ramp = inner.nodes.new("ShaderNodeValToRGB")
    inner.links.new(gi.outputs[0], ramp.inputs[0])
    inner.links.new(ramp.outputs[0], go.inputs[0])
    outer = bpy.data.node_groups.new("Outer", "ShaderNodeTree")
    outer.interface.new_socket("U", in_out="INPUT", socket_type="NodeSocketFloat")
    outer.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
    gi2, go2 = outer.nodes.new("NodeGroupInput"), outer.nodes.new("NodeGroupOutput")
    nested = outer.nodes.new("ShaderNodeGroup")
    nested.node_tree = inner
    muted = outer.nodes.new("ShaderNodeInvert")
    muted.mute = True  # passes its Color through
    reroute = outer.nodes.new("NodeReroute")
    outer.links.new(gi2.outputs[0], reroute.inputs[0])
    outer.links.new(reroute.outputs[0], nested.inputs[0])
    outer.links.new(nested.outputs[0], muted.inputs["Color"])
    outer.links.new(muted.outputs[0], go2.inputs[0])
    _, u, v = uv_parts(tree)
    group = _node(tree, "ShaderNodeGroup")
    group.node_tree = outer
    _link(tree, u, group.inputs[0])
    _node(tree, "NodeFrame")
    diffuse_with(tree, group.outputs[0])
    compare_albedo(mat)


def test_vertex_colours_by_name(addon):
    mat, tree = bare_material("vertex colours")
    attr = _node(tree, "ShaderNodeAttribute", attribute_name="Paint")
    vcol = _node(tree, "ShaderNodeVertexColor", layer_name="")  # the active render one
    mix = _node(tree, "ShaderNodeMix", data_type="RGBA", blend_type="MULTIPLY")
    ins = {s.identifier: s for s in mix.inputs}
    ins["Factor_Float"].default_value = 1.0
    _link(tree, attr.outputs["Color"], ins["A_Color"])
    _link(tree, vcol.outputs["Color"], ins["B_Color"])
    comb = _node(tree, "ShaderNodeCombineColor")
    _link(tree, sock(mix.outputs, "Result_Color"), comb.inputs[0])
    _link(tree, attr.outputs["Fac"], comb.inputs[1])
    _link(tree, vcol.outputs["Alpha"], comb.inputs[2])
    scene, plane = plane_scene(mat)
    bpy.ops.object.mode_set(mode="OBJECT")
    mesh = plane.data
    bpy.ops.object.select_all(action="DESELECT")
    rng = np.random.default_rng(1)
    for name, domain in (("Render", "CORNER"), ("Paint", "POINT")):
        layer = mesh.color_attributes.new(name, "FLOAT_COLOR", domain)
        layer.data.foreach_set("color", rng.random(len(layer.data) * 4).astype(np.float32))
    mesh.color_attributes.render_color_index = mesh.color_attributes.find("Render")
    diffuse_with(tree, sock(mix.outputs, "Result_Color") if False else comb.outputs[0])
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., :3]
    d = np.abs(ours - cycles)
    assert cycles.std() > 0.05
    assert d.mean() < 2e-3 and np.percentile(d, 99) < 1e-2, (d.mean(), d.max())


@pytest.mark.parametrize("mix", [0.0, 0.35, 1.0])
def test_shader_mix_and_add(addon, mix):
    """Diffuse and Glossy mixed per point by u, plus an emission: DiffCol, GlossCol, Emit."""
    mat, tree = bare_material(f"shaders {mix}")
    _, u, v = uv_parts(tree)
    diffuse = _node(tree, "ShaderNodeBsdfDiffuse")
    _link(tree, gradient(tree, u, v), diffuse.inputs["Color"])
    glossy = _node(tree, "ShaderNodeBsdfGlossy")
    glossy.inputs["Color"].default_value = (0.9, 0.6, 0.2, 1.0)
    glossy.inputs["Roughness"].default_value = 0.3
    fac = _node(tree, "ShaderNodeMath", operation="MULTIPLY")
    _link(tree, u, fac.inputs[0])
    fac.inputs[1].default_value = mix
    shader = _node(tree, "ShaderNodeMixShader")
    _link(tree, fac.outputs[0], shader.inputs[0])
    _link(tree, diffuse.outputs[0], shader.inputs[1])
    _link(tree, glossy.outputs[0], shader.inputs[2])
    emit = _node(tree, "ShaderNodeEmission")
    _link(tree, gradient(tree, v, u), emit.inputs["Color"])
    emit.inputs["Strength"].default_value = 0.5
    add = _node(tree, "ShaderNodeAddShader")
    _link(tree, shader.outputs[0], add.inputs[0])
    _link(tree, emit.outputs[0], add.inputs[1])
    _link(tree, add.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat)
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo", "Specular Color", "Emit"])
    cycles = render_passes(scene, "CYCLES", ["DiffCol", "GlossCol", "Emit"])
    for a, b in (("Albedo", "DiffCol"), ("Specular Color", "GlossCol"), ("Emit", "Emit")):
        d = np.abs(ours[a][..., :3] - cycles[b][..., :3])
        assert d.mean() < 2e-3 and d.max() < 2e-2, (a, d.mean(), d.max())


@pytest.mark.parametrize("object_scale", [(1.0, 1.0, 1.0), (-1.0, 1.0, 1.0), (0.2, 0.2, 0.2)])
def test_normal_map_and_bump_normals(addon, object_scale):
    """The Normal pass of a tangent-space normal map (Blender's MikkTSpace tangents) and a bump
    from a texture chain, on a plain, a mirrored (its bitangents turn) and a scaled object."""
    mat, tree, tex = image_material("normals", colorspace="Non-Color")
    tex.interpolation = "Linear"
    nmap = _node(tree, "ShaderNodeNormalMap", space="TANGENT", uv_map="UVMap")
    _link(tree, tex.outputs["Color"], nmap.inputs["Color"])
    nmap.inputs["Strength"].default_value = 0.6
    _, u, v = uv_parts(tree)
    height = _node(tree, "ShaderNodeMath", operation="SINE")
    scale = _node(tree, "ShaderNodeMath", operation="MULTIPLY")
    _link(tree, u, scale.inputs[0])
    scale.inputs[1].default_value = 9.0
    _link(tree, scale.outputs[0], height.inputs[0])
    bump = _node(tree, "ShaderNodeBump")
    bump.inputs["Distance"].default_value = 0.05
    _link(tree, height.outputs[0], bump.inputs["Height"])
    _link(tree, nmap.outputs[0], bump.inputs["Normal"])
    diffuse = diffuse_with(tree, gradient(tree, u, v))
    _link(tree, bump.outputs[0], diffuse.inputs["Normal"])
    scene, plane = plane_scene(mat)
    plane.rotation_euler = (0.2, 0.0, 0.7)
    plane.scale = object_scale
    scene.camera.data.ortho_scale = 2.0 * abs(object_scale[0])
    ours = render_passes(scene, "BO2_LIGHTING", ["Normal"])["Normal"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["Normal"])["Normal"][..., :3]
    covered = np.linalg.norm(cycles, axis=-1) > 0.5
    angle = np.degrees(np.arccos(np.clip(np.sum(ours * cycles, -1)[covered], -1, 1)))
    flat = np.degrees(np.arccos(np.clip(cycles[covered][:, 2], -1, 1)))
    print(f"normals: mean {angle.mean():.2f} deg, p95 {np.percentile(angle, 95):.2f} deg; "
          f"the map tilts them by {flat.mean():.1f} deg on average")
    assert flat.mean() > 5.0
    assert angle.mean() < 1.5 and np.percentile(angle, 95) < 4.0


def test_fresnel_and_layer_weight(addon):
    """View-dependent inputs on a sphere seen in perspective."""
    mat, tree = bare_material("facing")
    fres = _node(tree, "ShaderNodeFresnel")
    fres.inputs["IOR"].default_value = 1.8
    layer = _node(tree, "ShaderNodeLayerWeight")
    layer.inputs["Blend"].default_value = 0.3
    comb = _node(tree, "ShaderNodeCombineColor")
    _link(tree, fres.outputs[0], comb.inputs[0])
    _link(tree, layer.outputs["Fresnel"], comb.inputs[1])
    _link(tree, layer.outputs["Facing"], comb.inputs[2])
    diffuse_with(tree, comb.outputs[0])
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = 48
    scene.render.resolution_percentage = 100
    scene.render.filter_size = scene.cycles.filter_width = 0.01
    set_world_color(scene)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0)
    bpy.ops.object.shade_smooth()
    bpy.context.object.data.materials.append(mat)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.location = (0.0, -4.0, 0.0)
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., :3]
    d = np.abs(ours - cycles)[cycles.max(-1) > 0]
    print(f"facing: mean |d| {d.mean():.2e}, p99 {np.percentile(d, 99):.2e}")
    assert cycles.max() > 0.4  # grazing angles reached
    assert d.mean() < 2e-3 and np.percentile(d, 99) < 1e-2


def emitter(name, color, alpha_from_u=None):
    """An emission material; with ``alpha_from_u`` its coverage is u (through a Transparent
    BSDF mix, "mix") or the Principled BSDF's Alpha ("principled") or an image's alpha."""
    mat, tree = bare_material(name)
    emit = _node(tree, "ShaderNodeEmission")
    emit.inputs["Color"].default_value = (*color, 1.0)
    out = emit.outputs[0]
    if alpha_from_u == "mix":
        _, u, v = uv_parts(tree)
        mix = _node(tree, "ShaderNodeMixShader")
        _link(tree, u, mix.inputs[0])
        _link(tree, _node(tree, "ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
        _link(tree, out, mix.inputs[2])
        out = mix.outputs[0]
    elif alpha_from_u == "principled":
        _, u, v = uv_parts(tree)
        p = _node(tree, "ShaderNodeBsdfPrincipled")
        p.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        p.inputs["Specular IOR Level"].default_value = 0.0
        p.inputs["Emission Color"].default_value = (*color, 1.0)
        p.inputs["Emission Strength"].default_value = 1.0
        _link(tree, v, p.inputs["Alpha"])
        out = p.outputs[0]
    _link(tree, out, tree.nodes["Material Output"].inputs["Surface"])
    return mat


@pytest.mark.parametrize("how", ["mix", "principled"])
def test_dithered_transparency_matches_cycles(addon, how):
    """A half-transparent emitter over another: over the samples each pixel shows a fraction
    alpha of the top surface, as Cycles' transparency does."""
    top = emitter("top", (0.9, 0.8, 0.1), how)
    scene, plane = plane_scene(top)
    plane.location.z = 0.2
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    bpy.context.object.data.materials.append(emitter("bottom", (0.1, 0.2, 0.9)))
    scene.render.filter_size = scene.cycles.filter_width = 1.5
    scene.cycles.transparent_max_bounces = 8
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=64)["Combined"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=256)["Combined"][..., :3]
    # the image's rows and columns: alpha runs from 0 to 1 across the frame
    axis = 1 if how == "mix" else 0
    ours_line, cycles_line = ours.mean(axis=1 - axis), cycles.mean(axis=1 - axis)
    d = np.abs(ours_line - cycles_line)
    print(f"{how}: line mean |d| {d.mean():.4f}, max {d.max():.4f}; per pixel "
          f"{np.abs(ours - cycles).mean():.4f}")
    assert np.ptp(cycles_line[:, 2]) > 0.5  # the coverage really varies
    assert d.mean() < 0.01 and d.max() < 0.03
    assert np.abs(ours - cycles).mean() < 0.04  # 64 samples: the pixels' own noise


def test_transparent_film_keeps_the_coverage(addon):
    """Film > Transparent: where a surface of alpha u covers the background, the pixel's alpha
    is u, as in Cycles."""
    scene, _ = plane_scene(emitter("film", (0.9, 0.8, 0.1), "mix"))
    scene.render.film_transparent = True
    scene.render.filter_size = scene.cycles.filter_width = 1.5
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=64)["Combined"][..., 3]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=256)["Combined"][..., 3]
    d = np.abs(ours.mean(axis=0) - cycles.mean(axis=0))
    print(f"film alpha: columns {np.round(ours.mean(axis=0)[::4], 2)} vs "
          f"{np.round(cycles.mean(axis=0)[::4], 2)}")
    assert np.ptp(cycles.mean(axis=0)) > 0.8
    assert d.mean() < 0.01 and d.max() < 0.04


def test_shadows_honour_alpha(addon):
    """A sun shines through a plane whose alpha runs from 0 to 1 across it onto a white floor:
    its shadow darkens across the floor as Cycles' does."""
    top = emitter("cut-out", (0.0, 0.0, 0.0), "principled")
    scene, plane = plane_scene(top)
    plane.location.z = 1.5  # above the camera: it casts its shadow, the camera does not see it
    plane.scale = (3.0, 3.0, 1.0)
    floor, tree = bare_material("floor")
    rgb = _node(tree, "ShaderNodeRGB")
    rgb.outputs[0].default_value = (0.8, 0.8, 0.8, 1.0)
    diffuse_with(tree, rgb.outputs[0])
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    bpy.context.object.data.materials.append(floor)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy = 3.0
    sun.data.angle = 0.0
    scene.collection.objects.link(sun)
    scene.cycles.transparent_max_bounces = 8
    scene.render.filter_size = scene.cycles.filter_width = 1.5  # samples spread over the pixel
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=64)["Combined"][..., 0]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=64)["Combined"][..., 0]
    ours_line, cycles_line = ours.mean(axis=1), cycles.mean(axis=1)  # alpha follows v: rows
    d = np.abs(ours_line - cycles_line)
    # the trend over bands of 4 rows: one row's mean still holds the noise of the dithered
    # caster under the filter's turned discs (about +-0.04 from one seeding to another)
    n = len(d) // 4 * 4
    bands = np.abs(ours_line[:n].reshape(-1, 4).mean(1) - cycles_line[:n].reshape(-1, 4).mean(1))
    print(f"shadow: rows {np.round(ours_line[::4], 3)} vs {np.round(cycles_line[::4], 3)}; "
          f"mean |d| {d.mean():.4f}, max {d.max():.4f}, over 4-row bands {bands.max():.4f}")
    assert np.ptp(cycles_line) > 0.2  # the shadow's darkness varies with alpha
    assert d.mean() < 0.02 and bands.max() < 0.03


def test_bad_node_trees_warn_once_and_render_finite(addon):
    """A group without its tree, a missing attribute, an image that cannot load and NaN-making
    math: one warning each, finite pixels, the values Cycles renders."""
    from bo2_lighting.addon.blender import extract

    mat, tree = bare_material("bad")
    _, u, v = uv_parts(tree)
    group = _node(tree, "ShaderNodeGroup")
    group.node_tree = bpy.data.node_groups.new("Empty", "ShaderNodeTree")
    group.node_tree.interface.new_socket("Out", in_out="OUTPUT", socket_type="NodeSocketFloat")
    attr = _node(tree, "ShaderNodeAttribute", attribute_name="no such attribute")
    tex = _node(tree, "ShaderNodeTexImage")
    tex.image = bpy.data.images.new("gone", 4, 4)
    tex.image.source = "FILE"
    tex.image.filepath = "//missing/gone.png"
    div = _node(tree, "ShaderNodeMath", operation="DIVIDE")  # u / 0 -> 0 in Cycles
    _link(tree, u, div.inputs[0])
    div.inputs[1].default_value = 0.0
    log = _node(tree, "ShaderNodeMath", operation="LOGARITHM")  # log of a negative -> 0
    log.inputs[0].default_value = -2.0
    _link(tree, v, log.inputs[1])
    comb = _node(tree, "ShaderNodeCombineColor")
    add = _node(tree, "ShaderNodeMath", operation="ADD")
    _link(tree, group.outputs[0], add.inputs[0])
    add.inputs[1].default_value = 0.25
    _link(tree, add.outputs[0], comb.inputs[0])
    add2 = _node(tree, "ShaderNodeMath", operation="ADD")
    _link(tree, div.outputs[0], add2.inputs[0])
    _link(tree, log.outputs[0], add2.inputs[1])
    _link(tree, add2.outputs[0], comb.inputs[1])
    _link(tree, attr.outputs["Fac"], comb.inputs[2])
    mix = _node(tree, "ShaderNodeMix", data_type="RGBA", blend_type="MIX")
    ins = {s.identifier: s for s in mix.inputs}
    ins["Factor_Float"].default_value = 0.25  # a quarter of the missing image's magenta
    _link(tree, comb.outputs[0], ins["A_Color"])
    _link(tree, tex.outputs["Color"], ins["B_Color"])
    diffuse_with(tree, sock(mix.outputs, "Result_Color"))
    scene, _ = plane_scene(mat)
    _, warnings = extract.extract_scene(bpy.context.evaluated_depsgraph_get())
    text = "\n".join(warnings)
    assert text.count("'Empty', which is missing or empty") == 1
    assert text.count("'no such attribute'") == 1
    assert text.count("could not be loaded") == 1
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., :3]
    assert np.isfinite(ours).all()
    print("bad:", ours.mean((0, 1)), cycles.mean((0, 1)))
    assert cycles.max() > 0.2
    assert np.abs(ours - cycles).mean() < 2e-3


def test_a_node_loop_renders_as_in_cycles(addon):
    from bo2_lighting.addon.blender import extract

    mat, tree = bare_material("loop")
    a = _node(tree, "ShaderNodeMath", operation="ADD")
    b = _node(tree, "ShaderNodeMath", operation="MULTIPLY")
    _link(tree, a.outputs[0], b.inputs[0])
    _link(tree, b.outputs[0], a.inputs[0])
    comb = _node(tree, "ShaderNodeCombineColor")
    comb.inputs[0].default_value = 0.7
    _link(tree, b.outputs[0], comb.inputs[1])
    diffuse_with(tree, comb.outputs[0])
    scene, _ = plane_scene(mat)
    _, warnings = extract.extract_scene(bpy.context.evaluated_depsgraph_get())
    assert sum("has a loop" in w for w in warnings) == 1
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo", "Combined"])
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., :3]
    # Blender 5 renders a material with a loop black; 4.5 drops the loop's invalid link
    assert (cycles.max() == 0.0) == (bpy.app.version >= (5, 0, 0))
    assert np.abs(ours["Albedo"][..., :3] - cycles).max() < 1e-4
    assert np.isfinite(ours["Combined"]).all()


def test_gltf_occlusion_dims_indirect_light(addon):
    """The glTF importer's "glTF Material Output" group: its Occlusion scales the indirect
    light (Cycles ignores it; glTF defines it so)."""
    from bo2_lighting.addon.blender import extract

    results = {}
    for occlusion in (None, 0.25):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        mat, tree = bare_material("occluded")
        diffuse_with(tree, _node(tree, "ShaderNodeRGB").outputs[0])
        if occlusion is not None:
            group = bpy.data.node_groups.new("glTF Material Output", "ShaderNodeTree")
            group.interface.new_socket("Occlusion", in_out="INPUT",
                                       socket_type="NodeSocketFloat")
            node = _node(tree, "ShaderNodeGroup")
            node.node_tree = group
            value = _node(tree, "ShaderNodeValue")
            value.outputs[0].default_value = occlusion
            _link(tree, value.outputs[0], node.inputs["Occlusion"])
        scene, _ = plane_scene(mat)
        sky = bpy.data.worlds.new("Sky")
        sky.color = (0.5, 0.5, 0.5)
        if bpy.app.version < (5, 0, 0):
            sky.use_nodes = True
        sky.node_tree.nodes["Background"].inputs["Color"].default_value = (
            0.5, 0.5, 0.5, 1.0)
        scene.world = sky
        scene.bo2.indirect.use = True
        scene.bo2.indirect.use_implicit_bounce = False  # its captures would see the occlusion too
        frame, _ = extract.extract_scene(bpy.context.evaluated_depsgraph_get())
        assert (frame.materials[-1].program.occlusion is None) == (occlusion is None)
        results[occlusion] = render_passes(scene, "BO2_LIGHTING", ["DiffInd"])["DiffInd"]
    lit, dimmed = results[None][..., :3].mean(), results[0.25][..., :3].mean()
    assert lit > 0.05
    assert dimmed == pytest.approx(0.25 * lit, rel=1e-3)


def test_images_are_prepared_once_per_session(addon, monkeypatch):
    """Three image nodes of one image, two materials, two frames and a second render: the image
    becomes a texture once, and again only after it changes."""
    from bo2_lighting.addon.core.formulas import texture

    calls = []
    real = texture.make_texture
    monkeypatch.setattr(texture, "make_texture",
                        lambda *a, **k: calls.append(k.get("name")) or real(*a, **k))
    mat, tree, tex = image_material("shared image")
    for _ in range(2):
        other = _node(tree, "ShaderNodeTexImage")
        other.image = tex.image
        mix = _node(tree, "ShaderNodeMix", data_type="RGBA")
        _link(tree, tex.outputs["Color"], sock(mix.inputs, "A_Color"))
        _link(tree, other.outputs["Color"], sock(mix.inputs, "B_Color"))
        tex = other
    diffuse_with(tree, sock(mix.outputs, "Result_Color"))
    scene, _ = plane_scene(mat)
    second, tree2, _ = image_material("second material")
    tree2.nodes["Image Texture"].image = tex.image
    diffuse_with(tree2, tree2.nodes["Image Texture"].outputs["Color"])
    bpy.ops.mesh.primitive_plane_add(size=0.5, location=(0.0, 0.0, 0.1))
    bpy.context.object.data.materials.append(second)
    for frame in (1, 2):
        scene.frame_set(frame)
        render_passes(scene, "BO2_LIGHTING", ["Albedo"], samples=1)
    assert calls == [tex.image.name]
    tex.image.pixels[0] = 0.5  # an edit: the texture is made again
    render_passes(scene, "BO2_LIGHTING", ["Albedo"], samples=1)
    assert calls == [tex.image.name] * 2


def test_attributes_of_every_domain_and_type(addon):
    """Attribute nodes reading a float per face, an integer per point and a vector per corner
    of a grid, as Cycles reads them (Fac: the average of the components)."""
    mat, tree = bare_material("attributes")
    comb = _node(tree, "ShaderNodeCombineColor")
    for k, (name, out) in enumerate((("f", "Fac"), ("i", "Fac"), ("v", "Color"))):
        attr = _node(tree, "ShaderNodeAttribute", attribute_name=name)
        value = attr.outputs[out]
        if name == "i":
            scaled = _node(tree, "ShaderNodeMath", operation="MULTIPLY")
            _link(tree, value, scaled.inputs[0])
            scaled.inputs[1].default_value = 0.25
            value = scaled.outputs[0]
        _link(tree, value, comb.inputs[k])
    diffuse_with(tree, comb.outputs[0])
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = RES
    scene.render.filter_size = scene.cycles.filter_width = 0.01
    scene.cycles.max_bounces = 0
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=5, y_subdivisions=5, size=2.0)
    grid = bpy.context.object
    grid.data.materials.append(mat)
    add_ortho_camera(scene, 2.0)
    mesh = grid.data
    rng = np.random.default_rng(5)
    f = mesh.attributes.new("f", "FLOAT", "FACE")
    f.data.foreach_set("value", rng.random(len(f.data)).astype(np.float32))
    i = mesh.attributes.new("i", "INT", "POINT")
    i.data.foreach_set("value", rng.integers(0, 4, len(i.data)).astype(np.int32))
    v = mesh.attributes.new("v", "FLOAT_VECTOR", "CORNER")
    v.data.foreach_set("vector", rng.random(len(v.data) * 3).astype(np.float32))
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"])["Albedo"][..., :3]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"])["DiffCol"][..., :3]
    d = np.abs(ours - cycles)
    print(f"attributes: mean |d| {d.mean():.2e}, max {d.max():.2e}")
    assert cycles.std() > 0.1
    assert d.mean() < 2e-3 and np.percentile(d, 99) < 2e-2


def test_unsupported_node_feeding_two_sockets(addon):
    """An unsupported node feeding two sockets: each keeps its own value (as Cycles renders a
    node it cannot read... here, the values the sockets hold)."""
    from bo2_lighting.addon.blender import extract

    mat, tree = bare_material("two sockets")
    p = _node(tree, "ShaderNodeBsdfPrincipled")
    p.inputs["Metallic"].default_value = 0.0
    p.inputs["Roughness"].default_value = 0.5
    wave = _node(tree, "ShaderNodeTexWave")
    _link(tree, wave.outputs["Fac"], p.inputs["Metallic"])
    _link(tree, wave.outputs["Fac"], p.inputs["Roughness"])
    _link(tree, p.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    plane_scene(mat)
    scene, warnings = extract.extract_scene(bpy.context.evaluated_depsgraph_get())
    program = scene.materials[-1].program
    principled = next(op for op in program.ops if op.kind == "principled")
    metallic, roughness = (program.ops[principled.args[k]] for k in (1, 2))
    assert metallic.param == (0.0,) and roughness.param == (0.5,)
    assert sum("ShaderNodeTexWave" in w for w in warnings) == 2


def test_holdout_material_cuts_a_hole(addon):
    """A material whose surface is a Holdout node: alpha 0 and no colour where it is seen, as
    in Cycles."""
    mat, tree = bare_material("holdout")
    _link(tree, _node(tree, "ShaderNodeHoldout").outputs[0],
          tree.nodes["Material Output"].inputs["Surface"])
    scene, plane = plane_scene(emitter("behind", (0.2, 0.9, 0.3)))
    plane.location.z = -0.2
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    bpy.context.object.data.materials.append(mat)
    scene.render.film_transparent = True
    ours = render_passes(scene, "BO2_LIGHTING", ["Combined"], samples=4)["Combined"]
    cycles = render_passes(scene, "CYCLES", ["Combined"], samples=4)["Combined"]
    d = np.abs(ours - cycles)
    assert cycles[12, 12, 3] == pytest.approx(0.0, abs=1e-6)
    assert ours[12, 12, 3] == pytest.approx(0.0, abs=1e-6)
    assert d.mean() < 2e-3


def test_constant_ramp_steps_where_cycles_steps(addon):
    """A Constant Color Ramp over 1024 pixels: every pixel on the side Cycles puts it (its
    table has 257 entries at i / 256)."""
    mat, tree = bare_material("ramp steps")
    _, u, v = uv_parts(tree)
    node = _node(tree, "ShaderNodeValToRGB")
    ramp = node.color_ramp
    ramp.interpolation = "CONSTANT"
    ramp.elements[0].color = (0.0, 0.0, 0.0, 1.0)
    ramp.elements[1].position = 0.3
    ramp.elements.new(0.6).color = (0.5, 0.5, 0.5, 1.0)
    _link(tree, u, node.inputs["Fac"])
    diffuse_with(tree, node.outputs[0])
    scene, _ = plane_scene(mat)
    scene.render.resolution_x, scene.render.resolution_y = 1024, 2
    ours = render_passes(scene, "BO2_LIGHTING", ["Albedo"], samples=1)["Albedo"][1, :, 0]
    cycles = render_passes(scene, "CYCLES", ["DiffCol"], samples=1)["DiffCol"][1, :, 0]
    assert np.abs(ours - cycles).max() < 1e-4


def chain_group(name, kind, operation, length, value, socket_type):
    """A node group of ``length`` nodes ``kind`` chained from its input to its output, each
    with ``value`` on its second input. (Blender adds nodes to one tree in quadratic time or
    worse: deep graphs are built from groups.)"""
    group = bpy.data.node_groups.new(name, "ShaderNodeTree")
    group.interface.new_socket("In", in_out="INPUT", socket_type=socket_type)
    group.interface.new_socket("Out", in_out="OUTPUT", socket_type=socket_type)
    out = _node(group, "NodeGroupInput").outputs[0]
    for _ in range(length):
        node = _node(group, kind, operation=operation)
        node.inputs[1].default_value = value
        _link(group, out, node.inputs[0])
        out = node.outputs[0]
    _link(group, out, _node(group, "NodeGroupOutput").inputs[0])
    return group


def test_node_chains_deeper_than_pythons_recursion_limit(addon):
    """Generated assets bring deep graphs: 3000 Math nodes (adding 0.0002 each to 0) times an
    image read through 3000 Vector Math nodes (adding 0 to the UV, so its filter steps pass
    through them all), as 30 groups of 100: compiled and evaluated without recursion, against
    Cycles."""
    import sys

    from bo2_lighting.addon.blender.materials import convert_material
    from bo2_lighting.addon.core.render.job import Warnings

    groups, length = 30, 100
    assert groups * length > sys.getrecursionlimit()
    mat, tree, tex = image_material("deep chains")
    adds = chain_group("Add", "ShaderNodeMath", "ADD", length, 0.0002, "NodeSocketFloat")
    steps = chain_group("Step", "ShaderNodeVectorMath", "ADD", length, (0.0, 0.0, 0.0),
                        "NodeSocketVector")
    value = _node(tree, "ShaderNodeValue")
    value.outputs[0].default_value = 0.0
    out, vec = value.outputs[0], tex.inputs["Vector"].links[0].from_socket
    for _ in range(groups):
        for group, kind in ((adds, "out"), (steps, "vec")):
            node = _node(tree, "ShaderNodeGroup")
            node.node_tree = group
            if kind == "out":
                _link(tree, out, node.inputs[0])
                out = node.outputs[0]
            else:
                _link(tree, vec, node.inputs[0])
                vec = node.outputs[0]
    _link(tree, vec, tex.inputs["Vector"])
    mix = _node(tree, "ShaderNodeMix", data_type="RGBA", blend_type="MULTIPLY")
    mix.inputs["Factor"].default_value = 1.0
    _link(tree, tex.outputs["Color"], mix.inputs[6])
    _link(tree, out, mix.inputs[7])
    diffuse_with(tree, mix.outputs[2])
    warnings = Warnings()
    program = convert_material(mat, warnings).program
    assert not warnings.texts()
    assert len(program.ops) > 2 * groups * length  # every node compiled
    ours, cycles = compare_albedo(mat, mean=1e-3, worst=0.01)
    assert 0.05 < ours.mean() < 0.6  # the image times 0.6


def test_the_blender_nodes_compiled_are_those_the_core_declares():
    """Each Blender node the compiler reads is declared once, in the core (``nodes.NODES``):
    the compiler has a function for exactly those, and the supported list derives from them."""
    from bo2_lighting.addon.blender import material_nodes
    from bo2_lighting.addon.core.scene.nodes import BLENDER_NODES

    assert set(material_nodes.NODES) == set(BLENDER_NODES)
    assert BLENDER_NODES <= material_nodes.SUPPORTED_NODES
