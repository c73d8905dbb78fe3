"""How each Blender shader node compiles into the core's program operations
(``core.scene.material``): one function per node, ``NODES`` by the node's ``bl_idname``. A
function takes the compiler (``materials._Compiler``), the node, the output socket read and the
group context, and returns the output's register and kind.
"""

from __future__ import annotations

import numpy as np

from ..core.scene import node_math as nm
from ..core.scene.nodes import BLENDER_NODES
from .images import load_image

RAMP_TABLE_SIZE = 257  # Cycles' RAMP_TABLE_SIZE + 1 entries, at i / 256


def socket_kind(socket) -> str:
    """The kind of value a socket carries: "color", "vector", "shader" or "float"."""
    return {"RGBA": "color", "VECTOR": "vector", "SHADER": "shader"}.get(socket.type, "float")


def _in(c, node, key, kind, ctx):
    """Input ``key`` (name or index) of ``node`` as ``kind``."""
    sock = node.inputs[key]
    return c.socket(sock, kind, ctx)


def _by_id(node, identifier):
    return next(s for s in node.inputs if s.identifier == identifier)


def _swizzle(c, reg, start, stop):
    return c.b.add("swizzle", reg, param=(start, stop))


def _image(c, node, out, ctx):
    alpha_linked = node.outputs["Alpha"].is_linked
    if node.projection != "FLAT":
        c.warn(f"node '{node.name}': projection {node.projection} is read as Flat")
    tex = load_image(node.image, node.extension, node.interpolation, c.warnings,
                     f"Material '{c.name}', node '{node.name}'")
    alpha_mode = getattr(node.image, "alpha_mode", "STRAIGHT") if node.image else "NONE"
    # Cycles filters a colour image with alpha on colour times alpha; its Color output stays so
    # unless the Alpha output is used (then it is divided by alpha again, before the sRGB
    # decoding); data (Non-Color) images are never associated
    data = node.image is not None and node.image.colorspace_settings.is_data
    colour = not data and alpha_mode in ("STRAIGHT", "PREMUL")
    associate = (2 if alpha_linked else 1) if colour else 0
    vec = node.inputs["Vector"]
    args = (c.socket(vec, "vector", ctx),) if vec.is_linked else ()
    reg = c.b.add("image", *args, param=(tex, associate))
    if out.name == "Alpha":
        return _swizzle(c, reg, 3, 4), "float"
    return _swizzle(c, reg, 0, 3), "color"


def _texcoord(c, node, out, ctx):
    if getattr(node, "object", None) is not None:
        c.warn(f"node '{node.name}': coordinates of another object are not supported; the "
               "shaded object's are used")
    if out.name == "UV":
        return c.b.add("uv", param=("",)), "vector"
    return c.b.add("texcoord", param=(out.name,)), "vector"


def _uvmap(c, node, out, ctx):
    return c.b.add("uv", param=(node.uv_map,)), "vector"


def _attribute_out(c, reg, out_name):
    if out_name in ("Color",):
        return _swizzle(c, reg, 0, 3), "color"
    if out_name == "Vector":
        return _swizzle(c, reg, 0, 3), "vector"
    if out_name == "Alpha":
        return _swizzle(c, reg, 3, 4), "float"
    return c.b.add("to_float", _swizzle(c, reg, 0, 3), param=("vector",)), "float"  # Fac


def _attribute(c, node, out, ctx):
    if node.attribute_type != "GEOMETRY":
        c.warn(f"node '{node.name}': {node.attribute_type.lower()} attributes are not "
               "supported; they read 0")
        return c.constant(0.0, socket_kind(out)), socket_kind(out)
    if not node.attribute_name:  # Cycles looks up no attribute: 0
        c.warn(f"node '{node.name}' names no attribute; it reads 0")
        return c.constant(0.0, socket_kind(out)), socket_kind(out)
    return _attribute_out(c, c.b.add("attribute", param=(node.attribute_name,)), out.name)


def _color_attribute(c, node, out, ctx):
    return _attribute_out(c, c.b.add("attribute", param=(node.layer_name,)), out.name)


def _value(c, node, out, ctx):
    return c.constant(out.default_value, socket_kind(out)), socket_kind(out)


