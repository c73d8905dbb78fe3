"""Material programs (``core.scene.program.Program``, the node graph after it is read) as GLSL:
one function per material, a line per operation calling its GLSL form (``glsl/nodes.glsl``).

A register is a ``vec4`` variable per point context: the shaded point ("c") and, where the
CPU reads a value at moved points, the point moved one pixel right ("x") or down ("y"), for
the screen derivatives of an image's vector (its mip level), and ``filter width`` pixels for a
Bump's height ("bx<k>", "by<k>"). As on the CPU (``core.scene.material``), an image read at a
moved point keeps the level found at the shaded one, and a Bump there gives its normal input.

The values a program holds (its constants, ramp and curve tables) are data, not code: rows
of ``mat_const(k)`` (``Constants``), so that a value changed in a material keeps its shader
(only a changed graph compiles anew).

What the generated code calls besides ``nodes.glsl`` is given by its environment (the frame,
``glsl/material_frame.glsl``; the tests): ``mp_moved(p, axis, step)``, ``mp_object(p, k)``
(row k of the object's world_to_object, then its texture space's start and size),
``mp_image(t, uv, lod, associate)``, ``mp_camera(position)`` and ``mat_const(k)``; the
active UV map and the corner attributes by their value at the point and their change along
the two axes whose mix ``MatPoint.shift`` holds (``attribute_globals``).
"""

from __future__ import annotations

import math

import numpy as np

from ..core.scene import node_math as nm
from ..core.scene.nodes import NODES
from ..core.scene.program import Program
from . import images

MAX_IMAGES = 24  # images of every material together (ImageData records: 7 KiB)
MAX_STREAMS = 5  # corner attributes besides the active UV map (vertex inputs of 16)
MATH_OPS = {name: k for k, name in enumerate(nm.MATH)}  # nodes.glsl's numbering
VECTOR_OPS = {name: k for k, name in enumerate(nm.VECTOR_MATH)}
BLEND_OPS = {name: k for k, name in enumerate(nm.BLEND_MODES)}
COLOR_MODELS = {"RGB": 0, "XYZ": 0, "HSV": 1, "HSL": 2}
MAPPING_KINDS = {"POINT": 0, "TEXTURE": 1, "VECTOR": 2, "NORMAL": 3}
MAP_RANGE_KINDS = {"LINEAR": 0, "STEPPED": 1, "SMOOTHSTEP": 2, "SMOOTHERSTEP": 3}
TEXCOORDS = ("Generated", "Object", "Normal", "Camera", "Window", "Reflection")
NORMAL_SPACES = {"OBJECT": 1, "WORLD": 2, "BLENDER_OBJECT": 3, "BLENDER_WORLD": 4}
_ELEMENTWISE = {"math", "vector_math", "mix", "invert", "gamma", "bright_contrast",
                "map_range", "clamp"}
_WIDTHS = {"float": 1, "vector": 3, "color": 3, "rgba": 4, "pair": 2}


class Unsupported(Exception):
    """A program the GPU does not draw: the message says what."""


def streams(programs: list[Program]) -> list[tuple]:
    """The corner attributes ``programs`` read besides the active UV map, in a fixed order."""
    keys = {key for p in programs for key in p.requires() if key != ("uv", "")}
    return sorted(keys)


