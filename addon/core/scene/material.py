"""Material programs: a material's node tree as a list of operations over per-point arrays.

The Blender side (``addon/blender/materials.py``) translates a node tree once per material into
a ``Program``: operations in dependency order, each reading earlier results ("registers") by
index. The renderer evaluates the program over the visible points of a shading block
(``evaluate``) and gets the talk's parameters there (slide "Black Ops: shading model": albedo,
specular colour rf0, gloss with alpha = 8192^gloss), plus emission, alpha and a shading normal.

Values are float32 arrays (N, 1) for a float socket, (N, 3) for a colour or vector socket and
(N, 4) for an image look-up (RGBA); a constant has N = 1 and broadcasts. A shader socket holds a
``Closure``: weighted sums, so that Mix Shader and Add Shader act per point, as in Cycles:

    mix(a, b, f) = (1 - f) a + f b,   add(a, b) = a + b

over albedo, rf0, emission, the transparent weight, and the weighted gloss and normal (the talk
has one specular lobe: gloss and normal are the averages of the closures that have one,
weighted by their share). Surfaces map to the talk as follows (docs/engine.md, "Materials"):

- Principled BSDF: ``principled_to_talk`` below; Alpha a mixes it with a Transparent BSDF;
- the BO2 Material group: read as it is;
- Diffuse BSDF: albedo = colour, no specular;  Glossy BSDF: rf0 = colour, gloss from roughness
  (Cycles' Glossy has no Fresnel; the talk's Schlick Fresnel brightens it at grazing angles);
- Emission: emitted radiance colour x strength;  Transparent BSDF: its colour's luminance is the
  transparent weight.

Alpha = 1 - transparent weight. A point is drawn with probability alpha (Blender's "Dithered"
render method) and its parameters are then divided by alpha, which keeps the expected radiance
of Cycles' stochastic transparency.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..formulas import brdf
from . import node_math as nm
from .recursion import Bounded

# Operations that read the shaded points (the others are pure functions of their arguments).
INPUT_KINDS = frozenset({"uv", "attribute", "geometry", "texcoord", "fresnel", "layer_weight",
                         "normal_map", "bump"})


@dataclass(frozen=True)
class Op:
    """One operation. kind: a key of ``_OPS``; args: registers read; param: static data."""

    kind: str
    args: tuple = ()
    param: tuple = ()


@dataclass
class Program:
    """A compiled material: ``ops`` in dependency order; ``surface`` the register of the final
    closure; ``occlusion`` an optional float register (the glTF importer's occlusion)."""

    ops: list[Op]
    surface: int
    occlusion: int | None = None

    def __post_init__(self) -> None:
        varying = []
        for op in self.ops:
            varying.append(op.kind in INPUT_KINDS or op.kind == "image" and not op.args
                           or any(varying[a] for a in op.args if a is not None))
        self._varying = varying

    @property
    def constant(self) -> bool:
        """True when the result does not depend on the point: evaluated once per material."""
        outs = [self.surface] + ([self.occlusion] if self.occlusion is not None else [])
        return not any(self._varying[r] for r in outs)

    @property
    def holdout(self) -> bool:
        """True when the surface is a Holdout node: the object cuts a hole, as a holdout
        object does (a Holdout mixed with other shaders renders black instead)."""
        return self.ops[self.surface].kind == "holdout"

    @property
    def fades(self) -> bool:
        """True when the surface may be less than opaque somewhere: a Transparent BSDF or
        Holdout, or an Alpha input that is not the constant 1."""
        if self.holdout:
            return False
        for op in self.ops:
            if op.kind in ("transparent", "holdout"):
                return True
            if op.kind in ("principled", "bo2"):
                alpha = self.ops[op.args[9 if op.kind == "principled" else 6]]
                if not (alpha.kind == "const" and alpha.param[0] >= 1.0):
                    return True
        return False

    def requires(self) -> set[tuple[str, str]]:
        """Corner attributes the program reads: ("uv", map), ("attribute", name),
        ("tangent", map); "" names the active render UV map or colour attribute."""
        need = set()
        for op in self.ops:
            if op.kind == "uv" or op.kind == "image" and not op.args:
                need.add(("uv", op.param[0] if op.kind == "uv" else ""))
            elif op.kind == "attribute":
                need.add(("attribute", op.param[0]))
            elif op.kind == "normal_map" and op.param[0] == "TANGENT":
                need.add(("tangent", op.param[1]))
        return need


class ProgramBuilder:
    """Appends operations and returns their registers (constants are shared)."""

    def __init__(self) -> None:
        self.ops: list[Op] = []
        self._consts: dict[tuple, int] = {}

    def add(self, kind: str, *args, param: tuple = ()) -> int:
        self.ops.append(Op(kind, tuple(args), tuple(param)))
        return len(self.ops) - 1

    def const(self, *values: float) -> int:
        key = tuple(float(v) for v in values)
        if key not in self._consts:
            self._consts[key] = self.add("const", param=key)
        return self._consts[key]

    def build(self, surface: int, occlusion: int | None = None) -> Program:
        """The program of the operations ``surface`` and ``occlusion`` read, in dependency
        order, renumbered (the others, such as those of a compile of a node that stopped part
        way, ``core.scene.recursion``, are dropped)."""
        live = [False] * len(self.ops)
        stack = [r for r in (surface, occlusion) if r is not None]
        while stack:
            reg = stack.pop()
            if not live[reg]:
                live[reg] = True
                stack.extend(a for a in self.ops[reg].args if a is not None)
        new: dict[int, int] = {}
        ops = []
        for reg, op in enumerate(self.ops):
            if live[reg]:
                new[reg] = len(ops)
                ops.append(Op(op.kind, tuple(None if a is None else new[a] for a in op.args),
                              op.param))
        return Program(ops, new[surface], None if occlusion is None else new[occlusion])


def talk_program(albedo=(0.8, 0.8, 0.8), rf0=(0.04, 0.04, 0.04), gloss=0.5,
                 emission=(0.0, 0.0, 0.0), emission_strength=1.0) -> Program:
    """A constant material in the talk's parameters (the BO2 Material's inputs)."""
    b = ProgramBuilder()

    def col(v):
        v = np.broadcast_to(np.asarray(v, np.float32).reshape(-1), (3,))
        return b.const(*v)

    surface = b.add("bo2", col(albedo), col(rf0), b.const(gloss), None, col(emission),
                    b.const(emission_strength), b.const(1.0))
    return b.build(surface)


@dataclass
class Closure:
    """A shader socket's value at N points, every field weighted (module docstring).

    albedo, rf0, emission: (N, 3); spec: (N, 1) weight of closures with a specular lobe;
    gloss: (N, 1) spec-weighted gloss; normal: (N, 3) weighted normal and nweight (N, 1) the
    weight of closures with one; transparent: (N, 1) transparent weight; weight: (N, 1) weight
    of the other closures
    """

    albedo: np.ndarray
    rf0: np.ndarray
    spec: np.ndarray
    gloss: np.ndarray
    emission: np.ndarray
    normal: np.ndarray
    nweight: np.ndarray
    transparent: np.ndarray
    weight: np.ndarray

    def scaled(self, w) -> Closure:
        return Closure(*(getattr(self, f) * w for f in _CLOSURE_FIELDS))


_CLOSURE_FIELDS = ("albedo", "rf0", "spec", "gloss", "emission", "normal", "nweight",
                   "transparent", "weight")
_Z1 = np.zeros((1, 1), np.float32)
_Z3 = np.zeros((1, 3), np.float32)


_ONE = np.ones((1, 1), np.float32)


def _closure(albedo=_Z3, rf0=_Z3, spec=_Z1, gloss=_Z1, emission=_Z3, normal=None,
             transparent=None) -> Closure:
    nweight = _Z1 if normal is None else _ONE
    weight = _ONE if transparent is None else _Z1
    return Closure(albedo, rf0, spec, gloss * spec, emission, _Z3 if normal is None else normal,
                   nweight, _Z1 if transparent is None else transparent, weight)


@dataclass
class SurfaceParams:
    """The talk's parameters at N points: albedo, rf0, emission (N, 3); gloss, alpha (N,);
    normal (N, 3) unit shading normal or None (the geometry's); occlusion (N,) or None."""

    albedo: np.ndarray
    rf0: np.ndarray
    gloss: np.ndarray
    emission: np.ndarray
    alpha: np.ndarray
    normal: np.ndarray | None = None
    occlusion: np.ndarray | None = None


def principled_to_talk(base, metallic, roughness, ior, level, tint, transmission):
    """Principled BSDF inputs -> (albedo (N, 3), rf0 (N, 3), gloss (N, 1)):

        albedo = base (1 - metallic) (1 - transmission)
        rf0    = lerp(F0(ior) 2 level tint, base, metallic),  F0 = ((ior - 1) / (ior + 1))^2
        gloss  = brdf.roughness_to_gloss(roughness)        (docs/model.md)

    base, tint (N, 3); metallic, roughness, ior, level, transmission (N, 1); N may be 1.
    """
    metallic = np.clip(metallic, 0.0, 1.0)
    ior = np.maximum(ior, 1.0)
    f0 = ((ior - 1.0) / (ior + 1.0)) ** 2
    dielectric = np.clip(f0 * 2.0 * level * tint, 0.0, 1.0)
    albedo = base * (1.0 - metallic) * (1.0 - np.clip(transmission, 0.0, 1.0))
    rf0 = dielectric + (base - dielectric) * metallic
    gloss = brdf.roughness_to_gloss(np.clip(roughness, 0.0, 1.0).astype(np.float32))
    return (np.maximum(albedo, 0.0).astype(np.float32), np.maximum(rf0, 0.0).astype(np.float32),
            np.asarray(gloss, np.float32))


# ---------------------------------------------------------------------------------------------
# The shaded points


class Points:
    """What the input operations read at N shaded points, each field computed when first read.

    position, normal, geo, view: (N, 3) float32 world position, unit shading normal and true
    normal (both facing the viewer), unit direction to the viewer; backfacing (N, 1).
    world_to_object: (N, 4, 4) float64; texspace: (N, 2, 3) Generated = (p_obj - [0]) / [1].
    window: (N, 2) position in the frame, [0, 1], origin bottom left; world_to_camera (4, 4).
    bary: (N, 3) barycentrics in the points' triangles.
    fields: those names -> an array, or a function that makes it
    interpolate: (key, bary) -> (N, k) float32 corner attribute ``key`` (``Program.requires``)
    at the points, or None when no mesh has it
    shifts: (axis, step) -> (bary, fields) of the points moved ``step`` pixels right (axis 0)
    or down (1) in their triangles' planes (position and window change), for screen
    derivatives (``shifted``); None when there are none
    """

    _FIELDS = ("position", "normal", "geo", "view", "backfacing", "world_to_object", "texspace",
               "window", "world_to_camera")

    def __init__(self, n: int, bary, fields: dict, interpolate, shifts=None):
        self.n, self.bary = n, bary
        self._fields, self._interpolate, self._shifts = dict(fields), interpolate, shifts

    def _field(self, name):
        value = self._fields[name]
        if callable(value):
            value = self._fields[name] = value()
        return value

    position = property(lambda self: self._field("position"))
    normal = property(lambda self: self._field("normal"))
    geo = property(lambda self: self._field("geo"))
    view = property(lambda self: self._field("view"))
    backfacing = property(lambda self: self._field("backfacing"))
    world_to_object = property(lambda self: self._field("world_to_object"))
    texspace = property(lambda self: self._field("texspace"))
    window = property(lambda self: self._field("window"))
    world_to_camera = property(lambda self: self._field("world_to_camera"))

    def shifted(self, axis: int, step: float = 1.0) -> Points | None:
        """The points moved ``step`` pixels along ``axis`` (0: right, 1: down)."""
        if self._shifts is None:
            return None
        bary, fields = self._shifts(axis, step)
        return Points(self.n, bary, dict(self._fields, **fields), self._interpolate)

    def attribute(self, key, width: int):
        """(N, width) float32 ``key`` at the points, or None when no mesh has it."""
        out = self._interpolate(key, self.bary)
        return None if out is None else out[:, :width]

    def object_point(self, p) -> np.ndarray:
        m = self.world_to_object
        return (np.einsum("nij,nj->ni", m[:, :3, :3], p) + m[:, :3, 3]).astype(np.float32)

    def object_direction(self, d) -> np.ndarray:
        """Normals to object space (by the inverse transpose of object-to-world), unit."""
        m = self.world_to_object[:, :3, :3]
        return unit_vectors(np.einsum("nji,nj->ni", np.linalg.inv(m), d))


def unit_vectors(v) -> np.ndarray:
    v = np.asarray(v, np.float32)
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(length > 0.0, v / np.where(length > 0.0, length, 1.0), 0.0).astype(
        np.float32)


# ---------------------------------------------------------------------------------------------
# Operations: fn(ev, op, points) -> value; ev.arg(k) is argument k at the same points


def _op_const(ev, op, pts):
    return np.asarray(op.param, np.float32).reshape(1, -1)


def _op_uv(ev, op, pts):
    uv = pts.attribute(("uv", op.param[0]), 2)
    out = np.zeros((pts.n, 3), np.float32)
    if uv is not None:
        out[:, :2] = uv
    return out


def _op_attribute(ev, op, pts):
    """(N, 4): RGB (or XYZ, or the value thrice) and alpha of a corner attribute."""
    out = pts.attribute(("attribute", op.param[0]), 4)
    return np.zeros((pts.n, 4), np.float32) if out is None else out


def _op_geometry(ev, op, pts):
    which = op.param[0]
    if which == "Position":
        return pts.position
    if which == "Normal":
        return pts.normal
    if which == "True Normal":
        return pts.geo
    if which == "Incoming":
        return pts.view
    if which == "Backfacing":
        return pts.backfacing
    raise KeyError(which)


def _op_texcoord(ev, op, pts):
    which = op.param[0]
    if which == "Generated":
        t = pts.texspace
        with np.errstate(all="ignore"):
            g = (pts.object_point(pts.position) - t[:, 0]) / np.where(t[:, 1] != 0, t[:, 1], 1)
        return np.where(np.isfinite(g), g, 0.0).astype(np.float32)
    if which == "Object":
        return pts.object_point(pts.position)
    if which == "Normal":
        return pts.object_direction(pts.normal)
    if which == "Camera":
        m = np.asarray(pts.world_to_camera, np.float64)
        c = pts.position @ m[:3, :3].T + m[:3, 3]
        return (c * np.array([1.0, 1.0, -1.0])).astype(np.float32)
    if which == "Window":
        return np.concatenate([pts.window, np.zeros((pts.n, 1), np.float32)], 1)
    if which == "Reflection":
        n, v = pts.normal, pts.view
        return (2.0 * np.einsum("nc,nc->n", n, v)[:, None] * n - v).astype(np.float32)
    raise KeyError(which)


def _op_image(ev, op, pts):
    """(N, 4) RGBA of an image at the vector's (u, v); Cycles' magenta for a missing image.
    param: (texture or None, associate: ``texture.sample``'s). args: (vector,) or () for the
    active UV map."""
    from ..formulas import texture

    tex, associate = op.param
    if tex is None:
        return np.array([[1.0, 0.0, 1.0, 1.0]], np.float32)
    if op.args:
        vec = ev.arg(op, 0, pts)
    else:
        vec = _op_uv(ev, Op("uv", (), ("",)), pts)
    vec = np.broadcast_to(vec, (pts.n, 3))
    lod = ev.lod.get(id(op))
    if lod is None and pts is ev.centre:  # lod from the vector's screen derivatives
        steps = [ev.step(op.args[0] if op.args else None, axis, pts) for axis in (0, 1)]
        if steps[0] is not None and steps[1] is not None:
            from ..kernels import textures as kernels

            lod = np.empty(pts.n, np.float64)
            w, h = tex.size
            kernels.footprint_lod(np.broadcast_to(steps[0], (pts.n, 3)),
                                  np.broadcast_to(steps[1], (pts.n, 3)), float(w), float(h),
                                  lod)
            ev.lod[id(op)] = lod
    px = texture.sample(tex, vec[:, :2], lod, associate)
    c = px.shape[1]
    if c == 4:
        return px
    out = np.empty((pts.n, 4), np.float32)
    out[:, :3] = px[:, :3] if c >= 3 else px[:, :1]
    out[:, 3] = 1.0
    return out


def _op_swizzle(ev, op, pts):
    """Columns of a value: param (start, stop)."""
    v = ev.arg(op, 0, pts)
    return v[:, op.param[0]:op.param[1]]


def _op_to_float(ev, op, pts):
    return nm.to_float(ev.arg(op, 0, pts), op.param[0])


def _op_to_vector(ev, op, pts):
    v = ev.arg(op, 0, pts)
    return np.repeat(v, 3, 1) if v.shape[1] == 1 else v[:, :3]


def _op_math(ev, op, pts):
    a, b, c = (ev.arg(op, k, pts) for k in range(3))
    return nm.math(op.param[0], a, b, c, op.param[1])


def _op_vector_math(ev, op, pts):
    a, b, c, s = (ev.arg(op, k, pts) for k in range(4))
    return nm.vector_math(op.param[0], a, b, c, s)


def _op_mix(ev, op, pts):
    """Mix: param (data_type, blend_type, clamp_factor, clamp_result); args (factor, a, b)."""
    data_type, mode, clamp_factor, clamp_result = op.param
    f, a, b = (ev.arg(op, k, pts) for k in range(3))
    if clamp_factor:
        f = np.clip(f, 0.0, 1.0)
    if data_type == "RGBA":
        return nm.blend(mode, f, a, b, clamp_result)
    return (a + (b - a) * f).astype(np.float32)


_FROM_RGB = {"HSV": nm.rgb_to_hsv, "HSL": nm.rgb_to_hsl}  # Separate Color's models
_TO_RGB = {"HSV": nm.hsv_to_rgb, "HSL": nm.hsl_to_rgb}  # Combine Color's


def _op_separate(ev, op, pts):
    v = ev.arg(op, 0, pts)[:, :3]
    model = _FROM_RGB.get(op.param[0])
    return model(v) if model else v


def _op_combine(ev, op, pts):
    parts = np.broadcast_arrays(*(ev.arg(op, k, pts) for k in range(3)))
    v = np.concatenate(parts, 1).astype(np.float32)
    model = _TO_RGB.get(op.param[0])
    return model(v) if model else v


def _op_mapping(ev, op, pts):
    v, loc, rot, scale = (ev.arg(op, k, pts) for k in range(4))
    return nm.mapping(op.param[0], v, loc, rot, scale)


def _op_invert(ev, op, pts):
    return nm.invert(ev.arg(op, 0, pts), ev.arg(op, 1, pts))


def _op_gamma(ev, op, pts):
    return nm.gamma(ev.arg(op, 0, pts), ev.arg(op, 1, pts))


def _op_bright_contrast(ev, op, pts):
    return nm.bright_contrast(*(ev.arg(op, k, pts) for k in range(3)))


def _op_hsv(ev, op, pts):
    return nm.hue_saturation_value(*(ev.arg(op, k, pts) for k in range(5)))


def _op_ramp(ev, op, pts):
    """param (table (S, 4), interpolate); args (factor,) -> (N, 4) colour and alpha."""
    table, interpolate = op.param
    return nm.ramp_lookup(table, ev.arg(op, 0, pts), interpolate, False)


def _op_curves(ev, op, pts):
    """RGB Curves: param (table (S, 3), min_x, max_x, extrapolate); args (factor, colour)."""
    table, lo, hi, extrapolate = op.param
    f, c = ev.arg(op, 0, pts), ev.arg(op, 1, pts)
    rel = (c - np.float32(lo)) / np.float32(hi - lo if hi != lo else 1.0)
    out = np.concatenate([nm.ramp_lookup(table[:, k:k + 1], rel[:, k:k + 1], True, extrapolate)
                          for k in range(3)], 1)
    return ((1.0 - f) * c + f * out).astype(np.float32)


def _op_float_curve(ev, op, pts):
    table, lo, hi, extrapolate = op.param
    f, v = ev.arg(op, 0, pts), ev.arg(op, 1, pts)
    rel = (v - np.float32(lo)) / np.float32(hi - lo if hi != lo else 1.0)
    out = nm.ramp_lookup(table, rel, True, extrapolate)
    return ((1.0 - f) * v + f * out).astype(np.float32)


def _op_map_range(ev, op, pts):
    kind, use_clamp = op.param
    return nm.map_range(kind, *(ev.arg(op, k, pts) for k in range(6)), use_clamp)


def _op_clamp(ev, op, pts):
    return nm.clamp(op.param[0], *(ev.arg(op, k, pts) for k in range(3)))


def _op_fresnel(ev, op, pts):
    """Fresnel: args (ior, normal or None)."""
    ior = np.maximum(ev.arg(op, 0, pts), 1e-5)
    n = ev.normal_arg(op, 1, pts)
    back = pts.backfacing > 0.5
    eta = np.where(back, 1.0 / ior, ior)
    return nm.fresnel_dielectric_cos(np.einsum("nc,nc->n", pts.view, n)[:, None], eta)


def _op_layer_weight(ev, op, pts):
    """Layer Weight: args (blend, normal or None) -> (N, 2) Fresnel and Facing."""
    blend = ev.arg(op, 0, pts)
    n = ev.normal_arg(op, 1, pts)
    cos = np.einsum("nc,nc->n", pts.view, n)[:, None]
    back = pts.backfacing > 0.5
    eta = np.maximum(1.0 - blend, 1e-5)
    eta = np.where(back, eta, 1.0 / eta)
    fresnel = nm.fresnel_dielectric_cos(cos, eta)
    b = np.clip(blend, 0.0, 1.0 - 1e-5)
    exponent = np.where(b < 0.5, 2.0 * b, 0.5 / (1.0 - b))
    facing = np.where(blend != 0.5, np.abs(cos) ** exponent, np.abs(cos))
    return np.concatenate(np.broadcast_arrays(fresnel, 1.0 - facing), 1).astype(np.float32)


def _op_normal_map(ev, op, pts):
    """Normal Map: param (space, uv map); args (strength, colour) -> (N, 3) world normal."""
    from ..formulas import tangents

    space = op.param[0]
    strength = np.broadcast_to(ev.arg(op, 0, pts), (pts.n, 1))
    color = np.broadcast_to(ev.arg(op, 1, pts)[:, :3], (pts.n, 3))
    n = pts.normal
    if space == "TANGENT":
        t4 = pts.attribute(("tangent", op.param[1]), 4)
        if t4 is None:
            return n
        t, sign = t4[:, :3], np.where(t4[:, 3] < 0.0, -1.0, 1.0)
        flip = np.where(pts.backfacing > 0.5, -1.0, 1.0).astype(np.float32)
        out = tangents.apply_normal_map(n * flip, t, sign, color, strength[:, 0])
        return (out * flip).astype(np.float32)
    c = 2.0 * color - 1.0
    if space in ("OBJECT", "BLENDER_OBJECT", "BLENDER_WORLD") and space != "OBJECT":
        c = c * np.array([1.0, -1.0, -1.0], np.float32)  # Blender's own axes convention
    if space in ("OBJECT", "BLENDER_OBJECT"):  # normals go by the inverse transpose
        c = np.einsum("nji,nj->ni", pts.world_to_object[:, :3, :3], c)
    m = unit_vectors(c)
    m = np.where(pts.backfacing > 0.5, -m, m)  # Cycles turns the mapped normal of back faces
    s = np.maximum(strength, 0.0)
    return unit_vectors(n + (m - n) * s)


def _op_bump(ev, op, pts):
    """Bump (Cycles ``svm_node_set_bump``) from the height's screen derivatives, measured
    ``filter width`` pixels away as Blender 4.2+ does: param (invert,); args (strength,
    distance, height, normal or None, filter width) -> (N, 3)."""
    strength = np.maximum(np.broadcast_to(ev.arg(op, 0, pts), (pts.n, 1)), 0.0)
    distance = np.broadcast_to(ev.arg(op, 1, pts), (pts.n, 1))
    if op.param[0]:
        distance = -distance
    n = ev.normal_arg(op, 3, pts)
    h = np.broadcast_to(ev.arg(op, 2, pts), (pts.n, 1))
    width = np.asarray(ev.arg(op, 4, pts), np.float64)
    step = float(max(width.reshape(-1)[0] if width.size == 1 else width.mean(), 1e-3))
    shifted = [ev._moved(axis, pts, step) for axis in (0, 1)]
    if shifted[0] is None or shifted[1] is None:
        return n
    hx, hy = (np.broadcast_to(ev.value(op.args[2], s), (pts.n, 1)) for s in shifted)
    dpdx = shifted[0].position - pts.position
    dpdy = shifted[1].position - pts.position
    rx = np.cross(dpdy, n)
    ry = np.cross(n, dpdx)
    det = np.einsum("nc,nc->n", dpdx, rx)[:, None]
    grad = (hx - h) * rx + (hy - h) * ry
    out = unit_vectors(np.abs(det) * n - distance * np.sign(det) * grad)
    out = np.where(np.isfinite(out) & (np.abs(out).sum(1, keepdims=True) > 0.0), out, n)
    out = unit_vectors(strength * out + (1.0 - strength) * n)
    return np.where(np.abs(out).sum(1, keepdims=True) > 0.0, out, n)


# Closures


def _op_principled(ev, op, pts):
    """args: base, metallic, roughness, ior, level, tint, transmission, emission colour,
    emission strength, alpha, normal (or None)."""
    base, metallic, rough, ior, level, tint, trans, ecol, estr, alpha = (
        ev.arg(op, k, pts) for k in range(10))
    albedo, rf0, gloss = principled_to_talk(base[:, :3], metallic, rough, ior, level,
                                            tint[:, :3], trans)
    normal = ev.normal_arg(op, 10, pts) if op.args[10] is not None else None
    return _with_alpha(_closure(albedo, rf0, _ONE, gloss, ecol[:, :3] * estr, normal), alpha)


def _op_bo2(ev, op, pts):
    """The BO2 Material group. args: albedo, rf0, gloss, normal, emission, strength, alpha."""
    albedo, rf0, gloss = (ev.arg(op, k, pts) for k in range(3))
    normal = ev.normal_arg(op, 3, pts) if op.args[3] is not None else None
    emission, strength, alpha = (ev.arg(op, k, pts) for k in (4, 5, 6))
    return _with_alpha(_closure(albedo[:, :3], rf0[:, :3], _ONE, np.clip(gloss, 0.0, 1.0),
                                emission[:, :3] * strength, normal), alpha)


def _with_alpha(c: Closure, alpha) -> Closure:
    """A surface of coverage ``alpha``: mixed with a Transparent BSDF by 1 - alpha."""
    if alpha.shape == (1, 1) and alpha[0, 0] >= 1.0:
        return c
    a = np.clip(alpha, 0.0, 1.0)
    return _add(c.scaled(a), _closure(transparent=_ONE).scaled(1.0 - a))


def _op_diffuse(ev, op, pts):
    normal = ev.normal_arg(op, 1, pts) if op.args[1] is not None else None
    return _closure(albedo=np.maximum(ev.arg(op, 0, pts)[:, :3], 0.0), normal=normal)


def _op_glossy(ev, op, pts):
    """args: colour, roughness, normal (or None)."""
    normal = ev.normal_arg(op, 2, pts) if op.args[2] is not None else None
    gloss = brdf.roughness_to_gloss(np.clip(ev.arg(op, 1, pts), 0.0, 1.0)).astype(np.float32)
    return _closure(rf0=np.clip(ev.arg(op, 0, pts)[:, :3], 0.0, 1.0),
                    spec=_ONE, gloss=gloss, normal=normal)


def _op_emission(ev, op, pts):
    return _closure(emission=ev.arg(op, 0, pts)[:, :3] * ev.arg(op, 1, pts))


def _op_transparent(ev, op, pts):
    c = np.clip(ev.arg(op, 0, pts)[:, :3], 0.0, 1.0)
    return _closure(transparent=(c @ nm.LUMINANCE[:, None]).astype(np.float32))


def _op_holdout(ev, op, pts):
    return _closure(transparent=_Z1)


def _add(a: Closure, b: Closure) -> Closure:
    return Closure(*(getattr(a, f) + getattr(b, f) for f in _CLOSURE_FIELDS))


def _op_add_shader(ev, op, pts):
    return _add(ev.arg(op, 0, pts), ev.arg(op, 1, pts))


def _op_mix_shader(ev, op, pts):
    f = np.clip(ev.arg(op, 0, pts), 0.0, 1.0)
    return _add(ev.arg(op, 1, pts).scaled(1.0 - f), ev.arg(op, 2, pts).scaled(f))


_OPS = {
    "const": _op_const, "uv": _op_uv, "attribute": _op_attribute, "geometry": _op_geometry,
    "texcoord": _op_texcoord, "image": _op_image, "swizzle": _op_swizzle,
    "to_float": _op_to_float, "to_vector": _op_to_vector, "math": _op_math,
    "vector_math": _op_vector_math, "mix": _op_mix, "separate": _op_separate,
    "combine": _op_combine, "mapping": _op_mapping, "invert": _op_invert, "gamma": _op_gamma,
    "bright_contrast": _op_bright_contrast, "hsv": _op_hsv, "ramp": _op_ramp,
    "curves": _op_curves, "float_curve": _op_float_curve, "map_range": _op_map_range,
    "clamp": _op_clamp, "fresnel": _op_fresnel, "layer_weight": _op_layer_weight,
    "normal_map": _op_normal_map, "bump": _op_bump, "principled": _op_principled,
    "bo2": _op_bo2, "diffuse": _op_diffuse, "glossy": _op_glossy, "emission": _op_emission,
    "transparent": _op_transparent, "holdout": _op_holdout, "add_shader": _op_add_shader,
    "mix_shader": _op_mix_shader,
}


class _Evaluation:
    """One evaluation of a program at one set of points (and their one-pixel shifts)."""

    def __init__(self, program: Program, points: Points) -> None:
        self.program = program
        self.centre = points
        self.memo: dict[tuple, object] = {}
        self.lod: dict[int, np.ndarray] = {}
        # values and steps call themselves for their arguments: bounded, for chains of any
        # length; a key is ("value", reg, pts) or ("step", reg, axis, pts)
        self.depth = Bounded(lambda key: self._value(*key[1:]) if key[0] == "value"
                             else self._step(*key[1:]))

    def value(self, reg: int, pts: Points):
        key = (reg, id(pts))
        if key in self.memo:
            return self.memo[key]
        if not self.depth.level:
            return self.depth.run(("value", reg, pts))
        return self._value(reg, pts)

    def _value(self, reg: int, pts: Points):
        key = (reg, id(pts))
        if key not in self.memo:
            with self.depth.nested(("value", reg, pts)):
                op = self.program.ops[reg]
                with np.errstate(all="ignore"):
                    self.memo[key] = _OPS[op.kind](self, op, pts)
        return self.memo[key]

    def arg(self, op: Op, k: int, pts: Points) -> np.ndarray:
        return self.value(op.args[k], pts)

    def normal_arg(self, op: Op, k: int, pts: Points) -> np.ndarray:
        """A normal input: its value, unit, or the point's shading normal when unlinked."""
        if k >= len(op.args) or op.args[k] is None:
            return pts.normal
        return unit_vectors(np.broadcast_to(self.value(op.args[k], pts)[:, :3], (pts.n, 3)))

    def step(self, reg: int | None, axis: int, pts: Points):
        """How ``reg`` (None: the active UV map) changes over one pixel along ``axis``, (N, k)
        or None when the points have no neighbours: by the derivative rules of ``_STEPS``
        (exact for these linear operations), else by evaluating the value there."""
        key = ("step", reg, axis)
        if key in self.memo:
            return self.memo[key]
        if not self.depth.level:
            return self.depth.run(("step", reg, axis, pts))
        return self._step(reg, axis, pts)

    def _step(self, reg: int | None, axis: int, pts: Points):
        key = ("step", reg, axis)
        if key in self.memo:
            return self.memo[key]
        with self.depth.nested(("step", reg, axis, pts)):
            moved = self._moved(axis, pts)
            if moved is None:
                result = None
            elif reg is None:
                result = _uv_step("", pts, moved)
            else:
                op = self.program.ops[reg]
                rule = _STEPS.get(op.kind)
                result = rule(self, op, pts, axis, moved) if rule is not None else None
                if result is None and op.kind != "const":
                    result = self.value(reg, moved) - self.value(reg, pts)
                elif result is None:
                    result = np.zeros((1, self.value(reg, pts).shape[1]), np.float32)
        self.memo[key] = result
        return result

    def _moved(self, axis: int, pts: Points, step: float = 1.0):
        key = ("moved", axis, step, id(pts))
        if key not in self.memo:
            self.memo[key] = pts.shifted(axis, step) if pts is self.centre else None
        return self.memo[key]


def _uv_step(name, pts, moved):
    """(N, 3) change of a UV map's (u, v, 0) between the points and ``moved``."""
    d = pts._interpolate(("uv", name), moved.bary - pts.bary)
    out = np.zeros((pts.n, 3), np.float32)
    if d is not None:
        out[:, :2] = d
    return out


def _step_mapping(ev, op, pts, axis, moved):
    kind = op.param[0]
    if kind == "NORMAL" or any(ev.program._varying[a] for a in op.args[1:]):
        return None
    d = ev.step(op.args[0], axis, pts)
    _, loc, rot, scale = (ev.arg(op, k, pts) for k in range(4))
    if kind == "TEXTURE":
        return nm.mapping("TEXTURE", d, np.zeros((1, 3), np.float32), rot, scale)
    return nm.mapping("VECTOR", d, loc, rot, scale)


def _step_vector_math(ev, op, pts, axis, moved):
    kind = op.param[0]
    if kind in ("ADD", "SUBTRACT"):
        da, db = ev.step(op.args[0], axis, pts), ev.step(op.args[1], axis, pts)
        return da + db if kind == "ADD" else da - db
    if kind == "SCALE" and not ev.program._varying[op.args[3]]:
        return ev.step(op.args[0], axis, pts) * ev.arg(op, 3, pts)
    if kind in ("MULTIPLY", "MULTIPLY_ADD"):
        a, b = ev.arg(op, 0, pts), ev.arg(op, 1, pts)
        out = ev.step(op.args[0], axis, pts) * b + a * ev.step(op.args[1], axis, pts)
        return out + ev.step(op.args[2], axis, pts) if kind == "MULTIPLY_ADD" else out
    return None


def _step_swizzle(ev, op, pts, axis, moved):
    return ev.step(op.args[0], axis, pts)[:, op.param[0]:op.param[1]]


def _step_combine(ev, op, pts, axis, moved):
    if op.param[0] != "XYZ":
        return None
    parts = [ev.step(a, axis, pts) for a in op.args]
    return np.concatenate(np.broadcast_arrays(*parts), 1)


# Screen-space steps of linear operations (the others are evaluated at the moved points).
_STEPS = {
    "uv": lambda ev, op, pts, axis, moved: _uv_step(op.param[0], pts, moved),
    "mapping": _step_mapping, "vector_math": _step_vector_math, "swizzle": _step_swizzle,
    "combine": _step_combine,
    "to_vector": lambda ev, op, pts, axis, moved: (
        lambda d: np.repeat(d, 3, 1) if d.shape[1] == 1 else d[:, :3])(
        ev.step(op.args[0], axis, pts)),
}


def evaluate(program: Program, points: Points) -> SurfaceParams:
    """The talk's parameters of a material at N points (module docstring)."""
    ev = _Evaluation(program, points)
    c: Closure = ev.value(program.surface, points)
    n = points.n
    alpha = np.clip(1.0 - c.transparent, 0.0, 1.0)
    opaque = bool(np.all(alpha >= 1.0))
    inv = 1.0 if opaque else np.where(alpha > 0.0, 1.0 / np.where(alpha > 0.0, alpha, 1.0), 0.0)
    gloss = np.where(c.spec > 0.0, c.gloss / np.where(c.spec > 0.0, c.spec, 1.0), 0.0)
    normal = None
    if np.any(c.nweight > 0.0):
        # closures without a normal input contribute the geometry's
        rest = np.maximum(c.weight - c.nweight, 0.0)
        mixed = c.normal + rest * points.normal if np.any(rest > 0.0) else c.normal
        normal = np.broadcast_to(unit_vectors(mixed), (n, 3))
        normal = np.where(np.einsum("nc,nc->n", normal, normal)[:, None] > 0.25, normal,
                          points.normal)
    occlusion = None
    if program.occlusion is not None:
        occ = np.broadcast_to(ev.value(program.occlusion, points), (n, 1))[:, 0]
        occlusion = np.clip(np.nan_to_num(occ, nan=1.0), 0.0, 1.0).astype(np.float32)

    def out(x, width):
        x = np.asarray(x, np.float32)
        if (x.shape != (n, width) or not x.flags.c_contiguous or not x.flags.writeable
                or x is _Z1 or x is _Z3 or x is _ONE):
            x = np.broadcast_to(x, (n, width)).copy()
        return x if np.isfinite(x).all() else np.where(np.isfinite(x), x, 0.0).astype(np.float32)

    return SurfaceParams(
        albedo=out(c.albedo if opaque else c.albedo * inv, 3),
        rf0=out(np.clip(c.rf0 if opaque else c.rf0 * inv, 0.0, 1.0), 3),
        gloss=out(np.clip(gloss, 0.0, 1.0), 1)[:, 0],
        emission=out(c.emission if opaque else c.emission * inv, 3),
        alpha=out(alpha, 1)[:, 0], normal=normal, occlusion=occlusion)


__all__ = ["Op", "Program", "ProgramBuilder", "Points", "SurfaceParams", "Closure",
           "evaluate", "principled_to_talk", "talk_program"]
