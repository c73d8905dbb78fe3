"""Each GPU stage against the core's kernel of the same name, point for point: the same inputs
(the core's points, normals, maps) through ``pointwise.run``, the outputs compared."""

import numpy as np
import pytest
import scenes

from bo2_lighting.addon.core.kernels import shading
from bo2_lighting.addon.core.lighting import shade
from bo2_lighting.addon.core.render import shadow_filter, shadows
from bo2_lighting.addon.core.scene import Camera, Light
from bo2_lighting.addon.gpu_backend import lights, pointwise, programs, uniforms

RNG = np.random.default_rng(7)


def _unit(a):
    return (a / np.linalg.norm(a, axis=1, keepdims=True)).astype(np.float32)


def test_uniform_block_reads_back_what_was_packed():
    """A struct of every type, packed in Python and read by a shader field by field."""
    struct = uniforms.Struct("Probe", (("a", "float", 0), ("b", "vec3", 0), ("c", "int", 0),
                                       ("d", "vec2", 0), ("e", "vec4", 3), ("f", "ivec4", 2),
                                       ("m", "mat4", 0)))
    m = RNG.normal(size=(4, 4))
    records = [{"a": 1.5, "b": [2, 3, 4], "c": -7, "d": [5, 6],
                "e": np.arange(12) + 0.25, "f": np.arange(8) - 3, "m": m},
               {"a": -1.0, "b": [0.5, 0.25, 0.125], "c": 9, "d": [7, 8],
                "e": -np.arange(12.0), "f": np.arange(8) * 2, "m": -m}]
    body = """
      Probe r = items[index];
      o1 = vec4(r.a, r.b); o2 = vec4(float(r.c), r.d, 0.0); o3 = r.e[1];
      o4 = vec4(r.f[1]); o5 = r.m * vec4(1.0, 2.0, 3.0, 4.0);"""
    out = pointwise.run((), body, {"x": np.zeros((2, 1), np.float32)},
                        ("o1", "o2", "o3", "o4", "o5"), structs=(struct,),
                        blocks=(("Probe", "items[2]", struct.pack(records)),))
    for k, r in enumerate(records):
        assert out["o1"][k] == pytest.approx([r["a"], *r["b"]])
        assert out["o2"][k] == pytest.approx([r["c"], *r["d"], 0.0])
        assert out["o3"][k] == pytest.approx(np.asarray(r["e"]).reshape(3, 4)[1])
        assert out["o4"][k] == pytest.approx(np.asarray(r["f"]).reshape(2, 4)[1])
        assert out["o5"][k] == pytest.approx(np.asarray(r["m"]) @ [1, 2, 3, 4], rel=1e-5)


def test_a_broken_shader_names_its_error():
    with pytest.raises(programs.ShaderError) as info:
        pointwise.run((), "o = vec4(no_such_name);", {"x": np.zeros((1, 1), np.float32)},
                      ("o",), key="broken")
    assert "no_such_name" in str(info.value) and "did not compile" in str(info.value)


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN", "AREA"])
def test_incidence_matches_the_kernel(kind):
    n = 4000
    p = RNG.uniform(-3, 3, (n, 3)).astype(np.float32)
    geo = _unit(RNG.normal(size=(n, 3)))
    light = scenes.LIGHTS[kind]
    l_dir, e, lit = shade.light_incidence(light, p, geo)
    out = pointwise.run(("direct",), """
      vec3 l, e;
      bool lit = incidence(lights[0], p.xyz, geo.xyz, l, e);
      l_out = vec4(l, lit ? 1.0 : 0.0);
      e_out = vec4(e, 0.0);""", {"p": p, "geo": geo}, ("l_out", "e_out"),
        structs=(lights.LIGHT,),
        blocks=(("LightData", "lights[1]", lights.light_block([light], [-1])),))
    assert np.array_equal(out["l_out"][:, 3] > 0.5, lit)
    assert np.abs(out["l_out"][:, :3] - l_dir).max() < 1e-6
    assert np.abs(out["e_out"][:, :3] - e).max() <= 1e-5 * np.abs(e).max()


