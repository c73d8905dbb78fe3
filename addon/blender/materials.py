"""Blender materials -> ``core.scene.Material`` (a compiled ``core.scene.material.Program``).

A node tree is translated once per material: each node becomes operations of the core's
material program with Blender's semantics (the core evaluates them; this module only reads
nodes). Node groups (nested), reroutes, frames and muted nodes (through their internal links,
as Blender passes them through) are followed; implicit socket conversions are Cycles' (colour
to float by luminance, vector to float by average, float to colour or vector by repetition,
colour to shader by emission). The supported nodes are listed in ``docs/engine.md``
("Materials"). Any other node gives the value of the socket it feeds and one warning naming
material, node and socket; a node loop, a group without its tree, a missing image (Cycles'
magenta) or attribute (zero) give one warning each and the render goes on.
"""

from __future__ import annotations

import hashlib
import os
import threading

import bpy
import numpy as np

from ..core.formulas import texture
from ..core.render.job import Warnings
from ..core.scene import Material
from ..core.scene import node_math as nm
from ..core.scene.material import ProgramBuilder
from ..core.scene.recursion import Bounded
from ..core.system.cache import Cache
from . import images
from .node_groups import is_bo2_material_node

# image key -> (texture, digest): kept for later renders, the least recently used dropped
# beyond 2 GiB (a texture a material still holds lives on with it)
_textures = Cache("image textures", kept=1 << 16, size=lambda value: value[0].nbytes,
                  budget=2 << 30)
_lock = threading.Lock()  # the viewport and a final render may load images at once
RAMP_TABLE_SIZE = 257  # Cycles' RAMP_TABLE_SIZE + 1 entries, at i / 256
_GLTF_GROUPS = ("glTF Material Output", "glTF Settings")


def _on_disk(image) -> bool:
    return image.source == "FILE" and image.packed_file is None


def _image_key(image) -> tuple:
    """What identifies an image's pixels. An image file on disk that is not in memory: its
    path, size and modification time (read without loading it); an image in memory (edited,
    packed, generated, or loaded by Blender before): its size, type and generator, which load
    it. The two never match, so pixels read from memory are not taken for the file's."""
    common = (image.name_full, image.filepath_raw, image.colorspace_settings.name,
              image.alpha_mode, image.source)
    if _on_disk(image) and not image.has_data:
        try:
            stat = os.stat(bpy.path.abspath(image.filepath, library=image.library))
            return (*common, "file", stat.st_size, stat.st_mtime_ns)
        except (OSError, ValueError):
            pass
    generator = ((image.generated_type, tuple(image.generated_color),
                  image.use_generated_float) if image.source == "GENERATED" else ())
    return (*common, "memory", tuple(image.size), bool(image.is_float), *generator)


def load_image(image, extension: str, interpolation: str, warnings: Warnings, where: str):
    """A Blender image as a mipmapped ``Texture``, or None (with a warning) if unusable. 8-bit
    images stay 8-bit (``images.image_codes``), float images float32. Prepared once per image
    (its nodes' extensions and interpolations share its levels) and reused across renders
    while it is unchanged (an image edited in Blender and not saved is compared by a digest
    of its pixels). An image file that was not in memory before is released again once read
    (on Blender's main thread)."""
    if image is None:
        warnings.add(f"{where}: the Image Texture node has no image")
        return None
    with _lock:
        return _load(image, extension, interpolation, warnings, where)


def _load(image, extension, interpolation, warnings, where):
    main = threading.current_thread() is threading.main_thread()
    release = main and _on_disk(image) and not image.has_data
    key = _image_key(image)
    cached = _textures.get(key)
    dirty = image.is_dirty
    if cached is not None and not dirty:
        return cached[0].sampled_as(extension, interpolation)
    width, height = image.size
    if width == 0 or height == 0 or not image.has_data:
        warnings.add(f"{where}: image '{image.name}' could not be loaded "
                     f"({image.filepath or 'no file'}); it renders magenta, as in Cycles")
        return None
    is_float = image.is_float
    # Byte images hold encoded values; float images are already scene-linear in memory.
    srgb = not is_float and image.colorspace_settings.name == "sRGB"
    # Blender writes the codes of an image only on its main thread (a final render in the UI
    # runs on another)
    pixels = images.image_codes(image, release=release) if main else None
    if pixels is None:
        pixels = images.image_pixels(image)
        if not is_float:  # byte images hold codes / 255
            pixels = np.rint(pixels * np.float32(255.0)).astype(np.uint8)
    if release and image.has_data:
        image.buffers_free()  # (reading the image's properties would load it again)
    digest = None
    if dirty:  # an edited image is compared by its pixels
        rows = pixels[::-1] if pixels[::-1].flags.c_contiguous else np.ascontiguousarray(pixels)
        digest = hashlib.blake2b(memoryview(rows).cast("B"), digest_size=16).hexdigest()
        if cached is not None and cached[1] == digest:
            return cached[0].sampled_as(extension, interpolation)
    tex = texture.make_texture(pixels, srgb=srgb, extension=extension,
                               interpolation=interpolation, name=image.name)
    _textures.put(key, (tex, digest))  # with the digest of an edited image's pixels
    return tex


