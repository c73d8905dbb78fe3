"""Material programs on the GPU (``gpu_backend.materials``, ``glsl/nodes.glsl``) against the
NumPy reference of every node (``core.scene.nodes.NODES``), point for point: each operation
reads random values at random points (corner attributes that change linearly over the pixel,
so that screen derivatives are known on both sides), in every mode it has."""

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import texture as core_texture
from bo2_lighting.addon.core.scene import material
from bo2_lighting.addon.core.scene import node_math as nm
from bo2_lighting.addon.core.scene.program import ProgramBuilder
from bo2_lighting.addon.gpu_backend import images, materials, pointwise, textures

RNG = np.random.default_rng(11)
N = 400  # points per case
STREAMS = (("attribute", "s0"), ("attribute", "s1"), ("attribute", "s2"),
           ("tangent", "UVMap"))
W2C = np.array([[0.8, 0.0, -0.6, 1.0], [0.36, 0.8, 0.48, -2.0], [0.48, -0.6, 0.64, -5.0],
                [0.0, 0.0, 0.0, 1.0]])


def _unit(a):
    return (a / np.linalg.norm(a, axis=1, keepdims=True)).astype(np.float32)


def _rotations(n):
    """(n, 3, 3) random rotations (from unit quaternions)."""
    w, x, y, z = _unit(RNG.normal(size=(n, 4)).astype(np.float64)).T
    rows = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return np.stack([np.stack(row, 1) for row in rows], 1)


class Field:
    """N random points: what a program reads there, as the CPU's ``material.Points`` and as
    the GPU's inputs; corner attributes ``STREAMS`` (s0-s2: values in [lo, hi])."""

    def __init__(self, n=N, lo=-2.0, hi=3.0):
        self.n = n
        self.position = RNG.uniform(-3, 3, (n, 3)).astype(np.float32)
        self.normal = _unit(RNG.normal(size=(n, 3)))
        self.geo = _unit(self.normal + 0.3 * RNG.normal(size=(n, 3)))
        self.view = _unit(self.normal + 0.8 * RNG.normal(size=(n, 3)))
        self.backfacing = (RNG.random((n, 1)) < 0.3).astype(np.float32)
        self.window = RNG.random((n, 2)).astype(np.float32)
        self.dpos = [(RNG.normal(size=(n, 3)) * 0.02).astype(np.float32) for _ in range(2)]
        self.dwin = [np.tile(np.float32([[1 / 320, 0.0]]), (n, 1)),
                     np.tile(np.float32([[0.0, -1 / 180]]), (n, 1))]
        self.uv = [RNG.uniform(-1, 2, (n, 2)).astype(np.float32),
                   (RNG.normal(size=(n, 2)) * 0.004).astype(np.float32),
                   (RNG.normal(size=(n, 2)) * 0.004).astype(np.float32)]
        self.streams = {}
        for key in STREAMS:
            value = RNG.uniform(lo, hi, (n, 4)).astype(np.float32)
            if key[0] == "tangent":
                value[:, :3] = _unit(np.cross(self.normal, RNG.normal(size=(n, 3))))
                value[:, 3] = np.where(RNG.random(n) < 0.5, -1.0, 1.0)
            self.streams[key] = [value] + [(RNG.normal(size=(n, 4)) * 0.05).astype(np.float32)
                                           for _ in range(2)]
        m = np.zeros((n, 4, 4))
        m[:, :3, :3] = _rotations(n) * RNG.uniform(0.5, 2.0, (n, 1, 3))
        m[:, :3, 3] = RNG.uniform(-2, 2, (n, 3))
        m[:, 3, 3] = 1.0
        self.w2o = m
        size = RNG.uniform(0.5, 3.0, (n, 3))
        size[RNG.random((n, 3)) < 0.1] = 0.0
        self.texspace = np.stack([RNG.uniform(-1, 1, (n, 3)), size], 1).astype(np.float32)

    def points(self) -> material.Points:
        def interpolate(key, w):
            corners = self.uv if key == ("uv", "") else self.streams.get(key)
            if corners is None:
                return None
            return (w[:, :1] * corners[0] + w[:, 1:2] * corners[1]
                    + w[:, 2:3] * corners[2]).astype(np.float32)

        def shifts(axis, step):
            bary = np.zeros((self.n, 3), np.float32)
            bary[:, 0], bary[:, 1 + axis] = 1.0, step
            return bary, {"position": self.position + np.float32(step) * self.dpos[axis],
                          "window": self.window + np.float32(step) * self.dwin[axis]}

        fields = {"position": self.position, "normal": self.normal, "geo": self.geo,
                  "view": self.view, "backfacing": self.backfacing, "world_to_object": self.w2o,
                  "texspace": self.texspace, "window": self.window, "world_to_camera": W2C}
        bary = np.zeros((self.n, 3), np.float32)
        bary[:, 0] = 1.0
        return material.Points(self.n, bary, fields, interpolate, shifts)

    def inputs(self, repeat: int) -> dict:
        z = np.zeros((self.n, 1), np.float32)
        feeds = {"pos": self.position, "nrm": self.normal, "geo": self.geo, "view": self.view,
                 "misc": np.column_stack([self.backfacing, self.window, z]),
                 "uv": np.column_stack(self.uv[:2]), "uvd": self.uv[2],
                 "dpx": self.dpos[0], "dpy": self.dpos[1],
                 "dwin": np.column_stack(self.dwin)}
        for k in range(3):
            feeds[f"o{k}"] = self.w2o[:, k].astype(np.float32)
        feeds["o3"], feeds["o4"] = self.texspace[:, 0], self.texspace[:, 1]
        for k, key in enumerate(STREAMS):
            for part, suffix in zip(self.streams[key], ("", "x", "y"), strict=True):
                feeds[f"s{k}{suffix}"] = part
        return {name: np.tile(np.asarray(a, np.float32), (repeat, 1))
                for name, a in feeds.items()}


