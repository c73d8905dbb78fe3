"""Direct lighting kernels against the talk's formulas in NumPy.

- ``accumulate``: ``brdf.direct_brdf`` evaluated in float64 (the readable reference of the
  talk's terms) times the irradiance, every model, random points with lights above and below
  the horizon, gloss 0 to 1: relative difference below 2e-6 (the kernel rounds to float32);
- ``incidence``: Blender's light units written out here (point and spot P / (4 pi d^2), the
  spot's smoothstep cone, sun S, area P cos / (pi d^2)), in float64: relative 1e-6 (1e-5 for
  the spot, whose cone edge amplifies the last bits).
"""

import math

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import brdf
from bo2_lighting.addon.core.lighting import shade
from bo2_lighting.addon.core.scene import Light

RNG = np.random.default_rng(21)


def unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


@pytest.mark.parametrize("model", brdf.MODELS)
def test_accumulate_matches_direct_brdf(model):
    n_pts = 4000
    n = unit(RNG.normal(size=(n_pts, 3)))
    v = unit(n + RNG.normal(size=(n_pts, 3)) * 0.8)
    l_dir = unit(RNG.normal(size=(n_pts, 3)))  # half of them below the horizon
    albedo = RNG.random((n_pts, 3))
    rf0 = RNG.random((n_pts, 3))
    gloss = RNG.random(n_pts)
    gloss[:50] = [0.0, 1.0] * 25
    e = RNG.random((n_pts, 3)) * 5.0
    vis = np.random.default_rng(3).random(n_pts).astype(np.float32)  # RNG kept for the others
    vis[:20] = 0.0
    diffuse = np.zeros((n_pts, 3), np.float32)
    specular = np.zeros((n_pts, 3), np.float32)
    args = [a.astype(np.float32) for a in (n, v, l_dir, e, albedo, rf0, gloss)]
    shade.add_direct(*args[:4], *args[4:], model, diffuse, specular)
    shade.add_direct(*args[:4], *args[4:], model, diffuse, specular, visibility=vis)  # it adds
    d_ref, s_ref = brdf.direct_brdf(*(a.astype(np.float64) for a in args[:3]),
                                    args[4].astype(np.float64), args[5].astype(np.float64),
                                    args[6].astype(np.float64), model=model)
    e64 = args[3].astype(np.float64) * (1.0 + vis[:, None].astype(np.float64))
    np.testing.assert_allclose(diffuse, d_ref * e64, rtol=2e-6, atol=1e-12)
    np.testing.assert_allclose(specular, s_ref * e64, rtol=2e-6, atol=1e-12)
    assert (diffuse[(n * l_dir).sum(-1) <= 0] == 0).all()


def reference_incidence(light, p, geo):
    """Blender's light units (shade's module docstring), in float64."""
    color = np.asarray(light.color, np.float64)
    axis = np.asarray(light.direction, np.float64)
    if light.kind == "SUN":
        l_dir = np.broadcast_to(-axis, p.shape)
        scale = np.ones(len(p))
    else:
        d = np.asarray(light.position, np.float64) - p
        dist = np.linalg.norm(d, axis=-1)
        l_dir = d / dist[:, None]
        cos_axis = -(l_dir @ axis)
        if light.kind == "AREA":
            scale = np.maximum(cos_axis, 0.0) / (math.pi * dist**2)
        else:
            scale = 1.0 / (4.0 * math.pi * dist**2)
            if light.kind == "SPOT":
                c = math.cos(light.spot_size / 2)
                x = np.clip((cos_axis - c) / ((1.0 - c) * light.spot_blend), 0.0, 1.0)
                scale = scale * x * x * (3.0 - 2.0 * x)
    lit = ((geo * l_dir).sum(-1) > 0) & (scale > 0)
    return l_dir, scale[:, None] * color * lit[:, None], lit


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN", "AREA"])
def test_incidence_matches_the_light_units(kind):
    p = RNG.uniform(-2.0, 2.0, (3000, 3))
    geo = unit(RNG.normal(size=(3000, 3)))
    axis = unit(np.array([0.1, -0.2, -1.0])).astype(np.float32).astype(np.float64)  # as stored
    light = Light(kind, color=np.array([100.0, 50.0, 10.0]), position=np.array([0.3, 0.2, 3.0]),
                  direction=axis, spot_size=math.radians(70), spot_blend=0.3)
    l_dir, e, lit = shade.light_incidence(light, p.astype(np.float32), geo.astype(np.float32))
    l_ref, e_ref, lit_ref = reference_incidence(light, p.astype(np.float32).astype(np.float64),
                                                geo.astype(np.float32).astype(np.float64))
    assert 0 < lit.sum() < len(p) and (lit == lit_ref).mean() > 0.999
    both = lit & lit_ref
    np.testing.assert_allclose(l_dir, l_ref, rtol=1e-6, atol=1e-7)
    # the spot's smoothstep near its cone's edge amplifies the last bits of cos(theta) - cos
    np.testing.assert_allclose(e[both], e_ref[both], rtol=1e-5 if kind == "SPOT" else 1e-6)
    assert (e[~lit] == 0).all()