def unsupported(programs: list[Program], frame_attributes) -> str | None:
    """Why the GPU cannot draw these programs together (one phrase), or None."""
    found = {id(op.param[0]): op.param[0] for p in programs for op in p.ops
             if op.kind == "image" and op.param[0] is not None}
    if len(found) > MAX_IMAGES:
        return f"materials with more than {MAX_IMAGES} images"
    for codes in (True, False):  # level 0 and its mip chain: 4/3 of its pixels
        texels = sum(int(np.prod(t.size)) * 4 // 3 for t in found.values() if t.codes == codes)
        if texels > images.MAX_TEXELS:
            kind = "8-bit" if codes else "float"
            return (f"{kind} material images of {texels >> 20} M texels with their mip levels "
                    f"({images.MAX_TEXELS >> 20} M at most)")
    present = [k for k in streams(programs) if k in frame_attributes]
    if len(present) > MAX_STREAMS:
        return f"materials reading more than {MAX_STREAMS} UV maps and attributes"
    for p in programs:
        for op in p.ops:
            if op.kind == "bump" and p._varying[op.args[4]]:
                return "a Bump whose Filter Width varies over the surface"
    return None


def attribute_globals(count: int) -> str:
    """GLSL globals of ``count`` corner attributes: the value and its change per axis."""
    return "".join(f"vec4 mp_a{k};\nvec4 mp_da{k}[2];\n" for k in range(count))


def glsl_float(v: float) -> str:
    v = float(np.float32(v))
    if math.isnan(v):
        return "uintBitsToFloat(0x7fc00000u)"
    if math.isinf(v):
        return "uintBitsToFloat(0x7f800000u)" if v > 0 else "uintBitsToFloat(0xff800000u)"
    text = repr(v)
    return text if any(c in text for c in ".en") else text + ".0"


class Constants:
    """The rows (vec4) the programs' ``mat_const(k)`` read, gathered while emitting."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []

    def add(self, values) -> int:
        """Append ``values`` (up to 4, the rest 0) as a row; its number."""
        row = np.zeros(4, np.float32)
        v = np.asarray(values, np.float32).reshape(-1)[:4]
        row[:len(v)] = v
        self.rows.append(row)
        return len(self.rows) - 1

    def array(self) -> np.ndarray:
        """(K, 4) float32, at least one row."""
        return np.array(self.rows or [np.zeros(4, np.float32)], np.float32)


def widths(program: Program) -> list[int]:
    """Each register's columns as the NumPy reference gives them (a float broadcasts)."""
    out: list[int] = []
    for op in program.ops:
        node = NODES[op.kind]
        ins = [out[a] for a in op.args if a is not None]
        if op.kind == "const":
            w = len(op.param)
        elif op.kind == "swizzle":
            w = op.param[1] - op.param[0]
        elif op.kind == "geometry":
            w = 1 if op.param[0] == "Backfacing" else 3
        elif op.kind == "ramp":
            w = np.asarray(op.param[0]).shape[1]
        elif op.kind == "vector_math":
            w = 1 if op.param[0] in nm.VECTOR_MATH_VALUE else 3
        elif op.kind in _ELEMENTWISE or node.output == "columns":
            w = max(ins) if ins else 1
        else:
            w = _WIDTHS.get(node.output, 0)
        out.append(w)
    return out


class _Emitter:
    """Emits one program's GLSL (module docstring)."""

    def __init__(self, program: Program, name: str, images: dict[int, int],
                 streams_: dict[tuple, int], constants: Constants):
        self.program, self.name = program, name
        self.images, self.streams, self.constants = images, streams_, constants
        self.widths = widths(program)
        self.helpers: list[str] = []
        self.lines: list[str] = []
        self._rows: dict = {}  # what was emitted once for every context: a key -> its text

    # what is needed where
    def _cone(self, reg: int) -> set[int]:
        seen, stack = set(), [reg]
        while stack:
            r = stack.pop()
            if r is not None and r not in seen:
                seen.add(r)
                stack.extend(self.program.ops[r].args)
        return seen

    def order(self, roots: list[int]) -> list[tuple]:
        """(register, context) and ("point", context) nodes in an order where each follows
        what it reads (an iterative depth-first search: chains of any length)."""
        ops = self.program.ops

        def deps(node):
            reg, ctx = node
            if reg == "point":
                return [(ops[int(ctx[2:])].args[4], "c")] if ctx.startswith("b") else []
            op = ops[reg]
            out = [(a, ctx) for a in op.args if a is not None]
            if ctx != "c":
                out.append(("point", ctx))
            if op.kind == "image" and op.param[0] is not None:
                if ctx == "c":
                    if op.args:
                        out += [(op.args[0], "x"), (op.args[0], "y")]
                    out += [("point", "x"), ("point", "y")]
                else:
                    out.append((reg, "c"))  # its level of detail
            if op.kind == "bump" and ctx == "c":
                out += [(op.args[2], f"bx{reg}"), (op.args[2], f"by{reg}")]
            return out

        done, result = set(), []
        stack = [((r, "c"), False) for r in reversed(roots)]
        while stack:
            node, expanded = stack.pop()
            if node in done:
                continue
            if expanded:
                done.add(node)
                result.append(node)
                continue
            stack.append((node, True))
            for d in reversed(deps(node)):
                if d not in done:
                    stack.append((d, False))
        return result

    # expressions
    def v(self, reg: int, ctx: str) -> str:
        """A register's value as a vec4, a float broadcast to every component."""
        name = f"r{reg}_{ctx}"
        return f"vec4({name}.x)" if self.widths[reg] == 1 else name

    def normal(self, op, k: int, ctx: str) -> str:
        if k >= len(op.args) or op.args[k] is None:
            return f"p_{ctx}.normal"
        return f"n_unit({self.v(op.args[k], ctx)}.xyz)"

    def stream(self, key, p: str) -> str | None:
        """A corner attribute at point ``p``, or None when no mesh has it."""
        k = self.streams.get(key)
        return None if k is None else (f"(mp_a{k} + {p}.shift.x * mp_da{k}[0] + "
                                       f"{p}.shift.y * mp_da{k}[1])")

    def emit_point(self, ctx: str) -> None:
        if ctx in ("x", "y"):
            self.lines.append(f"  MatPoint p_{ctx} = mp_moved(p_c, {int(ctx == 'y')}, 1.0);")
        else:
            bump = int(ctx[2:])
            width = self.program.ops[bump].args[4]
            self.lines.append(f"  MatPoint p_{ctx} = mp_moved(p_c, {int(ctx[1] == 'y')}, "
                              f"max(r{width}_c.x, 1e-3));")

    def emit(self, reg: int, ctx: str) -> None:
        op = self.program.ops[reg]
        kind = op.kind
        a = [None if r is None else self.v(r, ctx) for r in op.args]
        p = f"p_{ctx}"
        target = f"r{reg}_{ctx}"
        if NODES[kind].output == "closure":
            self.lines.append(f"  Clo {target} = {self.closure(op, a, ctx)};")
            return
        if kind == "image" and op.param[0] is not None and ctx == "c":
            tex = op.param[0]
            vec = [self.v(op.args[0], c) for c in ("c", "x", "y")] if op.args else [
                f"vec4(mp_uv(p_{c}), 0.0)" for c in ("c", "x", "y")]
            size = f"images[{self.images[id(tex)]}].levels[0]"
            self.lines.append(
                f"  float lod{reg} = n_footprint_lod(({vec[1]} - {vec[0]}).xy, "
                f"({vec[2]} - {vec[0]}).xy, float({size}.z), float({size}.y));")
        expr = self.value(op, a, p, reg, ctx)
        self.lines.append(f"  vec4 {target} = {expr};")

    def value(self, op, a, p, reg, ctx) -> str:  # noqa: C901 - one case per operation
        kind, param = op.kind, op.param
        if kind == "const":
            return f"mat_const({self.row(('const', reg), param)})"
        if kind == "uv":
            read = (f"mp_uv({p})" if param[0] == "" else
                    self.stream(("uv", param[0]), p) or "vec4(0.0)")
            return f"vec4(({read}).xy, 0.0, 0.0)"
        if kind == "attribute":
            return self.stream(("attribute", param[0]), p) or "vec4(0.0)"
        if kind == "geometry":
            field = {"Position": "position", "Normal": "normal", "True Normal": "geo",
                     "Incoming": "view"}.get(param[0])
            return f"vec4({p}.backfacing)" if field is None else f"vec4({p}.{field}, 0.0)"
        if kind == "texcoord":
            return f"mp_texcoord({p}, {TEXCOORDS.index(param[0])})"
        if kind == "image":
            tex = param[0]
            if tex is None:
                return "vec4(1.0, 0.0, 1.0, 1.0)"
            vec = a[0] if op.args else f"vec4(mp_uv({p}), 0.0)"
            look = f"mp_image({self.images[id(tex)]}, ({vec}).xy, lod{reg}, {int(param[1])})"
            c = tex.channels
            return look if c == 4 else (f"vec4(({look}).rgb, 1.0)" if c >= 3 else
                                        f"vec4(vec3(({look}).r), 1.0)")
        if kind == "swizzle":
            comps = "xyzw"[param[0]:param[1]]
            src = f"r{op.args[0]}_{ctx}" if self.widths[op.args[0]] > 1 else a[0]
            return f"vec4({', '.join(f'{src}.{c}' for c in comps)}{', 0.0' * (4 - len(comps))})"
        if kind == "to_float":
            if self.widths[op.args[0]] == 1:
                return a[0]
            if param[0] == "color":
                return f"vec4(dot({a[0]}.xyz, vec3(0.2126, 0.7152, 0.0722)))"
            return f"vec4(({a[0]}.x + {a[0]}.y + {a[0]}.z) / 3.0)"
        if kind == "to_vector":
            return f"vec4({a[0]}.xyz, 0.0)"
        if kind == "math":
            return (f"n_math({MATH_OPS[param[0]]}, {a[0]}, {a[1]}, {a[2]}, "
                    f"{'true' if param[1] else 'false'})")
        if kind == "vector_math":
            return f"n_vector_math({VECTOR_OPS[param[0]]}, {a[0]}, {a[1]}, {a[2]}, {a[3]})"
        if kind == "mix":
            data_type, mode, clamp_factor, clamp_result = param
            f = f"clamp({a[0]}, 0.0, 1.0)" if clamp_factor else a[0]
            if data_type == "RGBA":
                return (f"n_blend({BLEND_OPS[mode]}, ({f}).x, {a[1]}, {a[2]}, "
                        f"{'true' if clamp_result else 'false'})")
            return f"({a[1]} + ({a[2]} - {a[1]}) * {f})"
        if kind == "separate":
            return f"n_separate({COLOR_MODELS[param[0]]}, {a[0]})"
        if kind == "combine":
            return f"n_combine({COLOR_MODELS[param[0]]}, {a[0]}.x, {a[1]}.x, {a[2]}.x)"
        if kind == "mapping":
            return f"n_mapping({MAPPING_KINDS[param[0]]}, {a[0]}, {a[1]}, {a[2]}, {a[3]})"
        if kind in ("invert", "gamma", "bright_contrast"):  # n_<kind> of its inputs as they are
            return f"n_{kind}({', '.join(a)})"
        if kind == "hsv":
            return f"n_hsv({a[0]}.x, {a[1]}.x, {a[2]}.x, {a[3]}.x, {a[4]})"
        if kind == "ramp":
            table, interpolate = param
            fn = self.ramp(reg, np.asarray(table, np.float32), interpolate, False)
            return f"{fn}({a[0]}.x)"
        if kind in ("curves", "float_curve"):
            table, lo, hi, extrapolate = param
            table = np.asarray(table, np.float32).reshape(len(table), -1)
            span = self.row(("span", reg), [lo, hi - lo if hi != lo else 1.0])
            rel = f"(({a[1]} - mat_const({span}).x) / mat_const({span}).y)"
            parts = [f"{self.ramp((reg, k), table[:, k:k + 1], True, extrapolate)}"
                     f"({rel}.{'xyz'[k]}).x" for k in range(table.shape[1])]
            out = f"vec4({', '.join(parts)}{', 0.0' * (4 - len(parts))})"
            if table.shape[1] == 1:
                out = f"vec4({parts[0]})"
            return f"((1.0 - {a[0]}) * {a[1]} + {a[0]} * {out})"
        if kind == "map_range":
            return (f"n_map_range({MAP_RANGE_KINDS[param[0]]}, {', '.join(a)}, "
                    f"{'true' if param[1] else 'false'})")
        if kind == "clamp":
            return f"n_clamp({int(param[0] == 'RANGE')}, {a[0]}, {a[1]}, {a[2]})"
        if kind == "fresnel":
            return f"vec4(n_fresnel({a[0]}.x, {self.normal(op, 1, ctx)}, {p}))"
        if kind == "layer_weight":
            return f"n_layer_weight({a[0]}.x, {self.normal(op, 1, ctx)}, {p})"
        if kind == "normal_map":
            space, uv_map = param
            back = f"{p}.backfacing > 0.5"
            if space == "TANGENT":
                t4 = self.stream(("tangent", uv_map), p)
                if t4 is None:
                    return f"vec4({p}.normal, 0.0)"
                return (f"vec4(n_normal_map_tangent({p}.normal, {t4}, {a[1]}.xyz, {a[0]}.x, "
                        f"{back}), 0.0)")
            return (f"vec4(n_normal_map_space({NORMAL_SPACES[space]}, {p}.normal, {a[1]}.xyz, "
                    f"{a[0]}.x, {back}, mp_to_world({p})), 0.0)")
        if kind == "bump":
            n = self.normal(op, 3, ctx)
            if ctx != "c":
                return f"vec4({n}, 0.0)"
            h = op.args[2]
            return (f"vec4(n_bump({a[0]}.x, {a[1]}.x, {'true' if param[0] else 'false'}, {n}, "
                    f"{a[2]}.x, {self.v(h, f'bx{reg}')}.x, {self.v(h, f'by{reg}')}.x, "
                    f"{p}.position, p_bx{reg}.position, p_by{reg}.position), 0.0)")
        raise Unsupported(f"the {kind} node")

    def closure(self, op, a, ctx) -> str:
        kind = op.kind
        zero = "vec3(0.0)"

        def normal(k):
            has = k < len(op.args) and op.args[k] is not None
            return ("true" if has else "false"), (self.normal(op, k, ctx) if has else zero)

        if kind in ("principled", "bo2"):
            opaque = "false"  # (an alpha of 1 mixes nothing in: the same numbers)
            if kind == "principled":
                has, n = normal(10)
                c = (f"n_principled({a[0]}.xyz, {a[1]}.x, {a[2]}.x, {a[3]}.x, {a[4]}.x, "
                     f"{a[5]}.xyz, {a[6]}.x, {a[7]}.xyz * {a[8]}.x, {has}, {n})")
                return f"n_with_alpha({c}, {a[9]}.x, {opaque})"
            has, n = normal(3)
            c = (f"n_closure({a[0]}.xyz, {a[1]}.xyz, 1.0, clamp({a[2]}.x, 0.0, 1.0), "
                 f"{a[4]}.xyz * {a[5]}.x, {has}, {n}, 0.0, false)")
            return f"n_with_alpha({c}, {a[6]}.x, {opaque})"
        if kind == "diffuse":
            has, n = normal(1)
            return (f"n_closure(max({a[0]}.xyz, 0.0), {zero}, 0.0, 0.0, {zero}, {has}, {n}, "
                    "0.0, false)")
        if kind == "glossy":
            has, n = normal(2)
            return (f"n_closure({zero}, clamp({a[0]}.xyz, 0.0, 1.0), 1.0, "
                    f"n_roughness_to_gloss({a[1]}.x), {zero}, {has}, {n}, 0.0, false)")
        if kind == "emission":
            return (f"n_closure({zero}, {zero}, 0.0, 0.0, {a[0]}.xyz * {a[1]}.x, false, {zero}, "
                    "0.0, false)")
        if kind in ("transparent", "see_through"):  # (casting a shadow: the CPU's maps)
            return (f"n_closure({zero}, {zero}, 0.0, 0.0, {zero}, false, {zero}, "
                    f"dot(clamp({a[0]}.xyz, 0.0, 1.0), vec3(0.2126, 0.7152, 0.0722)), true)")
        if kind == "holdout":
            return f"n_closure({zero}, {zero}, 0.0, 0.0, {zero}, false, {zero}, 0.0, true)"
        regs = [f"r{r}_{ctx}" for r in op.args]
        if kind == "add_shader":
            return f"n_add({regs[0]}, {regs[1]})"
        if kind == "mix_shader":
            f = f"clamp({a[0]}.x, 0.0, 1.0)"
            return f"n_add(n_scaled({regs[1]}, 1.0 - {f}), n_scaled({regs[2]}, {f}))"
        raise Unsupported(f"the {kind} node")

    def row(self, key, values) -> int:
        """The number of a constants row holding ``values``, added once per ``key`` (an
        operation is emitted once per point context)."""
        if key not in self._rows:
            self._rows[key] = self.constants.add(values)
        return self._rows[key]

    def ramp(self, key, table: np.ndarray, interpolate: bool, extrapolate: bool) -> str:
        """A helper function looking ``table`` (S, C) up at a float (``nm.ramp_lookup``),
        defined once per ``key``."""
        tag = "_".join(str(k) for k in (key if isinstance(key, tuple) else (key,)))
        name = f"ramp_{self.name}_{tag}"
        if ("ramp", key) in self._rows:
            return name
        self._rows[("ramp", key)] = name
        size = len(table)
        first = len(self.constants.rows)
        for row in table:
            self.constants.add(row)

        def entry(i: str) -> str:
            return f"mat_const({first} + {i})"

        lines = [f"vec4 {name}(float f)", "{",
                 "  f = n_finite(f);  /* a non-finite position reads the first entry */",
                 f"  vec2 at = n_ramp_at(f, {size});",
                 "  int i = int(at.x);",
                 f"  vec4 out_ = {entry('i')};"]
        if interpolate:
            lines.append(f"  if (at.y > 0.0) {{ out_ = (1.0 - at.y) * out_ + at.y * "
                         f"{entry(f'min(i + 1, {size - 1})')}; }}")
        if extrapolate and size > 1:
            first_, second = entry("0"), entry("1")
            last, before = entry(str(size - 1)), entry(str(size - 2))
            lines.append(f"  if (f < 0.0) {{ out_ = {first_} + ({first_} - {second}) * (-f) * "
                         f"{float(size - 1)}; }}")
            lines.append(f"  if (f > 1.0) {{ out_ = {last} + ({last} - {before}) * (f - 1.0) * "
                         f"{float(size - 1)}; }}")
        lines += ["  return out_;", "}", ""]
        self.helpers.append("\n".join(lines))
        return name

    def body(self, roots: list[int]) -> None:
        for reg, ctx in self.order(roots):
            if reg == "point":
                self.emit_point(ctx)
            else:
                self.emit(reg, ctx)


def surface_function(program: Program, name: str, images: dict[int, int],
                     streams_: dict[tuple, int], constants: Constants) -> str:
    """GLSL of ``MatSurface name(MatPoint p_c)``: the talk's parameters of ``program`` at a
    point (``core.scene.material.evaluate``). images: id of a ``Texture`` -> its number in
    ``images[]``; streams_: a corner attribute's key -> its number (``mp_a<k>``); constants:
    where its values go."""
    e = _Emitter(program, name, images, streams_, constants)
    roots = [program.surface] + ([program.occlusion] if program.occlusion is not None else [])
    e.body(roots)
    occlusion = ("1.0" if program.occlusion is None else
                 f"clamp(isnan(r{program.occlusion}_c.x) ? 1.0 : r{program.occlusion}_c.x, "
                 "0.0, 1.0)")
    return "\n".join(e.helpers + [
        f"MatSurface {name}(MatPoint p_c)", "{", *e.lines,
        "  MatSurface s;",
        f"  n_resolve(r{program.surface}_c, p_c.normal, s.albedo, s.rf0, s.emission, s.gloss, "
        "s.alpha, s.normal, s.layer, s.layer_f0);",
        f"  s.occlusion = {occlusion};", "  return s;", "}", ""])


def value_function(program: Program, regs: list[int], name: str, images: dict[int, int],
                   streams_: dict[tuple, int], constants: Constants) -> str:
    """GLSL of ``vec4 name(MatPoint p_c, int which)``: register ``regs[which]``'s value at a
    point (how the tests read single operations)."""
    e = _Emitter(program, name, images, streams_, constants)
    e.body(list(regs))
    cases = [f"    case {k}: return {e.v(r, 'c')};" for k, r in enumerate(regs)]
    return "\n".join(e.helpers + [f"vec4 {name}(MatPoint p_c, int which)", "{", *e.lines,
                                  "  switch (which) {", *cases, "  }", "  return vec4(0.0);",
                                  "}", ""])