ENVIRONMENT = """
vec3 mp_dpos[2];
vec2 mp_dwin[2];
vec4 mp_rows[5];
MatPoint mp_moved(MatPoint p, int axis, float step)
{
  MatPoint q = p;
  q.position = p.position + step * mp_dpos[axis];
  q.window = p.window + step * mp_dwin[axis];
  q.shift = axis == 0 ? vec2(step, 0.0) : vec2(0.0, step);
  return q;
}
vec4 mp_object(MatPoint p, int k) { return mp_rows[k]; }
vec3 mp_camera(vec3 q) { return (W2C * vec4(q, 1.0)).xyz; }
vec4 mat_const(int k)
{
  int w = textureSize(mat_consts, 0).x;
  return texelFetch(mat_consts, ivec2(k % w, k / w), 0);
}
"""
IMAGE_ENVIRONMENT = """
vec4 mp_image(int t, vec2 uv, float lod, int associate)
{
  return texture_sample(t, img_texels, uv, lod, associate);
}
"""
SETUP = """
  mp_dpos[0] = dpx.xyz; mp_dpos[1] = dpy.xyz;
  mp_dwin[0] = dwin.xy; mp_dwin[1] = dwin.zw;
  mp_uv0 = vec3(uv.xy, 0.0); mp_duv[0] = vec3(uv.zw, 0.0); mp_duv[1] = vec3(uvd.xy, 0.0);
  mp_rows[0] = o0; mp_rows[1] = o1; mp_rows[2] = o2; mp_rows[3] = o3; mp_rows[4] = o4;
  mp_a0 = s0; mp_da0[0] = s0x; mp_da0[1] = s0y;
  mp_a1 = s1; mp_da1[0] = s1x; mp_da1[1] = s1y;
  mp_a2 = s2; mp_da2[0] = s2x; mp_da2[1] = s2y;
  mp_a3 = s3; mp_da3[0] = s3x; mp_da3[1] = s3y;
  MatPoint p;
  p.position = pos.xyz; p.normal = nrm.xyz; p.geo = geo.xyz; p.view = view.xyz;
  p.backfacing = misc.x; p.window = misc.yz; p.object = 0; p.shift = vec2(0.0);
"""


def _w2c() -> str:
    cols = ", ".join(materials.glsl_float(v) for v in np.asarray(W2C, np.float32).T.reshape(-1))
    return f"const mat4 W2C = mat4({cols});\n"