_GEOMETRY = {"Position", "Normal", "True Normal", "Incoming", "Backfacing"}


def _geometry(c, node, out, ctx):
    if out.name not in _GEOMETRY:
        c.warn(f"node '{node.name}': output '{out.name}' is not supported; it reads 0")
        return c.constant(0.0, socket_kind(out)), socket_kind(out)
    return c.b.add("geometry", param=(out.name,)), socket_kind(out)


def _fresnel(c, node, out, ctx):
    return c.b.add("fresnel", _in(c, node, "IOR", "float", ctx),
                   c.normal(node, "Normal", ctx)), "float"


def _layer_weight(c, node, out, ctx):
    reg = c.b.add("layer_weight", _in(c, node, "Blend", "float", ctx),
                  c.normal(node, "Normal", ctx))
    k = 0 if out.name == "Fresnel" else 1
    return _swizzle(c, reg, k, k + 1), "float"


def _mapping(c, node, out, ctx):
    args = [_in(c, node, name, "vector", ctx) if name in node.inputs
            else c.b.const(0.0, 0.0, 0.0) for name in ("Vector", "Location", "Rotation")]
    args.append(_in(c, node, "Scale", "vector", ctx))
    return c.b.add("mapping", *args, param=(node.vector_type,)), "vector"


def _separate_color(c, node, out, ctx):
    reg = c.b.add("separate", _in(c, node, 0, "color", ctx), param=(node.mode,))
    k = list(node.outputs).index(out)
    return _swizzle(c, reg, k, k + 1), "float"


def _combine_color(c, node, out, ctx):
    return c.b.add("combine", *(_in(c, node, k, "float", ctx) for k in range(3)),
                   param=(node.mode,)), "color"


def _separate_xyz(c, node, out, ctx):
    reg = _in(c, node, 0, "vector", ctx)
    k = list(node.outputs).index(out)
    return _swizzle(c, reg, k, k + 1), "float"


def _combine_xyz(c, node, out, ctx):
    return c.b.add("combine", *(_in(c, node, k, "float", ctx) for k in range(3)),
                   param=("XYZ",)), "vector"


def _math(c, node, out, ctx):
    return c.b.add("math", *(_in(c, node, k, "float", ctx) for k in range(3)),
                   param=(node.operation, bool(node.use_clamp))), "float"


def _vector_math(c, node, out, ctx):
    op = node.operation
    args = [_in(c, node, k, "vector", ctx) for k in range(3)]
    args.append(_in(c, node, 3, "float", ctx) if len(node.inputs) > 3 else c.b.const(1.0))
    value_op = op in nm.VECTOR_MATH_VALUE
    if (out.name == "Value") != value_op:  # the output this operation leaves unset reads 0
        return c.constant(0.0, socket_kind(out)), socket_kind(out)
    return c.b.add("vector_math", *args, param=(op,)), "float" if value_op else "vector"


def _mix(c, node, out, ctx):
    dt = node.data_type
    if dt not in ("FLOAT", "VECTOR", "RGBA"):
        c.warn(f"node '{node.name}': Mix of {dt} is not supported; its A input is used")
        dt = "FLOAT"
    suffix, kind = {"FLOAT": ("Float", "float"), "VECTOR": ("Vector", "vector"),
                    "RGBA": ("Color", "color")}[dt]
    uniform = dt != "VECTOR" or node.factor_mode == "UNIFORM"
    factor = c.socket(_by_id(node, "Factor_Float" if uniform else "Factor_Vector"),
                      "float" if uniform else "vector", ctx)
    a = c.socket(_by_id(node, f"A_{suffix}"), kind, ctx)
    b = c.socket(_by_id(node, f"B_{suffix}"), kind, ctx)
    return c.b.add("mix", factor, a, b, param=(dt, node.blend_type, bool(node.clamp_factor),
                                               bool(node.clamp_result))), kind


def _mix_rgb(c, node, out, ctx):
    return c.b.add("mix", _in(c, node, "Fac", "float", ctx), _in(c, node, 1, "color", ctx),
                   _in(c, node, 2, "color", ctx),
                   param=("RGBA", node.blend_type, True, bool(node.use_clamp))), "color"