def _width(socket) -> int:
    return 1 if socket.type in ("VALUE", "INT", "BOOLEAN") else 3


def _kind(socket) -> str:
    return {"RGBA": "color", "VECTOR": "vector", "SHADER": "shader"}.get(socket.type, "float")


class _Compiler:
    """Translates one material's tree; ``socket`` returns a register for an input socket."""

    def __init__(self, material, warnings: Warnings) -> None:
        self.material = material
        self.name = material.name
        self.warnings = warnings
        self.b = ProgramBuilder()
        self.memo: dict[tuple, tuple[int, str]] = {}
        self.busy: set[tuple] = set()
        self.depth = Bounded(lambda key: self._compiled(*key))
        self.said: set[str] = set()

    # -- messages and constants

    def warn(self, text: str) -> None:
        message = f"Material '{self.name}': {text}"
        if message not in self.said:
            self.said.add(message)
            self.warnings.add(message)

    def constant(self, value, kind: str) -> int:
        if kind == "shader":
            return self.b.add("emission", self.b.const(0.0, 0.0, 0.0), self.b.const(0.0))
        try:
            v = [float(x) for x in value][:3]
        except TypeError:
            v = [float(value)]
        if kind == "float":
            return self.b.const(v[0] if len(v) == 1 else float(np.mean(v)))
        return self.b.const(*(v * 3 if len(v) == 1 else v))

    def convert(self, reg: int, src: str, dst: str) -> int:
        """Cycles' implicit conversion of a value of kind ``src`` to kind ``dst``."""
        if src == dst or dst in ("color", "vector") and src in ("color", "vector"):
            return reg
        if dst == "shader":  # colour or value into a shader socket: an emission
            return self.b.add("emission", self.convert(reg, src, "color"), self.b.const(1.0))
        if src == "shader":
            return self.constant(0.0, dst)
        if dst == "float":
            return self.b.add("to_float", reg, param=(src,))
        return self.b.add("to_vector", reg)

    def is_zero(self, reg: int) -> bool:
        op = self.b.ops[reg]
        return op.kind == "const" and not any(op.param)

    # -- following links

    def default(self, socket, kind: str) -> int:
        """A socket's own value (0, or no light, when it has none) as ``kind``."""
        value = getattr(socket, "default_value", None)
        return self.constant(0.0 if value is None else value, kind)

    def socket(self, socket, kind: str, ctx: tuple = ()) -> int:
        """The value flowing into input ``socket`` as ``kind`` ("float", "color", "vector",
        "shader")."""
        link = next((lk for lk in socket.links if not lk.is_muted), None) \
            if socket.is_linked else None
        if link is not None and not link.is_valid:
            self.warn(f"the link from '{link.from_node.name}' to '{link.to_node.name}' is "
                      f"invalid; '{socket.name}' keeps its own value")
            link = None
        if link is None:
            return self.default(socket, kind)
        node, out = link.from_node, link.from_socket
        reg, got = self.output(node, out, ctx, socket)
        return self.convert(reg, got, kind)

    def normal(self, node, name: str, ctx: tuple) -> int | None:
        """A Normal input, or None when it is the surface normal (unlinked)."""
        sock = node.inputs.get(name)
        if sock is None or not sock.is_linked:
            return None
        reg = self.socket(sock, "vector", ctx)
        # a group's unconnected Normal input (a zero vector) is the surface normal, as in Cycles
        return None if self.is_zero(reg) else reg

    def output(self, node, out, ctx: tuple, into) -> tuple[int, str]:
        """(register, kind) of output ``out`` of ``node`` in group context ``ctx``; graphs of
        any depth, their deepest nodes compiled first (``core.scene.recursion``)."""
        key = (ctx, node.as_pointer(), out.identifier)
        if key in self.memo:
            return self.memo[key]
        if not self.depth.level:
            return self.depth.run((node, out, ctx, into))
        return self._compiled(node, out, ctx, into)

    def _compiled(self, node, out, ctx: tuple, into) -> tuple[int, str]:
        key = (ctx, node.as_pointer(), out.identifier)
        if key in self.memo:
            return self.memo[key]
        if key in self.busy:
            self.warn(f"node '{node.name}' is part of a loop; socket '{into.name}' keeps its "
                      "own value")
            return self.keep(into)
        self.busy.add(key)
        self.fallback = False
        try:
            with self.depth.nested((node, out, ctx, into)):
                result = self._output(node, out, ctx, into)
        finally:
            self.busy.discard(key)
        if not self.fallback:  # a fallback is the consuming socket's own value: not shared
            self.memo[key] = result
        self.fallback = False
        return result

    def keep(self, into) -> tuple[int, str]:
        """The consuming socket's own value (a fallback, never memoized for other sockets)."""
        self.fallback = True
        return self.default(into, _kind(into)), _kind(into)

    def _output(self, node, out, ctx, into) -> tuple[int, str]:
        if node.bl_idname == "NodeReroute":
            return self._through(node.inputs[0], ctx, into)
        if node.mute:
            for link in node.internal_links:
                if link.to_socket.identifier == out.identifier:
                    return self._through(link.from_socket, ctx, into)
            return self.default(out, _kind(out)), _kind(out)
        if node.bl_idname == "NodeGroupInput":
            if not ctx:
                return self.keep(into)
            group = ctx[-1]
            sock = next((s for s in group.inputs if s.identifier == out.identifier), None)
            if sock is None:
                return self.keep(into)
            return self._through(sock, ctx[:-1], into)
        if node.bl_idname == "ShaderNodeGroup" and not is_bo2_material_node(node):
            return self._group(node, out, ctx, into)
        handler = _NODES.get(node.bl_idname)
        if is_bo2_material_node(node):
            handler = _bo2
        if handler is None:
            self.warn(f"node '{node.name}' ({node.bl_idname}) feeding '{into.name}' is not "
                      "supported; the socket's value is used")
            if _kind(into) == "shader":
                return self._viewport_surface(), "shader"
            return self.keep(into)
        return handler(self, node, out, ctx)

    def _through(self, socket, ctx, into) -> tuple[int, str]:
        kind = _kind(socket) if socket.type != "CUSTOM" else _kind(into)
        return self.socket(socket, kind, ctx), kind

    def _group(self, node, out, ctx, into) -> tuple[int, str]:
        tree = node.node_tree
        if tree is None or not len(tree.nodes):
            what = "has no node tree" if tree is None else \
                f"uses '{tree.name}', which is missing or empty"
            self.warn(f"group node '{node.name}' {what}; its output '{out.name}' reads its "
                      "default, as in Cycles")
            return self.default(out, _kind(out)), _kind(out)
        outputs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"]
        active = [n for n in outputs if n.is_active_output] or outputs
        if not active:
            return self.default(out, _kind(out)), _kind(out)
        sock = next((s for s in active[0].inputs if s.identifier == out.identifier), None)
        if sock is None:
            return self.default(out, _kind(out)), _kind(out)
        kind = _kind(out)
        return self.socket(sock, kind, ctx + (node,)), kind

    def _viewport_surface(self) -> int:
        m = self.material
        b = self.b
        return b.add("principled", b.const(*m.diffuse_color[:3]), b.const(m.metallic),
                     b.const(m.roughness), b.const(1.5), b.const(0.5), b.const(1.0, 1.0, 1.0),
                     b.const(0.0), b.const(0.0, 0.0, 0.0), b.const(0.0), b.const(1.0), None)

    # -- the whole material

    def compile(self):
        tree = self.material.node_tree
        if tree is None or bpy.app.version < (5, 0, 0) and not self.material.use_nodes:
            return self.b.build(self._viewport_surface())
        outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"
                   and n.target in ("ALL", "CYCLES")]
        active = [n for n in outputs if n.is_active_output] or outputs
        if not active:
            self.warn("no Material Output node; rendered with the viewport colour")
            return self.b.build(self._viewport_surface())
        looped = _looped_tree(tree)
        if looped is not None and bpy.app.version >= (5, 0, 0):
            self.warn(f"the node tree '{looped}' has a loop; the material renders black, as in "
                      "Cycles")
            return self.b.build(self.constant(0.0, "shader"))
        if looped is not None:  # Blender 4.5's Cycles drops the loop's invalid link
            self.warn(f"the node tree '{looped}' has a loop; its invalid link is ignored, as "
                      "in Cycles")
        surface_socket = active[0].inputs["Surface"]
        if not surface_socket.is_linked:
            self.warn("nothing is connected to the Material Output's Surface; it renders "
                      "black, as in Cycles")
        surface = self.socket(surface_socket, "shader")
        occlusion = None
        for node in tree.nodes:
            if (node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None
                    and node.node_tree.name.split(".")[0] in _GLTF_GROUPS
                    and "Occlusion" in node.inputs and node.inputs["Occlusion"].is_linked):
                occlusion = self.socket(node.inputs["Occlusion"], "float")
        return self.b.build(surface, occlusion)