def _run(program, regs, field: Field, texture=None, surface=False) -> np.ndarray:
    """(len(regs), N, 4) the GPU's values of ``regs`` at the field's points (or, ``surface``,
    (5, N, 4): albedo, rf0, emission, (gloss, alpha, occlusion) and the normal)."""
    streams = {key: k for k, key in enumerate(STREAMS)}
    tex_images = {id(texture): 0} if texture is not None else {}
    constants = materials.Constants()
    if surface:
        code = materials.surface_function(program, "mat", tex_images, streams, constants)
        call = """MatSurface s = mat(p);
          int which = index / N_POINTS;
          res = which == 0 ? vec4(s.albedo, 0.0) : which == 1 ? vec4(s.rf0, 0.0) :
                which == 2 ? vec4(s.emission, 0.0) :
                which == 3 ? vec4(s.gloss, s.alpha, s.occlusion, 0.0) : vec4(s.normal, 0.0);"""
        repeat = 5
    else:
        code = materials.value_function(program, list(regs), "value", tex_images, streams,
                                        constants)
        call = "res = value(p, index / N_POINTS);"
        repeat = len(regs)
    functions = (_w2c() + materials.attribute_globals(len(STREAMS)) + ENVIRONMENT
                 + (IMAGE_ENVIRONMENT if texture is not None else "") + code)
    extra = {"samplers": (("FLOAT_2D", "mat_consts", textures.rows(constants.array())),)}
    if texture is not None:
        record, texels = images.upload(texture)
        extra = {"structs": (images.IMAGE,),
                 "blocks": (("ImageData", "images[1]", images.IMAGE.pack([record])),),
                 "samplers": extra["samplers"] + (
                     ("FLOAT_2D", "img_texels", texels),
                     ("FLOAT_2D", "srgb_table", images.srgb_table()))}
    out = pointwise.run(("texture", "nodes") if texture is not None else ("nodes",),
                        SETUP + call, field.inputs(repeat), ("res",), functions=functions,
                        defines={"N_POINTS": field.n}, **extra)["res"]
    return out.reshape(repeat, field.n, 4)


def _reference(program, regs, field: Field) -> list[np.ndarray]:
    pts = field.points()
    ev = material._Evaluation(program, pts)
    return [np.broadcast_to(np.asarray(ev.value(r, pts), np.float32),
                            (field.n, ev.value(r, pts).shape[1])) for r in regs]


def _check(program, regs, field, names, rtol=2e-4, atol=2e-5, allowed=0.0, texture=None):
    """Every register's GPU values against the reference: |gpu - cpu| <= atol + rtol |cpu|
    at all points but a share ``allowed`` (discontinuities: a floor, a comparison)."""
    gpu = _run(program, regs, field, texture)
    for k, (cpu, name) in enumerate(zip(_reference(program, regs, field), names, strict=True)):
        got = gpu[k, :, :cpu.shape[1]]
        bad = ~(np.abs(got - cpu) <= atol + rtol * np.abs(cpu))
        share = bad.any(axis=1).mean()
        worst = np.flatnonzero(bad.any(axis=1))[:3]
        assert share <= allowed, (name, share, cpu[worst], got[worst])


def _inputs(b: ProgramBuilder, *widths: int) -> list[int]:
    """Registers reading the random streams s0-s2 (then again from s0): floats and vectors,
    in the given widths."""
    regs, used = [], 0
    for w in widths:
        stream, start = divmod(used, 4)
        if start + w > 4:
            stream, start = stream + 1, 0
            used = 4 * stream
        attr = b.add("attribute", param=(f"s{stream % 3}",))
        regs.append(b.add("swizzle", attr, param=(start, start + w)))
        used += w
    return regs


DISCONTINUOUS_MATH = {"LESS_THAN", "GREATER_THAN", "COMPARE", "ROUND", "FLOOR", "CEIL", "TRUNC",
                      "FRACT", "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG", "SIGN"}


@pytest.mark.parametrize("use_clamp", [False, True])
def test_math(use_clamp):
    field = Field()
    b = ProgramBuilder()
    x, y, z = _inputs(b, 1, 1, 1)
    regs = [b.add("math", x, y, z, param=(op, use_clamp)) for op in nm.MATH]
    _check(_whole(b, regs), regs, field, list(nm.MATH), rtol=5e-4, allowed=0.01)


def _whole(b: ProgramBuilder, regs):
    """A program keeping every register of ``regs`` (a closure reads them all)."""
    from bo2_lighting.addon.core.scene.program import Program

    return Program(list(b.ops), regs[-1])