def _invert(c, node, out, ctx):
    return c.b.add("invert", _in(c, node, "Fac", "float", ctx),
                   _in(c, node, "Color", "color", ctx)), "color"


def _gamma(c, node, out, ctx):
    return c.b.add("gamma", _in(c, node, "Color", "color", ctx),
                   _in(c, node, "Gamma", "float", ctx)), "color"


def _bright_contrast(c, node, out, ctx):
    return c.b.add("bright_contrast", _in(c, node, "Color", "color", ctx),
                   _in(c, node, "Bright", "float", ctx),
                   _in(c, node, "Contrast", "float", ctx)), "color"


def _hsv(c, node, out, ctx):
    return c.b.add("hsv", *(_in(c, node, k, "float", ctx) for k in range(4)),
                   _in(c, node, "Color", "color", ctx)), "color"


def _ramp(c, node, out, ctx):
    ramp = node.color_ramp
    table = np.array([ramp.evaluate(i / (RAMP_TABLE_SIZE - 1)) for i in range(RAMP_TABLE_SIZE)],
                     np.float32)
    reg = c.b.add("ramp", _in(c, node, "Fac", "float", ctx),
                  param=(table, ramp.interpolation != "CONSTANT"))
    if out.name == "Alpha":
        return _swizzle(c, reg, 3, 4), "float"
    return _swizzle(c, reg, 0, 3), "color"


def _curve_table(mapping, curves, combine):
    """Cycles' ``curvemapping_color_to_array``: (table (256, k), min_x, max_x, extrapolate:
    whether the curves extend their end slopes, Blender's Extrapolated, or hold their ends)."""
    mapping.initialize()
    lo = min(cm.points[0].location[0] for cm in mapping.curves if len(cm.points))
    hi = max(cm.points[-1].location[0] for cm in mapping.curves if len(cm.points))
    xs = lo + np.arange(RAMP_TABLE_SIZE) / (RAMP_TABLE_SIZE - 1) * (hi - lo)
    cm = mapping.curves
    if combine:  # each channel's curve after the combined one
        rows = [[mapping.evaluate(cm[k], mapping.evaluate(cm[3], x)) for k in curves]
                for x in xs]
    else:
        rows = [[mapping.evaluate(cm[k], x) for k in curves] for x in xs]
    return (np.array(rows, np.float32), float(lo), float(hi),
            getattr(mapping, "extend", "EXTRAPOLATED") == "EXTRAPOLATED")


def _rgb_curves(c, node, out, ctx):
    return c.b.add("curves", _in(c, node, "Fac", "float", ctx),
                   _in(c, node, "Color", "color", ctx),
                   param=_curve_table(node.mapping, (0, 1, 2), True)), "color"


def _float_curve(c, node, out, ctx):
    return c.b.add("float_curve", _in(c, node, 0, "float", ctx), _in(c, node, 1, "float", ctx),
                   param=_curve_table(node.mapping, (0,), False)), "float"


def _map_range(c, node, out, ctx):
    vector = node.data_type == "FLOAT_VECTOR"
    kind = "vector" if vector else "float"
    ids = (["Vector", "From_Min_FLOAT3", "From_Max_FLOAT3", "To_Min_FLOAT3", "To_Max_FLOAT3",
            "Steps_FLOAT3"] if vector else
           ["Value", "From Min", "From Max", "To Min", "To Max", "Steps"])
    socks = [_by_id(node, i) for i in ids]
    args = [c.socket(s, kind, ctx) for s in socks]
    return c.b.add("map_range", *args, param=(node.interpolation_type, bool(node.clamp))), kind


def _clamp(c, node, out, ctx):
    return c.b.add("clamp", *(_in(c, node, k, "float", ctx) for k in ("Value", "Min", "Max")),
                   param=(node.clamp_type,)), "float"


def _rgb_to_bw(c, node, out, ctx):
    return c.b.add("to_float", _in(c, node, "Color", "color", ctx), param=("color",)), "float"


def _normal_map(c, node, out, ctx):
    return c.b.add("normal_map", _in(c, node, "Strength", "float", ctx),
                   _in(c, node, "Color", "color", ctx),
                   param=(node.space, node.uv_map)), "vector"