def _looped_tree(tree, seen=None) -> str | None:
    """The name of the first tree (``tree`` or a group used in it) whose links form a loop."""
    seen = set() if seen is None else seen
    if tree.as_pointer() in seen:
        return None
    seen.add(tree.as_pointer())
    after: dict[int, set[int]] = {}
    for link in tree.links:
        after.setdefault(link.from_node.as_pointer(), set()).add(link.to_node.as_pointer())
    state: dict[int, int] = {}  # 1: on the path, 2: done

    def looped(start) -> bool:  # depth-first, with a stack of (node, its successors left)
        state[start] = 1
        path = [(start, iter(after.get(start, ())))]
        while path:
            node, rest = path[-1]
            nxt = next(rest, None)
            if nxt is None:
                state[node] = 2
                path.pop()
            elif state.get(nxt) == 1:
                return True
            elif state.get(nxt) is None:
                state[nxt] = 1
                path.append((nxt, iter(after.get(nxt, ()))))
        return False

    if any(state.get(n) is None and looped(n) for n in list(after)):
        return tree.name
    for node in tree.nodes:
        if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
            inner = _looped_tree(node.node_tree, seen)
            if inner is not None:
                return inner
    return None


# ---------------------------------------------------------------------------------------------
# Nodes: handler(compiler, node, out, ctx) -> (register, kind of the output)


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
        return c.constant(0.0, _kind(out)), _kind(out)
    if not node.attribute_name:  # Cycles looks up no attribute: 0
        c.warn(f"node '{node.name}' names no attribute; it reads 0")
        return c.constant(0.0, _kind(out)), _kind(out)
    return _attribute_out(c, c.b.add("attribute", param=(node.attribute_name,)), out.name)