def test_math_at_its_edges():
    """Zero, negative and integer operands: the safe division, power and logarithm."""
    field = Field()
    for key in ("attribute", "s0"), ("attribute", "s1"), ("attribute", "s2"):
        v = field.streams[key][0]
        v[::3] = np.round(v[::3]) + np.float32(0.0)  # no negative zeros: their sign is noise
        v[::7] = 0.0
    b = ProgramBuilder()
    x, y, z = _inputs(b, 1, 1, 1)
    ops = ("DIVIDE", "POWER", "LOGARITHM", "INVERSE_SQRT", "SQRT", "MODULO", "FLOORED_MODULO",
           "SNAP", "WRAP", "PINGPONG", "ARCTAN2", "SMOOTH_MIN", "COMPARE")
    regs = [b.add("math", x, y, z, param=(op, False)) for op in ops]
    _check(_whole(b, regs), regs, field, ops, rtol=5e-4, allowed=0.01)


def test_modulo_is_cs_fmod():
    """Modulo where the float32 quotient rounds to an integer (1 mod 0.1, 5.5 mod 1.1), by an
    infinite divisor, of negative numbers: C's fmod at every point."""
    field = Field()
    a, b = field.streams[("attribute", "s0")][0][:, 0], field.streams[("attribute", "s0")][0][:, 1]
    pairs = [(1.0, 0.1), (5.5, 1.1), (-5.5, 1.1), (0.3, 0.1), (7.0, -0.7), (2.5, np.inf),
             (-1.0, 0.1), (1e-3, 1e-4)]
    for k, (x, y) in enumerate(pairs):
        a[k::len(pairs)], b[k::len(pairs)] = x, y
    b_ = ProgramBuilder()
    x, y, z = _inputs(b_, 1, 1, 1)
    regs = [b_.add("math", x, y, z, param=("MODULO", False)),
            b_.add("vector_math", b_.add("to_vector", x), b_.add("to_vector", y), z, z,
                   param=("MODULO",))]
    _check(_whole(b_, regs), regs, field, ["math", "vector math"], rtol=1e-6, atol=1e-7)


def test_vector_math():
    field = Field()
    b = ProgramBuilder()
    a, c = _inputs(b, 3, 3)
    d, s = _inputs(b, 3, 1)[0], _inputs(b, 1)[0]
    regs = [b.add("vector_math", a, c, d, s, param=(op,)) for op in nm.VECTOR_MATH]
    _check(_whole(b, regs), regs, field, list(nm.VECTOR_MATH), rtol=5e-4, atol=5e-5,
           allowed=0.01)


@pytest.mark.parametrize("clamp_result", [False, True])
def test_mix_colour_blend_modes(clamp_result):
    field = Field(lo=-0.2, hi=1.2)
    b = ProgramBuilder()
    f, c1, c2 = _inputs(b, 1, 3, 3)
    regs = [b.add("mix", f, c1, c2, param=("RGBA", mode, True, clamp_result))
            for mode in nm.BLEND_MODES]
    _check(_whole(b, regs), regs, field, list(nm.BLEND_MODES), rtol=5e-4, atol=5e-5,
           allowed=0.01)


def test_mix_float_and_vector():
    field = Field()
    b = ProgramBuilder()
    f, x, y, fv, u, v = _inputs(b, 1, 1, 1, 3, 3, 3)
    regs = [b.add("mix", f, x, y, param=("FLOAT", "MIX", True, False)),
            b.add("mix", f, u, v, param=("VECTOR", "MIX", False, False)),
            b.add("mix", fv, u, v, param=("VECTOR", "MIX", True, False))]
    _check(_whole(b, regs), regs, field, ["float", "vector", "per component"])


def test_colour_adjustments_and_models():
    field = Field(lo=-0.2, hi=1.3)
    b = ProgramBuilder()
    c, f, g, br, co = _inputs(b, 3, 1, 1, 1, 1)
    h, s, v = _inputs(b, 1, 1, 1)
    regs = [b.add("invert", f, c), b.add("gamma", c, g), b.add("bright_contrast", c, br, co),
            b.add("hsv", h, s, v, f, c)]
    names = ["invert", "gamma", "bright_contrast", "hsv"]
    for model in ("RGB", "HSV", "HSL"):
        regs.append(b.add("separate", c, param=(model,)))
        regs.append(b.add("combine", h, s, v, param=(model if model != "RGB" else "XYZ",)))
        names += [f"separate {model}", f"combine {model}"]
    regs += [b.add("to_float", c, param=("color",)), b.add("to_float", c, param=("vector",)),
             b.add("to_vector", f)]
    names += ["to_float colour", "to_float vector", "to_vector"]
    _check(_whole(b, regs), regs, field, names, rtol=5e-4, atol=5e-5, allowed=0.01)