def _bump(c, node, out, ctx):
    width = (_in(c, node, "Filter Width", "float", ctx) if "Filter Width" in node.inputs
             else c.b.const(1.0))  # before Blender 4.2: one pixel
    return c.b.add("bump", _in(c, node, "Strength", "float", ctx),
                   _in(c, node, "Distance", "float", ctx), _in(c, node, "Height", "float", ctx),
                   c.normal(node, "Normal", ctx), width, param=(bool(node.invert),)), "vector"


def _principled(c, node, out, ctx):
    for name in ("Coat Weight", "Sheen Weight", "Subsurface Weight"):
        if name in node.inputs and not c.is_zero(_in(c, node, name, "float", ctx)):
            c.warn(f"node '{node.name}': {name} is not part of the talk's model and is "
                   "ignored")

    def v(name, kind, default):
        return _in(c, node, name, kind, ctx) if name in node.inputs else c.constant(default, kind)

    base, metallic, ior = v("Base Color", "color", 0.8), v("Metallic", "float", 0.0), v(
        "IOR", "float", 1.5)
    transmission, alpha = v("Transmission Weight", "float", 0.0), v("Alpha", "float", 1.0)
    surface = c.b.add(
        "principled", base, metallic, v("Roughness", "float", 0.5), ior,
        v("Specular IOR Level", "float", 0.5), v("Specular Tint", "color", 1.0),
        transmission, v("Emission Color", "color", 0.0),
        v("Emission Strength", "float", 0.0), alpha, c.normal(node, "Normal", ctx))
    if c.is_zero(transmission):
        return surface, "shader"
    # the transmission of the dielectric part (one less the metal), of the covered part, tinted
    # by the square root of the base colour (Cycles' Principled BSDF: the colour is met twice)
    weight = _arith(c, "MULTIPLY", _arith(c, "MULTIPLY", transmission, alpha),
                    _arith(c, "SUBTRACT", c.b.const(1.0), metallic))
    tint = c.b.add("gamma", base, c.b.const(0.5))
    return c.b.add("add_shader", surface, _see_through(c, tint, weight, ior)), "shader"


def _arith(c, operation, a, b):
    return c.b.add("math", a, b, c.b.const(0.0), param=(operation, False))


def _f0(c, ior):
    """The register of a dielectric's reflectance at normal incidence, ((ior - 1) / (ior +
    1))^2."""
    one = c.b.const(1.0)
    r = _arith(c, "DIVIDE", _arith(c, "SUBTRACT", ior, one), _arith(c, "ADD", ior, one))
    return _arith(c, "MULTIPLY", r, r)


def _see_through(c, color, weight, ior):
    """Transmission as EEVEE shows it without refraction: seen through (``see_through``: as a
    Transparent BSDF, but casting shadows) by ``color`` times ``weight`` times one less the
    dielectric's reflectance at normal incidence, F0 = ((ior - 1) / (ior + 1))^2."""
    through = _arith(c, "MULTIPLY", weight, _arith(c, "SUBTRACT", c.b.const(1.0), _f0(c, ior)))
    zero = c.b.const(0.0, 0.0, 0.0)
    return c.b.add("see_through", c.b.add("vector_math", color, zero, zero, through,
                                          param=("SCALE",)))


def _glass(c, node, out, ctx):
    """Glass BSDF: its reflection (a Glossy BSDF of the colour times F0) plus what it lets
    through (``_see_through``), without refraction."""
    color, ior = _in(c, node, "Color", "color", ctx), _in(c, node, "IOR", "float", ctx)
    zero = c.b.const(0.0, 0.0, 0.0)
    tint = c.b.add("vector_math", color, zero, zero, _f0(c, ior), param=("SCALE",))
    mirror = c.b.add("glossy", tint, _in(c, node, "Roughness", "float", ctx),
                     c.normal(node, "Normal", ctx))
    return c.b.add("add_shader", mirror, _see_through(c, color, c.b.const(1.0), ior)), "shader"


