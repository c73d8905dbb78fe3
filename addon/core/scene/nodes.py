"""The operations of material programs, each declared once (``NODES``): its inputs and
parameters by name, what it gives, its NumPy reference, its screen-space derivative rule and
the Blender nodes it stands for; the closures that shader operations give (``Closure``); and
the Principled BSDF in the talk's parameters (``principled_to_talk``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..formulas import brdf
from . import node_math as nm

__all__ = ["BLENDER_NODES", "NODES", "Closure", "Node", "principled_to_talk", "unit_vectors",
           "uv_step"]


@dataclass(frozen=True)
class Node:
    """One operation of a material program, declared once.

    kind:      its name in ``Op.kind``
    inputs:    the registers it reads, in ``Op.args`` order (a name ending in "?" may be None:
               an unlinked normal, the shading normal then)
    params:    its static data, in ``Op.param`` order ("*": any number of values)
    output:    what it gives: "float" (N, 1), "vector" or "color" (N, 3), "rgba" (N, 4),
               "columns" (as many as it takes), "pair" (N, 2) or "closure" (a ``Closure``)
    reference: the NumPy evaluation, ``reference(ev, op, points)`` (it calls the compiled
               kernels where they exist: image look-ups in ``kernels.textures``)
    step:      how it changes over one pixel, exactly for a linear operation,
               ``step(ev, op, points, axis, moved)``; None: evaluated at the moved points
    reads_points: it reads the shaded points (the others depend on their inputs alone)
    blender:   the Blender shader nodes whose compilation this operation stands for
    """

    kind: str
    inputs: tuple[str, ...]
    params: tuple[str, ...]
    output: str
    reference: Callable
    step: Callable | None = None
    reads_points: bool = False
    blender: tuple[str, ...] = ()

    def index(self, name: str) -> int:
        """The position of input ``name`` in ``Op.args``."""
        return [i.rstrip("?") for i in self.inputs].index(name)


@dataclass
class Closure:
    """A shader socket's value at N points, every field weighted (module docstring).

    albedo, rf0, emission: (N, 3); spec: (N, 1) weight of closures with a specular lobe;
    gloss: (N, 1) spec-weighted gloss; normal: (N, 3) weighted normal and nweight (N, 1) the
    weight of closures with one; transparent: (N, 1) transparent weight, and through (N, 1) the
    part of it that is a transmission seen through (it casts shadows: ``_op_see_through``);
    weight: (N, 1) weight of the other closures; layer: (N, 1) weight of the closures whose
    diffuse lies under their specular (Principled BSDF: Cycles weights its diffuse by one less
    the specular's albedo);
    layer_f0: (N, 1) weight times the largest channel of that specular's rf0 (the dielectric's:
    a Principled BSDF's metal is not above its diffuse)
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
    layer: np.ndarray
    layer_f0: np.ndarray
    through: np.ndarray

    def scaled(self, w) -> Closure:
        return Closure(*(getattr(self, f) * w for f in _CLOSURE_FIELDS))


_CLOSURE_FIELDS = ("albedo", "rf0", "spec", "gloss", "emission", "normal", "nweight",
                   "transparent", "weight", "layer", "layer_f0", "through")
_Z1 = np.zeros((1, 1), np.float32)
_Z3 = np.zeros((1, 3), np.float32)
_ONE = np.ones((1, 1), np.float32)
for _shared in (_Z1, _Z3, _ONE):  # shared by every closure: never written (copied when output)
    _shared.setflags(write=False)


def _closure(albedo=_Z3, rf0=_Z3, spec=_Z1, gloss=_Z1, emission=_Z3, normal=None,
             transparent=None, layer=_Z1, layer_f0=_Z1, through=_Z1) -> Closure:
    nweight = _Z1 if normal is None else _ONE
    weight = _ONE if transparent is None else _Z1
    return Closure(albedo, rf0, spec, gloss * spec, emission, _Z3 if normal is None else normal,
                   nweight, _Z1 if transparent is None else transparent, weight, layer,
                   layer_f0, through)


def principled_to_talk(base, metallic, roughness, ior, level, tint, transmission):
    """Principled BSDF inputs -> (albedo (N, 3), rf0 (N, 3), gloss (N, 1)):

        albedo = base (1 - metallic) (1 - transmission)
        rf0    = lerp(F0(ior) 2 level tint, base, metallic),  F0 = ((ior - 1) / (ior + 1))^2
        gloss  = brdf.roughness_to_gloss(roughness)        (docs/model.md)

    base, tint (N, 3); metallic, roughness, ior, level, transmission (N, 1); N may be 1.
    """
    metallic = np.clip(metallic, 0.0, 1.0)
    dielectric = dielectric_f0(ior, level, tint)
    albedo = base * (1.0 - metallic) * (1.0 - np.clip(transmission, 0.0, 1.0))
    rf0 = dielectric + (base - dielectric) * metallic
    gloss = brdf.roughness_to_gloss(np.clip(roughness, 0.0, 1.0).astype(np.float32))
    return (np.maximum(albedo, 0.0).astype(np.float32), np.maximum(rf0, 0.0).astype(np.float32),
            np.asarray(gloss, np.float32))


def dielectric_f0(ior, level, tint) -> np.ndarray:
    """A Principled BSDF's dielectric rf0 (N, 3): F0(ior) 2 level tint, F0 = ((ior - 1) /
    (ior + 1))^2 (``principled_to_talk``)."""
    ior = np.maximum(ior, 1.0)
    return np.clip(((ior - 1.0) / (ior + 1.0)) ** 2 * 2.0 * level * tint, 0.0, 1.0)


def unit_vectors(v) -> np.ndarray:
    v = np.asarray(v, np.float32)
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(length > 0.0, v / np.where(length > 0.0, length, 1.0), 0.0).astype(
        np.float32)


def _op_const(ev, op, pts):
    return np.asarray(op.param, np.float32).reshape(1, -1)


def _uv(pts, name: str) -> np.ndarray:
    """(N, 3) the UV map ``name`` ("": the active one) at the points as (u, v, 0)."""
    uv = pts.attribute(("uv", name), 2)
    out = np.zeros((pts.n, 3), np.float32)
    if uv is not None:
        out[:, :2] = uv
    return out


def _op_uv(ev, op, pts):
    return _uv(pts, op.param[0])


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
    vec = ev.arg(op, 0, pts) if op.args else _uv(pts, "")
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
    layer_f0 = dielectric_f0(ior, level, tint[:, :3]).max(axis=1, keepdims=True)
    return _with_alpha(_closure(albedo, rf0, _ONE, gloss, ecol[:, :3] * estr, normal,
                                layer=_ONE, layer_f0=layer_f0.astype(np.float32)), alpha)


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


def _op_see_through(ev, op, pts):
    """A transmission seen without refraction (Glass BSDF, Principled Transmission): the
    camera sees through it by its colour's luminance, as through a Transparent BSDF, but it
    casts a shadow, as glass does in Cycles and EEVEE (no caustics)."""
    c = _op_transparent(ev, op, pts)
    c.through = c.transparent
    return c


def _op_holdout(ev, op, pts):
    return _closure(transparent=_Z1)


def _add(a: Closure, b: Closure) -> Closure:
    return Closure(*(getattr(a, f) + getattr(b, f) for f in _CLOSURE_FIELDS))


def _op_add_shader(ev, op, pts):
    return _add(ev.arg(op, 0, pts), ev.arg(op, 1, pts))


def _op_mix_shader(ev, op, pts):
    f = np.clip(ev.arg(op, 0, pts), 0.0, 1.0)
    return _add(ev.arg(op, 1, pts).scaled(1.0 - f), ev.arg(op, 2, pts).scaled(f))


def uv_step(name, pts, moved):
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



def _step_to_vector(ev, op, pts, axis, moved):
    d = ev.step(op.args[0], axis, pts)
    return np.repeat(d, 3, 1) if d.shape[1] == 1 else d[:, :3]


NODES: dict[str, Node] = {n.kind: n for n in (
    Node("const", (), ("values*",), "columns", _op_const,
         blender=("ShaderNodeValue", "ShaderNodeRGB")),
    Node("uv", (), ("uv_map",), "vector", _op_uv,
         lambda ev, op, pts, axis, moved: uv_step(op.param[0], pts, moved), True,
         ("ShaderNodeTexCoord", "ShaderNodeUVMap")),
    Node("attribute", (), ("name",), "rgba", _op_attribute, reads_points=True,
         blender=("ShaderNodeAttribute", "ShaderNodeVertexColor")),
    Node("geometry", (), ("output",), "vector", _op_geometry, reads_points=True,
         blender=("ShaderNodeNewGeometry",)),
    Node("texcoord", (), ("output",), "vector", _op_texcoord, reads_points=True,
         blender=("ShaderNodeTexCoord",)),
    Node("image", ("vector",), ("texture", "associate"), "rgba", _op_image,
         blender=("ShaderNodeTexImage",)),
    Node("swizzle", ("value",), ("start", "stop"), "columns", _op_swizzle, _step_swizzle,
         blender=("ShaderNodeSeparateXYZ",)),
    Node("to_float", ("value",), ("kind",), "float", _op_to_float,
         blender=("ShaderNodeRGBToBW",)),
    Node("to_vector", ("value",), (), "vector", _op_to_vector, _step_to_vector),
    Node("math", ("a", "b", "c"), ("operation", "use_clamp"), "float", _op_math,
         blender=("ShaderNodeMath",)),
    Node("vector_math", ("a", "b", "c", "scale"), ("operation",), "vector", _op_vector_math,
         _step_vector_math, blender=("ShaderNodeVectorMath",)),
    Node("mix", ("factor", "a", "b"), ("data_type", "blend_type", "clamp_factor",
                                       "clamp_result"), "columns", _op_mix,
         blender=("ShaderNodeMix", "ShaderNodeMixRGB")),
    Node("separate", ("color",), ("model",), "vector", _op_separate,
         blender=("ShaderNodeSeparateColor",)),
    Node("combine", ("x", "y", "z"), ("model",), "vector", _op_combine, _step_combine,
         blender=("ShaderNodeCombineColor", "ShaderNodeCombineXYZ")),
    Node("mapping", ("vector", "location", "rotation", "scale"), ("kind",), "vector",
         _op_mapping, _step_mapping, blender=("ShaderNodeMapping",)),
    Node("invert", ("factor", "color"), (), "color", _op_invert, blender=("ShaderNodeInvert",)),
    Node("gamma", ("color", "gamma"), (), "color", _op_gamma, blender=("ShaderNodeGamma",)),
    Node("bright_contrast", ("color", "bright", "contrast"), (), "color", _op_bright_contrast,
         blender=("ShaderNodeBrightContrast",)),
    Node("hsv", ("hue", "saturation", "value", "factor", "color"), (), "color", _op_hsv,
         blender=("ShaderNodeHueSaturation",)),
    Node("ramp", ("factor",), ("table", "interpolate"), "rgba", _op_ramp,
         blender=("ShaderNodeValToRGB",)),
    Node("curves", ("factor", "color"), ("table", "min_x", "max_x", "extrapolate"), "color",
         _op_curves, blender=("ShaderNodeRGBCurve",)),
    Node("float_curve", ("factor", "value"), ("table", "min_x", "max_x", "extrapolate"),
         "float", _op_float_curve, blender=("ShaderNodeFloatCurve",)),
    Node("map_range", ("value", "from_min", "from_max", "to_min", "to_max", "steps"),
         ("kind", "use_clamp"), "columns", _op_map_range, blender=("ShaderNodeMapRange",)),
    Node("clamp", ("value", "min", "max"), ("kind",), "float", _op_clamp,
         blender=("ShaderNodeClamp",)),
    Node("fresnel", ("ior", "normal?"), (), "float", _op_fresnel, reads_points=True,
         blender=("ShaderNodeFresnel",)),
    Node("layer_weight", ("blend", "normal?"), (), "pair", _op_layer_weight,
         reads_points=True, blender=("ShaderNodeLayerWeight",)),
    Node("normal_map", ("strength", "color"), ("space", "uv_map"), "vector", _op_normal_map,
         reads_points=True, blender=("ShaderNodeNormalMap",)),
    Node("bump", ("strength", "distance", "height", "normal?", "filter_width"), ("invert",),
         "vector", _op_bump, reads_points=True, blender=("ShaderNodeBump",)),
    Node("principled", ("base", "metallic", "roughness", "ior", "level", "tint",
                        "transmission", "emission", "emission_strength", "alpha", "normal?"),
         (), "closure", _op_principled, blender=("ShaderNodeBsdfPrincipled",)),
    Node("bo2", ("albedo", "rf0", "gloss", "normal?", "emission", "emission_strength",
                 "alpha"), (), "closure", _op_bo2),
    Node("diffuse", ("color", "normal?"), (), "closure", _op_diffuse,
         blender=("ShaderNodeBsdfDiffuse",)),
    Node("glossy", ("color", "roughness", "normal?"), (), "closure", _op_glossy,
         blender=("ShaderNodeBsdfGlossy", "ShaderNodeBsdfAnisotropic")),
    Node("emission", ("color", "strength"), (), "closure", _op_emission,
         blender=("ShaderNodeEmission",)),
    Node("transparent", ("color",), (), "closure", _op_transparent,
         blender=("ShaderNodeBsdfTransparent",)),
    Node("see_through", ("color",), (), "closure", _op_see_through,
         blender=("ShaderNodeBsdfGlass",)),
    Node("holdout", (), (), "closure", _op_holdout, blender=("ShaderNodeHoldout",)),
    Node("add_shader", ("a", "b"), (), "closure", _op_add_shader,
         blender=("ShaderNodeAddShader",)),
    Node("mix_shader", ("factor", "a", "b"), (), "closure", _op_mix_shader,
         blender=("ShaderNodeMixShader",)),
)}

BLENDER_NODES = frozenset(b for n in NODES.values() for b in n.blender)
"""The Blender shader nodes a material may use (besides groups, reroutes and frames)."""