def test_mapping():
    field = Field()
    b = ProgramBuilder()
    v, loc, rot, scale = _inputs(b, 3, 3, 3, 3)
    none = b.const(0.0, 0.0, 0.0)
    kinds = list(materials.MAPPING_KINDS)
    regs = [b.add("mapping", v, loc, r, scale, param=(k,)) for k in kinds for r in (rot, none)]
    _check(_whole(b, regs), regs, field, [f"{k} {r}" for k in kinds for r in ("turned", "not")],
           rtol=5e-4, atol=5e-5)


def test_map_range_and_clamp():
    field = Field()
    b = ProgramBuilder()
    value, f0, f1, t0, t1, steps = _inputs(b, 1, 1, 1, 1, 1, 1)
    vv, v0, v1 = _inputs(b, 3, 3, 3)
    regs, names = [], []
    for kind in materials.MAP_RANGE_KINDS:
        for use_clamp in (False, True):
            regs.append(b.add("map_range", value, f0, f1, t0, t1, steps, param=(kind, use_clamp)))
            names.append(f"{kind} {use_clamp}")
        regs.append(b.add("map_range", vv, v0, v1, t0, t1, steps, param=(kind, True)))
        names.append(f"{kind} vector")
    for kind in ("MINMAX", "RANGE"):
        regs.append(b.add("clamp", value, f0, f1, param=(kind,)))
        names.append(f"clamp {kind}")
    _check(_whole(b, regs), regs, field, names, rtol=5e-4, atol=5e-5, allowed=0.01)


def test_ramps_and_curves():
    field = Field(lo=-0.4, hi=1.4)
    b = ProgramBuilder()
    f, x = _inputs(b, 1, 1)
    c = _inputs(b, 3)[0]
    table4 = RNG.random((257, 4)).astype(np.float32)
    table3 = np.sort(RNG.random((257, 3)), axis=0).astype(np.float32)
    table1 = np.sort(RNG.random((257, 1)), axis=0).astype(np.float32)
    regs = [b.add("ramp", f, param=(table4, True)), b.add("ramp", f, param=(table4, False)),
            b.add("curves", f, c, param=(table3, -0.2, 1.1, False)),
            b.add("curves", f, c, param=(table3, 0.0, 1.0, True)),
            b.add("float_curve", f, x, param=(table1, 0.0, 1.0, True)),
            b.add("float_curve", f, x, param=(table1, 0.5, 0.5, False))]
    _check(_whole(b, regs), regs, field, ["ramp", "ramp constant", "curves", "curves extrapolated",
                                          "float curve", "float curve flat"], rtol=5e-4,
           atol=5e-5, allowed=0.01)


def test_what_programs_read_at_the_point():
    field = Field()
    b = ProgramBuilder()
    regs = [b.add("uv", param=("",)), b.add("uv", param=("Missing",)),
            b.add("attribute", param=("s1",)), b.add("attribute", param=("Missing",))]
    names = ["uv", "missing uv", "attribute", "missing attribute"]
    for which in ("Position", "Normal", "True Normal", "Incoming", "Backfacing"):
        regs.append(b.add("geometry", param=(which,)))
        names.append(f"geometry {which}")
    for which in materials.TEXCOORDS:
        regs.append(b.add("texcoord", param=(which,)))
        names.append(f"texcoord {which}")
    _check(_whole(b, regs), regs, field, names, rtol=5e-4, atol=5e-5)


