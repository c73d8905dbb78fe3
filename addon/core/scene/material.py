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

from .nodes import NODES, Closure, unit_vectors, uv_step
from .program import Op, Program
from .recursion import Bounded

__all__ = ["Points", "SurfaceParams", "evaluate", "evaluate_aovs"]


@dataclass
class SurfaceParams:
    """The talk's parameters at N points: albedo, rf0, emission (N, 3); gloss, alpha (N,);
    shadow_alpha (N,) the alpha it casts shadows with (a transmission seen through is opaque
    to them; None: ``alpha``);
    normal (N, 3) unit shading normal or None (the geometry's); occlusion (N,) or None; layer
    (N,) the weight of the closures whose albedo lies under a specular layer and layer_f0 (N,)
    that times the layer's rf0 (``Closure.layer``, ``layer_f0``; the albedo is weighted by
    ``env_brdf.diffuse_layering`` where the view is known: ``surface_params``)."""

    albedo: np.ndarray
    rf0: np.ndarray
    gloss: np.ndarray
    emission: np.ndarray
    alpha: np.ndarray
    normal: np.ndarray | None = None
    occlusion: np.ndarray | None = None
    layer: np.ndarray | None = None
    layer_f0: np.ndarray | None = None
    shadow_alpha: np.ndarray | None = None


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
                    self.memo[key] = NODES[op.kind].reference(self, op, pts)
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
        or None when the points have no neighbours: by the derivative rules of ``nodes.NODES``
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
                result = uv_step("", pts, moved)
            else:
                op = self.program.ops[reg]
                rule = NODES[op.kind].step
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
        if x.shape != (n, width) or not x.flags.c_contiguous or not x.flags.writeable:
            x = np.broadcast_to(x, (n, width)).copy()
        return x if np.isfinite(x).all() else np.where(np.isfinite(x), x, 0.0).astype(np.float32)

    return SurfaceParams(
        albedo=out(c.albedo if opaque else c.albedo * inv, 3),
        rf0=out(np.clip(c.rf0 if opaque else c.rf0 * inv, 0.0, 1.0), 3),
        gloss=out(np.clip(gloss, 0.0, 1.0), 1)[:, 0],
        emission=out(c.emission if opaque else c.emission * inv, 3),
        alpha=out(alpha, 1)[:, 0], normal=normal, occlusion=occlusion,
        layer=out(np.clip(c.layer if opaque else c.layer * inv, 0.0, 1.0), 1)[:, 0],
        layer_f0=out(np.clip(c.layer_f0 if opaque else c.layer_f0 * inv, 0.0, 1.0), 1)[:, 0],
        shadow_alpha=None if not np.any(c.through) else out(
            np.clip(1.0 - c.transparent + c.through, 0.0, 1.0), 1)[:, 0])


def evaluate_aovs(program: Program, points: Points, wanted) -> np.ndarray:
    """The shader AOVs ``wanted`` ((name, "COLOR" or "VALUE") each) a material writes at N
    points, side by side: (N, C) float32, 4 columns for a colour (RGB and 1, as Cycles writes
    them: averaged, the alpha is the coverage), 1 for a value; 0 for an AOV it has no AOV
    Output node of."""
    ev = _Evaluation(program, points)
    own = {name: (color, value) for name, color, value in program.aovs}
    columns = []
    for name, kind in wanted:
        width = 4 if kind == "COLOR" else 1
        if name not in own:
            columns.append(np.zeros((points.n, width), np.float32))
            continue
        value = np.ones((points.n, width), np.float32)
        value[:, :min(width, 3)] = ev.value(own[name][0 if kind == "COLOR" else 1],
                                            points)[:, :min(width, 3)]
        columns.append(value)
    out = np.concatenate(columns, axis=1) if columns else np.zeros((points.n, 0), np.float32)
    return np.where(np.isfinite(out), out, 0.0).astype(np.float32)