def test_surface_is_its_numpy_construction_bit_for_bit():
    """Position, normals turned towards the camera and UV of camera samples: the NumPy
    construction they replaced (interpolation by the weights, the geometric normal by the cross
    product, normalized), bit for bit: the shadow filter hashes the position's bits."""
    from bo2_lighting.addon.core.kernels import shading
    from bo2_lighting.addon.core.scene import Camera

    t_count, m = 50, 3000
    positions = RNG.uniform(-1.0, 1.0, (t_count, 3, 3)).astype(np.float32)
    normals = unit(RNG.normal(size=(t_count, 3, 3))).astype(np.float32)
    uvs = RNG.random((t_count, 3, 2)).astype(np.float32)
    tri = RNG.integers(0, t_count, m).astype(np.int32)
    bary = RNG.dirichlet([1.0, 1.0, 1.0], m).astype(np.float32)
    cam = Camera.look_at([0.5, -6.0, 2.0], [0.0, 0.0, 0.0], math.radians(40), 320, 200)
    v = -cam.rays(RNG.uniform(0, 320, m), RNG.uniform(0, 200, m))[1]
    out = [np.empty((m, 3), np.float32) for _ in range(3)] + [np.empty((m, 2), np.float32)]
    shading.surface(tri, bary, positions, normals, uvs, v, *out)
    p, n, geo, uv = out
    corners = positions[tri]
    ref_p = np.einsum("nk,nkc->nc", bary, corners)
    ref_n = np.einsum("nk,nkc->nc", bary, normals[tri])
    ref_n /= np.maximum(np.linalg.norm(ref_n, axis=-1, keepdims=True), 1e-20)
    ref_geo = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    ref_geo /= np.maximum(np.linalg.norm(ref_geo, axis=-1, keepdims=True), 1e-30)
    back = np.sum(ref_geo * v, -1) < 0
    assert 0 < back.sum() < m
    ref_n[back] *= -1.0
    ref_geo[back] *= -1.0
    np.testing.assert_array_equal(p, ref_p)
    np.testing.assert_array_equal(n, ref_n)
    np.testing.assert_array_equal(geo, ref_geo)
    np.testing.assert_array_equal(uv, np.einsum("nk,nkc->nc", bary, uvs[tri]))


def reference_rays(cam, x, y):
    """Camera rays as the NumPy the kernel replaced computed them."""
    inv = np.linalg.inv(cam.projection @ cam.world_to_camera)
    sx, sy = 2.0 / cam.width, -2.0 / cam.height
    x = np.asarray(x, np.float64)[:, None]
    y = np.asarray(y, np.float64)[:, None]
    ends = []
    for z in (-1.0, 1.0):
        c = inv @ np.array([-1.0, 1.0, z, 1.0])
        h = x * (sx * inv[:, 0]) + y * (sy * inv[:, 1]) + c
        ends.append(h[:, :3] / h[:, 3:])
    d = ends[1] - ends[0]
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return ends[0].astype(np.float32), d.astype(np.float32)


def test_camera_rays_bit_for_bit():
    from bo2_lighting.addon.core.scene import Camera

    persp = Camera.look_at([0.5, -6.0, 2.0], [0.0, 0.0, 0.0], math.radians(40), 320, 200)
    ortho = Camera(persp.world_to_camera, np.diag([0.2, 0.3, -0.01, 1.0]), 320, 200, True)
    x, y = RNG.uniform(-5, 325, 5000), RNG.uniform(-5, 205, 5000)
    for cam in (persp, ortho):
        origins, directions = cam.rays(x, y)
        ref_o, ref_d = reference_rays(cam, x, y)
        np.testing.assert_array_equal(origins, ref_o)
        np.testing.assert_array_equal(directions, ref_d)