@pytest.mark.parametrize("model", list(shading.MODELS))
def test_every_specular_model_matches_the_kernel(model):
    """The direct BRDF (slide "Black Ops: shading model" and the Black Ops II terms): float32
    on the GPU against the kernel's float64 within a point; the specular power 8192^gloss
    turns a rounding of n.h into a relative error of at most ~1e-3."""
    n = 20000
    normal = _unit(RNG.normal(size=(n, 3)))
    view = _unit(normal + 0.7 * RNG.normal(size=(n, 3)))
    light = _unit(normal + 0.7 * RNG.normal(size=(n, 3)))
    e = RNG.uniform(0, 3, (n, 3)).astype(np.float32)
    vis = RNG.uniform(0, 1, n).astype(np.float32)
    albedo, rf0 = (RNG.uniform(0, 1, (n, 3)).astype(np.float32) for _ in range(2))
    gloss = RNG.uniform(0, 1, n).astype(np.float32)
    diffuse, specular = (np.zeros((n, 3), np.float32) for _ in range(2))
    shade.add_direct(normal, view, light, e, albedo, rf0, gloss, model, diffuse, specular,
                     visibility=vis)
    out = pointwise.run(("direct",), f"""
      vec3 d = vec3(0.0), s = vec3(0.0);
      accumulate(n.xyz, v.xyz, l.xyz, e.xyz, e.w, a.xyz, f.xyz, a.w, {shading.MODELS[model]},
                 d, s);
      dd = vec4(d, 0.0);
      ss = vec4(s, 0.0);""", {"n": normal, "v": view, "l": light,
                              "e": np.column_stack([e, vis]),
                              "a": np.column_stack([albedo, gloss]), "f": rf0},
        ("dd", "ss"), structs=(lights.LIGHT,),
        blocks=(("LightData", "lights[1]", lights.light_block([scenes.LIGHTS["SUN"]], [-1])),))
    assert np.abs(out["dd"][:, :3] - diffuse).max() <= 1e-6 * np.abs(diffuse).max()
    assert np.abs(out["ss"][:, :3] - specular).max() <= 2e-3 * np.abs(specular).max()
    close = np.abs(out["ss"][:, :3] - specular) <= 1e-3 * np.abs(specular) + 1e-6
    assert close.mean() > 0.999


def _casters() -> np.ndarray:
    ground = np.array([[[-5, -5, 0], [5, -5, 0], [5, 5, 0]], [[-5, -5, 0], [5, 5, 0],
                                                              [-5, 5, 0]]], np.float32)
    return np.concatenate([ground, scenes.box([-0.5, -0.5, 0.3], [0.5, 0.5, 1.3]),
                           scenes.box([1, 1, 0], [1.4, 1.6, 2.0])])


SHADOW_LIGHTS = {
    "point": Light("POINT", np.ones(3), position=np.array([0.3, -0.4, 3.0]), radius=0.25),
    "point_hard": Light("POINT", np.ones(3), position=np.array([0.3, -0.4, 3.0]), radius=0.0),
    "spot": Light("SPOT", np.ones(3), position=np.array([-2, 1, 4.0]),
                  direction=_unit(np.array([[0.4, -0.2, -1]]))[0], radius=0.1, spot_size=1.4),
    "sun": Light("SUN", np.ones(3), direction=_unit(np.array([[0.3, 0.5, -1]]))[0],
                 radius=np.radians(3)),
    "area": Light("AREA", np.ones(3), position=np.array([2.3, -1.4, 2.5]),
                  direction=np.array([0, 0, -1.0]), size=np.array([0.5, 0.3])),
}