def test_fresnel_layer_weight_and_normal_maps():
    field = Field(lo=0.0, hi=1.0)
    b = ProgramBuilder()
    ior, blend, strength = _inputs(b, 1, 1, 1)
    color, nrm = _inputs(b, 3, 3)
    ior = b.add("math", ior, b.const(2.0), b.const(0.0), param=("MULTIPLY_ADD", False))
    ior = b.add("math", ior, b.const(0.7), b.const(0.0), param=("ADD", False))
    regs = [b.add("fresnel", ior, None), b.add("fresnel", ior, nrm),
            b.add("layer_weight", blend, None), b.add("layer_weight", blend, nrm),
            b.add("layer_weight", b.const(0.5), None), b.add("layer_weight", b.const(0.0), None)]
    names = ["fresnel", "fresnel normal", "layer weight", "layer weight normal",
             "layer weight 0.5", "layer weight 0"]
    for space in ("TANGENT", "OBJECT", "WORLD", "BLENDER_OBJECT", "BLENDER_WORLD"):
        regs.append(b.add("normal_map", strength, color, param=(space, "UVMap")))
        names.append(f"normal map {space}")
    regs.append(b.add("normal_map", strength, color, param=("TANGENT", "Missing")))
    names.append("normal map without tangents")
    _check(_whole(b, regs), regs, field, names, rtol=1e-3, atol=1e-4, allowed=0.01)


def test_bump_from_the_heights_at_moved_points():
    """The height read at points moved filter-width pixels (a UV map through a sine, and an
    attribute), as Cycles' ``svm_node_set_bump``."""
    field = Field(lo=0.0, hi=1.0)
    b = ProgramBuilder()
    strength, distance = _inputs(b, 1, 1)
    uv = b.add("uv", param=("",))
    u = b.add("swizzle", uv, param=(0, 1))
    height = b.add("math", b.add("math", u, b.const(40.0), b.const(0.0),
                                 param=("MULTIPLY", False)), b.const(0.0), b.const(0.0),
                   param=("SINE", False))
    width = b.const(0.1)
    other = _inputs(b, 1)[0]
    ramp = b.add("ramp", height, param=(np.float32([[0, 0, 0, 1], [0.3, 0.6, 1, 1],
                                                   [1, 1, 1, 1]]), True))
    ramped = b.add("to_float", ramp, param=("color",))
    regs = [b.add("bump", strength, distance, height, None, width, param=(False,)),
            b.add("bump", strength, distance, height, None, b.const(1.0), param=(True,)),
            b.add("bump", strength, distance, other, None, width, param=(False,)),
            b.add("bump", strength, distance, ramped, None, width, param=(False,))]
    _check(_whole(b, regs), regs, field, ["bump", "bump inverted, 1 px", "bump of attribute",
                                          "bump of a ramp"], rtol=2e-3, atol=2e-3,
           allowed=0.01)


@pytest.mark.parametrize("dtype,channels,extension,interpolation", [
    ("uint8", 4, "REPEAT", "Linear"), ("float", 3, "MIRROR", "Cubic"),
    ("uint8", 1, "EXTEND", "Closest"), ("float", 4, "CLIP", "Linear")])
def test_image_at_the_level_of_its_footprint(dtype, channels, extension, interpolation):
    """Image Texture at the mip level of its vector's change over one pixel (the active UV
    map, and a Mapping of it), RGBA whatever the image's channels."""
    image = RNG.uniform(0, 1, (64, 96, channels)).astype(np.float32)
    if dtype == "uint8":
        image = (image * 255).astype(np.uint8)
    tex = core_texture.make_texture(image if channels > 1 else image[..., 0], srgb=True,
                                    extension=extension, interpolation=interpolation)
    field = Field()
    b = ProgramBuilder()
    uv = b.add("uv", param=("",))
    mapped = b.add("mapping", uv, b.const(0.1, 0.2, 0.0), b.const(0.0, 0.0, 0.3),
                   b.const(3.0, 2.0, 1.0), param=("POINT",))
    curve = b.add("curves", b.const(1.0), mapped, param=(
        np.float32([[0.0, 0.0, 0.0], [0.6, 0.5, 0.4], [1.0, 1.0, 1.0]]), -1.0, 3.0, True))
    regs = [b.add("image", param=(tex, 0)), b.add("image", mapped, param=(tex, 1)),
            b.add("image", curve, param=(tex, 0))]
    _check(_whole(b, regs), regs, field, ["active UV", "mapped", "through curves"], rtol=1e-3,
           atol=1e-4, allowed=0.01, texture=tex)