def test_splat_and_compose_place_every_value():
    from bo2_lighting.addon.core.kernels import shading
    from bo2_lighting.addon.core.render.passes import SAMPLED, SAMPLED_WIDTH

    m = 500
    p, n, diff, spec, dind, gind, emit, alb, rf0 = (
        RNG.random((m, 3)).astype(np.float32) for _ in range(9))
    uv = RNG.random((m, 2)).astype(np.float32)
    has_uv = RNG.random(m) < 0.5
    gloss = RNG.random(m).astype(np.float32)
    out = np.full((m, SAMPLED_WIDTH), np.nan, np.float32)
    cols = np.array([SAMPLED[name].start for name in shading.COMPOSED], np.int64)
    shading.compose(out, cols, n, p, uv, has_uv, diff, spec, dind, gind, emit, alb, rf0, gloss)
    mine = np.ones(SAMPLED_WIDTH, bool)
    for name in ("AO", "Lightmap", "Lightmap Texels", "Shadow Catcher"):  # the pipeline's
        mine[SAMPLED[name]] = False
    assert np.isfinite(out[:, mine]).all()  # every other column written
    expect = {"Normal": n, "Position": p, "DiffDir": diff, "GlossDir": spec, "DiffInd": dind,
              "GlossInd": gind, "Emit": emit, "Albedo": alb, "Specular Color": rf0,
              "Gloss": gloss[:, None],
              "Combined": np.concatenate([diff + spec + dind + gind + emit, np.ones((m, 1))], 1),
              "UV": np.concatenate([uv, np.ones((m, 1))], 1) * has_uv[:, None]}
    for name, value in expect.items():
        np.testing.assert_allclose(out[:, SAMPLED[name]], value, rtol=1e-6, err_msg=name)
    # splat: weighted sums per pixel, by hand
    pixel = RNG.integers(0, 40, m)
    weight = RNG.integers(1, 5, m).astype(np.float32)
    acc = np.zeros((40, SAMPLED_WIDTH), np.float32)
    shading.splat(acc, pixel, weight, out)
    ref = np.zeros((40, SAMPLED_WIDTH))
    np.add.at(ref, pixel, weight[:, None].astype(np.float64) * out)
    np.testing.assert_allclose(acc, ref, rtol=1e-5)


def test_plane_hits_give_the_ray_differentials_of_uv_derivatives():
    """The barycentrics where the neighbouring pixels' rays meet the triangle's plane
    (``plane_hits``, what the material programs' screen steps use) give the UV steps of
    ``texture.uv_derivatives`` (the NumPy reference, Igehy 1999)."""
    from bo2_lighting.addon.core.formulas import texture
    from bo2_lighting.addon.core.kernels import shading
    from bo2_lighting.addon.core.scene import Camera

    cam = Camera.look_at((0.3, -4.0, 2.5), (0.0, 0.0, 0.0), math.radians(40.0), 64, 48)
    n = 300
    tris = RNG.uniform(-2.0, 2.0, (n, 3, 3)).astype(np.float32)
    uvs = RNG.uniform(0.0, 1.0, (n, 3, 2)).astype(np.float32)
    bary = RNG.dirichlet((2.0, 2.0, 2.0), n).astype(np.float32)
    points = np.einsum("nk,nkc->nc", bary, tris).astype(np.float32)
    clip = np.c_[points, np.ones(n)] @ (cam.projection @ cam.world_to_camera).T
    x = (clip[:, 0] / clip[:, 3] * 0.5 + 0.5) * cam.width
    y = (0.5 - clip[:, 1] / clip[:, 3] * 0.5) * cam.height
    index = np.arange(n, dtype=np.int32)
    expected = texture.uv_derivatives(tris, uvs, points, *cam.rays(x + 1, y),
                                      *cam.rays(x, y + 1))
    for axis, reference in enumerate(expected):
        origin, direction = cam.rays(x + (axis == 0), y + (axis == 1))
        b, q = np.empty((n, 3), np.float32), np.empty((n, 3), np.float32)
        shading.plane_hits(index, tris, origin, direction, b, q)
        step = np.einsum("nk,nkc->nc", b - bary, uvs)
        ok = np.abs(reference).max(axis=1) < texture.DEGENERATE_DUV
        assert ok.mean() > 0.9
        np.testing.assert_allclose(step[ok], reference[ok], rtol=2e-3, atol=2e-5)