def bo2_material(c, node, out, ctx):
    def v(name, kind, default):
        return _in(c, node, name, kind, ctx) if name in node.inputs else c.constant(default, kind)

    return c.b.add("bo2", v("Albedo", "color", 0.8), v("Specular Color", "color", 0.04),
                   v("Gloss", "float", 0.5), c.normal(node, "Normal", ctx),
                   v("Emission", "color", 0.0), v("Emission Strength", "float", 1.0),
                   v("Alpha", "float", 1.0)), "shader"


def _diffuse(c, node, out, ctx):
    return c.b.add("diffuse", _in(c, node, "Color", "color", ctx),
                   c.normal(node, "Normal", ctx)), "shader"


def _glossy(c, node, out, ctx):
    return c.b.add("glossy", _in(c, node, "Color", "color", ctx),
                   _in(c, node, "Roughness", "float", ctx),
                   c.normal(node, "Normal", ctx)), "shader"


def _emission(c, node, out, ctx):
    return c.b.add("emission", _in(c, node, "Color", "color", ctx),
                   _in(c, node, "Strength", "float", ctx)), "shader"


def _transparent(c, node, out, ctx):
    return c.b.add("transparent", _in(c, node, "Color", "color", ctx)), "shader"


def _holdout(c, node, out, ctx):
    return c.b.add("holdout"), "shader"


def _mix_shader(c, node, out, ctx):
    return c.b.add("mix_shader", _in(c, node, 0, "float", ctx), _in(c, node, 1, "shader", ctx),
                   _in(c, node, 2, "shader", ctx)), "shader"


def _add_shader(c, node, out, ctx):
    return c.b.add("add_shader", _in(c, node, 0, "shader", ctx),
                   _in(c, node, 1, "shader", ctx)), "shader"


NODES = {
    "ShaderNodeTexImage": _image, "ShaderNodeTexCoord": _texcoord, "ShaderNodeUVMap": _uvmap,
    "ShaderNodeAttribute": _attribute, "ShaderNodeVertexColor": _color_attribute,
    "ShaderNodeValue": _value, "ShaderNodeRGB": _value, "ShaderNodeNewGeometry": _geometry,
    "ShaderNodeFresnel": _fresnel, "ShaderNodeLayerWeight": _layer_weight,
    "ShaderNodeMapping": _mapping, "ShaderNodeSeparateColor": _separate_color,
    "ShaderNodeCombineColor": _combine_color, "ShaderNodeSeparateXYZ": _separate_xyz,
    "ShaderNodeCombineXYZ": _combine_xyz, "ShaderNodeMath": _math,
    "ShaderNodeVectorMath": _vector_math, "ShaderNodeMix": _mix, "ShaderNodeMixRGB": _mix_rgb,
    "ShaderNodeInvert": _invert, "ShaderNodeGamma": _gamma,
    "ShaderNodeBrightContrast": _bright_contrast, "ShaderNodeHueSaturation": _hsv,
    "ShaderNodeValToRGB": _ramp, "ShaderNodeMapRange": _map_range, "ShaderNodeClamp": _clamp,
    "ShaderNodeRGBToBW": _rgb_to_bw, "ShaderNodeRGBCurve": _rgb_curves,
    "ShaderNodeFloatCurve": _float_curve, "ShaderNodeNormalMap": _normal_map,
    "ShaderNodeBump": _bump, "ShaderNodeBsdfPrincipled": _principled,
    "ShaderNodeBsdfDiffuse": _diffuse, "ShaderNodeBsdfGlossy": _glossy,
    "ShaderNodeBsdfAnisotropic": _glossy, "ShaderNodeEmission": _emission,
    "ShaderNodeBsdfTransparent": _transparent, "ShaderNodeHoldout": _holdout,
    "ShaderNodeBsdfGlass": _glass,
    "ShaderNodeMixShader": _mix_shader, "ShaderNodeAddShader": _add_shader,
}
# The nodes a material may use: those the core's operations stand for (``nodes.NODES``), and
# the tree's structure (groups, reroutes, frames, the output)
SUPPORTED_NODES = BLENDER_NODES | {"NodeReroute", "NodeFrame", "NodeGroupInput",
                                   "NodeGroupOutput", "ShaderNodeGroup",
                                   "ShaderNodeOutputMaterial", "ShaderNodeOutputAOV"}

