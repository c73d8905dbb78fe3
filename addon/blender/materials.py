"""Blender materials -> ``core.scene.Material`` (a compiled ``core.scene.program.Program``).

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

import bpy
import numpy as np

from ..core.render.job import Warnings
from ..core.scene import Material
from ..core.scene.program import ProgramBuilder
from ..core.scene.recursion import Bounded
from .material_nodes import NODES, bo2_material, socket_kind
from .node_groups import is_bo2_material_node

_GLTF_GROUPS = ("glTF Material Output", "glTF Settings")


def _width(socket) -> int:
    return 1 if socket.type in ("VALUE", "INT", "BOOLEAN") else 3


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
        return self.default(into, socket_kind(into)), socket_kind(into)

    def _output(self, node, out, ctx, into) -> tuple[int, str]:
        if node.bl_idname == "NodeReroute":
            return self._through(node.inputs[0], ctx, into)
        if node.mute:
            for link in node.internal_links:
                if link.to_socket.identifier == out.identifier:
                    return self._through(link.from_socket, ctx, into)
            return self.default(out, socket_kind(out)), socket_kind(out)
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
        handler = NODES.get(node.bl_idname)
        if is_bo2_material_node(node):
            handler = bo2_material
        if handler is None:
            self.warn(f"node '{node.name}' ({node.bl_idname}) feeding '{into.name}' is not "
                      "supported; the socket's value is used")
            if socket_kind(into) == "shader":
                return self._viewport_surface(), "shader"
            return self.keep(into)
        return handler(self, node, out, ctx)

    def _through(self, socket, ctx, into) -> tuple[int, str]:
        kind = socket_kind(socket) if socket.type != "CUSTOM" else socket_kind(into)
        return self.socket(socket, kind, ctx), kind

    def _group(self, node, out, ctx, into) -> tuple[int, str]:
        tree = node.node_tree
        if tree is None or not len(tree.nodes):
            what = "has no node tree" if tree is None else \
                f"uses '{tree.name}', which is missing or empty"
            self.warn(f"group node '{node.name}' {what}; its output '{out.name}' reads its "
                      "default, as in Cycles")
            return self.default(out, socket_kind(out)), socket_kind(out)
        outputs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"]
        active = [n for n in outputs if n.is_active_output] or outputs
        if not active:
            return self.default(out, socket_kind(out)), socket_kind(out)
        sock = next((s for s in active[0].inputs if s.identifier == out.identifier), None)
        if sock is None:
            return self.default(out, socket_kind(out)), socket_kind(out)
        kind = socket_kind(out)
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
        aovs = {}  # the AOV Output nodes (of the tree's top level, as Cycles reads them)
        for node in tree.nodes:
            if (node.bl_idname == "ShaderNodeOutputAOV" and not node.mute and node.aov_name
                    and node.aov_name not in aovs):
                aovs[node.aov_name] = (self.socket(node.inputs["Color"], "color"),
                                       self.socket(node.inputs["Value"], "float"))
        return self.b.build(surface, occlusion,
                            tuple((name, *regs) for name, regs in aovs.items()))


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
                    pass_index=int(material.pass_index),
                    blended=material.surface_render_method == "BLENDED",
                    transparency_overlap=bool(material.use_transparency_overlap))