CLOSURES = {
    "principled": lambda b, v: b.add("principled", v[3], v[0], v[1], v[2], v[0], v[4], v[1],
                                     v[5], v[2], v[0], v[6]),
    "principled opaque": lambda b, v: b.add("principled", v[3], v[0], v[1], v[2], v[0], v[4],
                                            v[1], v[5], v[2], b.const(1.0), None),
    "bo2": lambda b, v: b.add("bo2", v[3], v[4], v[0], None, v[5], v[1], b.const(1.0)),
    "diffuse and glossy": lambda b, v: b.add(
        "mix_shader", v[0], b.add("diffuse", v[3], v[6]), b.add("glossy", v[4], v[1], None)),
    "emission, transparent and holdout": lambda b, v: b.add(
        "add_shader", b.add("emission", v[3], v[2]),
        b.add("mix_shader", v[0], b.add("transparent", v[4]), b.add("holdout"))),
}


@pytest.mark.parametrize("kind", list(CLOSURES))
def test_closures_resolve_to_the_talks_parameters(kind):
    """Shader nodes and their mixes down to albedo, rf0, emission, gloss, alpha and the
    shading normal (``core.scene.material.evaluate``)."""
    field = Field(lo=0.0, hi=1.0)
    b = ProgramBuilder()
    values = _inputs(b, 1, 1, 1, 3, 3, 3, 3)
    values[2] = b.add("math", values[2], b.const(1.5), b.const(1.0), param=("MULTIPLY_ADD", False))
    surface = CLOSURES[kind](b, values)
    program = b.build(surface)
    gpu = _run(program, (), field, surface=True)
    cpu = material.evaluate(program, field.points())
    normal = cpu.normal if cpu.normal is not None else field.normal
    for name, got, want in (("albedo", gpu[0, :, :3], cpu.albedo), ("rf0", gpu[1, :, :3], cpu.rf0),
                            ("emission", gpu[2, :, :3], cpu.emission),
                            ("gloss", gpu[3, :, 0], cpu.gloss), ("alpha", gpu[3, :, 1], cpu.alpha),
                            ("normal", gpu[4, :, :3], normal)):
        assert np.abs(got - want).max() <= 2e-4 * max(1.0, np.abs(want).max()), name


def test_a_changed_value_keeps_the_shader():
    """Two materials that differ in their values alone (a colour, a ramp's table, a curve's
    range) give the same GLSL: a tweak in the viewport compiles nothing."""
    def build(color, table, lo):
        b = ProgramBuilder()
        f = b.add("swizzle", b.add("attribute", param=("s0",)), param=(0, 1))
        ramp = b.add("ramp", f, param=(np.asarray(table, np.float32), True))
        curve = b.add("float_curve", f, f, param=(np.float32([[0.0], [1.0]]), lo, 1.0, False))
        surface = b.add("bo2", b.add("swizzle", ramp, param=(0, 3)), b.const(*color), curve,
                        None, b.const(0.0, 0.0, 0.0), b.const(1.0), b.const(1.0))
        return b.build(surface)

    codes, rows = [], []
    for color, table, lo in (((0.04,) * 3, [[0, 0, 0, 1], [1, 1, 1, 1]], 0.0),
                             ((0.5, 0.2, 0.1), [[1, 0, 0, 1], [0, 0, 1, 1]], 0.25)):
        constants = materials.Constants()
        codes.append(materials.surface_function(build(color, table, lo), "m", {}, {},
                                                constants))
        rows.append(constants.array())
    assert codes[0] == codes[1]
    assert not np.array_equal(rows[0], rows[1])


def test_images_are_uploaded_once_while_their_texels_stay():
    """A frame made again (a material tweak) finds its images' GPU textures kept; the same
    image sampled another way shares them; an image with new texels is uploaded anew."""
    from bo2_lighting.addon.gpu_backend import images

    a = core_texture.make_texture(RNG.uniform(0, 1, (16, 8, 4)).astype(np.float32),
                                  srgb=False)
    b = core_texture.make_texture((RNG.uniform(0, 1, (8, 8, 3)) * 255).astype(np.uint8),
                                  srgb=True)
    records, first = images.pack([a, b])
    again, second = images.pack([a, b.sampled_as("MIRROR", "Closest")])
    assert second[0] is first[0] and second[1] is first[1]
    assert again[1]["info"][2:] != records[1]["info"][2:]  # the sampling is the record's
    edited = core_texture.make_texture(RNG.uniform(0, 1, (16, 8, 4)).astype(np.float32),
                                       srgb=False)
    _, third = images.pack([edited, b])
    assert third[0] is not first[0]