def _color_attribute(c, node, out, ctx):
    return _attribute_out(c, c.b.add("attribute", param=(node.layer_name,)), out.name)


def _value(c, node, out, ctx):
    return c.constant(out.default_value, _kind(out)), _kind(out)


_GEOMETRY = {"Position", "Normal", "True Normal", "Incoming", "Backfacing"}


def _geometry(c, node, out, ctx):
    if out.name not in _GEOMETRY:
        c.warn(f"node '{node.name}': output '{out.name}' is not supported; it reads 0")
        return c.constant(0.0, _kind(out)), _kind(out)
    return c.b.add("geometry", param=(out.name,)), _kind(out)


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
        return c.constant(0.0, _kind(out)), _kind(out)
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

    return c.b.add(
        "principled", v("Base Color", "color", 0.8), v("Metallic", "float", 0.0),
        v("Roughness", "float", 0.5), v("IOR", "float", 1.5),
        v("Specular IOR Level", "float", 0.5), v("Specular Tint", "color", 1.0),
        v("Transmission Weight", "float", 0.0), v("Emission Color", "color", 0.0),
        v("Emission Strength", "float", 0.0), v("Alpha", "float", 1.0),
        c.normal(node, "Normal", ctx)), "shader"


def _bo2(c, node, out, ctx):
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


_NODES = {
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
    "ShaderNodeMixShader": _mix_shader, "ShaderNodeAddShader": _add_shader,
}
SUPPORTED_NODES = frozenset(_NODES) | {"NodeReroute", "NodeFrame", "NodeGroupInput",
                                       "NodeGroupOutput", "ShaderNodeGroup",
                                       "ShaderNodeOutputMaterial"}

def convert_material(material, warnings: Warnings) -> Material:
    """One Blender material (or None for an empty slot) -> ``core.scene.Material``."""
    if material is None:
        return Material(name="(empty slot)")
    compiler = _Compiler(material, warnings)
    try:
        program = compiler.compile()
    except (KeyError, AttributeError, TypeError, ValueError, RuntimeError) as exc:
        compiler.warn(f"its node tree could not be read ({type(exc).__name__}: {exc}); "
                      "rendered with the viewport colour")
        program = compiler.b.build(compiler._viewport_surface())
    return Material(name=material.name, program=program,
                    backface_culling=bool(getattr(material, "use_backface_culling", False)),
                    pass_index=int(material.pass_index))