def shadow_points(n: int = 20000):
    """(n, 3) points on the ground, the box's top and a slope, their normals, rotation seeds."""
    pts = np.column_stack([RNG.uniform(-3, 3, n), RNG.uniform(-3, 3, n), np.zeros(n)])
    pts[:n // 4, 2] = 1.3  # on the box's top, and a slope
    pts[:n // 4, :2] = RNG.uniform(-0.5, 0.5, (n // 4, 2))
    normals = np.tile(np.float32([0, 0, 1]), (n, 1))
    normals[n // 2:] = _unit(np.array([[0.3, 0.2, 1.0]]))
    return pts.astype(np.float32), normals, RNG.integers(0, 2**32, (n, 3), dtype=np.uint32)


def gpu_visibility(shadow_set, pts, normals, seeds) -> np.ndarray:
    """The GPU filter's visibility of map 0 of ``shadow_set`` at the points."""
    return pointwise.run(("shadow_filter",), """
      vis = vec4(shadow_visibility(0, p.xyz, n.xyz, floatBitsToUint(seed.xyz)));""",
        {"p": pts, "n": normals, "seed": seeds.view(np.float32)}, ("vis",),
        defines=lights.filter_defines(), structs=(lights.SHADOW,),
        prelude=lights.filter_prelude(),
        blocks=(("ShadowData", "shadows[1]", shadow_set.block),),
        samplers=shadow_set.samplers())["vis"][:, 0]


@pytest.mark.parametrize("name", list(SHADOW_LIGHTS))
def test_shadow_filter_matches_the_kernel(name):
    """PCF and PCSS with the pyramid tests (``shadow_filter``), every map kind: the GPU reads
    the very maps the CPU built and gives the kernel's visibility at the same points and
    seeds (float32 in the kernel's order: equal where the GPU rounds as the CPU does)."""
    cam = Camera(scenes.look_at(np.array([6.0, -6.0, 4.0]), [0, 0, 0.5]),
                 scenes.perspective(1.5, 16 / 9), 320, 180)
    light = SHADOW_LIGHTS[name]
    smap = shadows.build_shadow_map(light, _casters(), cam, resolution=512)
    pts, normals, seeds = shadow_points()
    cpu = shadow_filter.shadow_visibility(smap, pts, normals, seeds=seeds)
    assert 0.05 < (cpu < 1).mean() < 0.95 and ((cpu > 0) & (cpu < 1)).sum() > 100
    out = gpu_visibility(lights.shadow_set([smap]), pts, normals, seeds)
    diff = np.abs(out - cpu)
    assert diff.mean() < 1e-4 and (diff > 1 / 16).mean() < 1e-3


DC = np.eye(9, 3)[:, :1] * np.ones(3)


def _chain(size):
    out = []
    while size >= 1:
        out.append(RNG.uniform(0.05, 2.0, (6, size, size, 3)).astype(np.float32))
        size //= 2
    return out


def _moments(count):
    """Depth moments (count, 6, 4, 4, 2) of ``count`` samples: means 0.2-3 m, variances to
    0.3 m^2."""
    mean = RNG.uniform(0.2, 3.0, (count, 6, 4, 4))
    return np.stack([mean, mean * mean + RNG.uniform(0, 0.3, mean.shape)], -1).astype(
        np.float32)


def _probes(world_color: bool, volumes: bool):
    """Three overlapping reflection probes (with sphere and box proxies when ``volumes``), a
    world chain or colour, and an irradiance volume with validity, biases and depth moments
    plus a bounce volume."""
    from bo2_lighting.addon.core.lighting import probes as cp

    refl = [cp.ReflectionProbe(
        f"P{i}", RNG.uniform(-1, 1, 3), float(RNG.uniform(1, 2)), float(RNG.uniform(0.1, 0.9)),
        {"bo2": _chain(16), "bo1": _chain(8)},
        (RNG.normal(size=(9, 3)) * 0.3 + DC * 2.0).astype(np.float32),
        proxy=("box" if i % 2 else "sphere") if volumes else "none",
        proxy_to_world=np.diag([2.0, 1.5, 1.0, 1.0]) if volumes else None) for i in range(3)]
    world_sh = (RNG.normal(size=(9, 3)) * 0.2 + DC * [1.5, 1.2, 1.0]).astype(np.float32)
    p = cp.Probes(world_sh=world_sh, world_mips={"bo2": _chain(16), "bo1": _chain(8)},
                  world_color=np.float32([0.4, 0.5, 0.6]) if world_color else None,
                  reflection=refl)
    if volumes:
        p.volumes.append(cp.IrradianceVolume(
            "V", np.diag([1.5, 1.5, 1.5, 1.0]), (3, 2, 2),
            (RNG.normal(size=(3, 2, 2, 9, 3)) * 0.2 + 1.0).astype(np.float32), influence=0.5,
            validity=RNG.uniform(0, 1, (3, 2, 2)).astype(np.float32), normal_bias=0.2,
            view_bias=0.1, facing_bias=0.3, moments=_moments(12).reshape(3, 2, 2, 6, 4, 4, 2)))
        p.bounce = cp.IrradianceVolume(
            "B", np.diag([3.0, 3.0, 2.0, 1.0]), (4, 4, 2),
            (RNG.normal(size=(4, 4, 2, 9, 3)) * 0.1 + 0.3).astype(np.float32), influence=0.3)
    return p


@pytest.mark.parametrize("world_color,volumes,normalization,env_model,extrapolate,visibility", [
    (False, False, "none", "bo2", False, False), (False, False, "bo1", "table", False, False),
    (True, False, "bo2", "fit", False, False), (False, True, "bo2", "bo1", False, True),
    (True, True, "bo2", "bo2", True, False), (False, True, "bo1", "table", True, True),
])
def test_indirect_light_matches_the_kernel(world_color, volumes, normalization, env_model,
                                           extrapolate, visibility):
    """The SH irradiance of volumes (held or extrapolated past their outermost samples, with
    or without the samples' visibility test), bounce and world (with the sky's share), and the
    normalized prefiltered reflections of overlapping probes with parallax proxies times the
    environment BRDF (``probes.indirect``): relative difference below 2e-5."""
    from bo2_lighting.addon.core.lighting import probes as cp
    from bo2_lighting.addon.gpu_backend import probes as gpu_probes

    probes = _probes(world_color, volumes)
    n = 20000
    pts = RNG.uniform(-2.5, 2.5, (n, 3)).astype(np.float32)
    normal = _unit(RNG.normal(size=(n, 3)))
    view = _unit(normal + RNG.normal(size=(n, 3)))
    albedo, rf0 = (RNG.uniform(0, 1, (n, 3)).astype(np.float32) for _ in range(2))
    gloss = RNG.uniform(0, 1, n).astype(np.float32)
    sky = RNG.uniform(0, 1, n).astype(np.float32)
    diffuse, specular = cp.indirect(probes, pts, normal, view, albedo, rf0, gloss,
                                    normalization, "bo2", env_model, sky=lambda k: sky[k],
                                    extrapolate=extrapolate, visibility=visibility,
                                    nearest=True)
    if visibility:  # the test changes the light of some points, not all
        held = cp.indirect(probes, pts, normal, view, albedo, rf0, gloss, normalization, "bo2",
                           env_model, sky=lambda k: sky[k], extrapolate=extrapolate,
                           visibility=False)[0]
        changed = (np.abs(held - diffuse) > 1e-3 * np.abs(diffuse).max()).any(1).mean()
        assert 0.05 < changed < 0.95, changed
    drawn = gpu_probes.indirect_set(probes, normalization, "bo2", env_model, extrapolate,
                                    visibility, nearest=True)
    out = pointwise.run(("direct", "indirect"), """
      vec3 psh[9];
      pixel_sh(p.xyz, n.xyz, v.xyz, p.w, psh);
      vec3 d, s;
      indirect_light(p.xyz, n.xyz, v.xyz, a.xyz, f.xyz, a.w, psh, p.w, d, s);
      od = vec4(d, 0.0);
      os = vec4(s, 0.0);""",
        {"p": np.column_stack([pts, sky]), "n": normal, "v": view,
         "a": np.column_stack([albedo, gloss]), "f": rf0}, ("od", "os"),
        defines=gpu_probes.defines(), prelude=gpu_probes.prelude(),
        structs=(lights.LIGHT, gpu_probes.INDIRECT, gpu_probes.REFLECTION, gpu_probes.VOLUME),
        blocks=drawn.blocks() + (("LightData", "lights[1]", bytes(64)),),
        samplers=drawn.samplers())
    assert np.abs(out["od"][:, :3] - diffuse).max() <= 2e-5 * np.abs(diffuse).max()
    assert np.abs(out["os"][:, :3] - specular).max() <= 2e-5 * np.abs(specular).max()


@pytest.mark.parametrize("dtype,channels,extension,interpolation", [
    ("float", 3, "REPEAT", "Linear"), ("uint8", 4, "REPEAT", "Cubic"),
    ("uint8", 3, "MIRROR", "Linear"), ("float", 1, "EXTEND", "Closest"),
    ("uint8", 4, "CLIP", "Linear"), ("float", 4, "MIRROR", "Cubic"),
])
def test_texture_look_ups_match_the_kernel(dtype, channels, extension, interpolation):
    """``texture.sample``: every extension and filter, sRGB 8-bit codes (their decoded mip
    levels too) and float texels, level 0 and trilinear levels of detail, associated alpha:
    relative difference below 2e-4 (an alpha near 0 divides its rounding)."""
    from bo2_lighting.addon.core.formulas import texture as core_texture
    from bo2_lighting.addon.gpu_backend import images

    image = RNG.uniform(0, 1, (37, 53, channels)).astype(np.float32)
    if dtype == "uint8":
        image = (image * 255).astype(np.uint8)
    tex = core_texture.make_texture(image if channels > 1 else image[..., 0], srgb=True,
                                    extension=extension, interpolation=interpolation)
    n = 20000
    uv = RNG.uniform(-1.5, 2.5, (n, 2)).astype(np.float32)
    lod = RNG.uniform(0, 7, n).astype(np.float32)
    record, texels = images.upload(tex)
    table = images.srgb_table()
    for use_lod in (False, True):
        for associate in ((0, 1, 2) if channels == 4 else (0,)):
            cpu = core_texture.sample(tex, uv, lod if use_lod else None, associate)
            out = pointwise.run(("texture",), f"""
              o = texture_sample(0, texels, uv.xy, {"uv.z" if use_lod else "-1.0"}, {associate});
              """, {"uv": np.column_stack([uv, lod])}, ("o",), structs=(images.IMAGE,),
                blocks=(("ImageData", "images[1]", images.IMAGE.pack([record])),),
                samplers=(("FLOAT_2D", "texels", texels), ("FLOAT_2D", "srgb_table", table)))
            error = np.abs(out["o"][:, :channels] - cpu).max() / np.abs(cpu).max()
            assert error <= 2e-4, (use_lod, associate, error)
