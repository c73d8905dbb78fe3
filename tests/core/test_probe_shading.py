"""Indirect light from probes (core/lighting/probes.py): irradiance volumes, blending,
normalization.

Values are checked against closed forms: the irradiance of a constant environment is pi L, of
the SH of one direction the clamped-cosine convolution; the normalizations against the
formulas of slides "Black Ops: normalization algorithm" and "Improved normalization
algorithm" evaluated by hand."""

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import cubemap, env_brdf, sh
from bo2_lighting.addon.core.lighting import probes as cp
from bo2_lighting.addon.core.lighting.world_probes import filtered, world_cube
from bo2_lighting.addon.core.scene import World


def constant_probes(radiance):
    world_sh, mips = filtered(world_cube(World(color=np.float32(radiance)), 16))
    return cp.Probes(world_sh=world_sh, world_mips=mips)


def test_constant_world_lights_a_lambert_surface_by_pi_l():
    """A white Lambert surface under a uniform sky of radiance L reflects L (E = pi L)."""
    probes = constant_probes([0.5, 1.0, 2.0])
    n = np.array([[0, 0, 1], [1, 0, 0], [0, -1, 0]], np.float32)
    diffuse, specular = cp.indirect(probes, np.zeros((3, 3), np.float32), n, n,
                                    np.ones((3, 3), np.float32), np.zeros((3, 3), np.float32),
                                    np.full(3, 0.5, np.float32))
    np.testing.assert_allclose(diffuse, [[0.5, 1.0, 2.0]] * 3, rtol=2e-3)
    assert np.abs(specular).max() < 1e-3  # rf0 = 0 and n.v = 1: the environment BRDF's a0 ~ 0


def test_specular_is_environment_times_environment_brdf():
    probes = constant_probes([1.0, 1.0, 1.0])
    n = np.array([[0, 0, 1]], np.float32)
    v = np.array([[0.6, 0, 0.8]], np.float32)
    rf0 = np.array([[1.0, 0.5, 0.04]], np.float32)
    gloss = np.array([0.7], np.float32)
    for model in ("bo1", "bo2", "fit", "table"):
        _, spec = cp.indirect(probes, np.zeros((1, 3), np.float32), n, v, rf0 * 0, rf0, gloss,
                              normalization="none", env_brdf=model)
        expected = env_brdf.environment_brdf(0.7, 0.8, rf0[0], model)
        np.testing.assert_allclose(spec[0], expected, rtol=2e-3)


def test_volume_trilinear_blend_and_influence():
    res = (2, 1, 1)
    coeffs = np.zeros((2, 1, 1, 9, 3), np.float32)
    coeffs[0, 0, 0, 0] = 1.0  # left sample: constant radiance (0.282095 ... ) of 1/(2 sqrt pi)
    coeffs[1, 0, 0, 0] = 3.0
    vol = cp.IrradianceVolume("V", np.diag([2.0, 1.0, 1.0, 1.0]), res, coeffs, influence=1.0)
    # samples at local x = -0.5 and +0.5, world x = -1 and +1
    pts = np.array([[-1, 0, 0], [0, 0, 0], [1, 0, 0], [2.5, 0, 0], [3.5, 0, 0]], np.float32)
    # trilinear between the samples, held beyond them
    np.testing.assert_allclose(vol.sample_sh(pts)[:, 0, 0], [1.0, 2.0, 3.0, 3.0, 3.0], rtol=1e-6)
    # extrapolated to the box's face (x = 2), held beyond it
    np.testing.assert_allclose(vol.sample_sh(pts, extrapolate=True)[:, 0, 0],
                               [1.0, 2.0, 3.0, 4.0, 4.0], rtol=1e-6)
    # toward x = -2 the field 2 + x falls to 0: it stops at half the sample's
    edge = np.array([[-1.25, 0, 0], [-1.5, 0, 0], [-2.0, 0, 0]], np.float32)
    np.testing.assert_allclose(vol.sample_sh(edge, extrapolate=True)[:, 0, 0], [0.75, 0.5, 0.5],
                               rtol=1e-6)
    # weight 1 inside the box (|x| <= 2); outside, Blender's rule: Distance in local units
    # (x is scaled by 2: 1 local unit = 2 m), fading linearly over all of it (Falloff 1)
    np.testing.assert_allclose(vol.weight(pts), [1, 1, 1, 0.75, 0.25], atol=1e-6)
    # Falloff 0.5: full weight over the first half of the Distance, 0 at its end
    vol.falloff = 0.5
    far = np.array([[2.5, 0, 0], [3.5, 0, 0], [4.0, 0, 0], [0, 1.5, 0], [0, 1.75, 0]],
                   np.float32)
    np.testing.assert_allclose(vol.weight(far), [1, 0.5, 0, 1, 0.5], atol=1e-6)
    positions = cp.volume_sample_positions(vol.local_to_world, res)
    np.testing.assert_allclose(positions.reshape(-1, 3), [[-1, 0, 0], [1, 0, 0]], atol=1e-12)


def test_volume_look_up_reproduces_a_linear_field_up_to_the_box():
    """Light of one directional shape whose strength varies linearly in space (SH = (a + b . x)
    times a fixed SH) is read back exactly anywhere in the box, up to its faces half a cell
    beyond the outermost samples, and beyond the box as at its nearest point."""
    rng = np.random.default_rng(11)
    m = np.diag([2.0, 1.0, 1.5, 1.0])
    m[:3, 3] = (0.5, -1.0, 0.25)
    res = (5, 3, 4)
    positions = cp.volume_sample_positions(m, res)
    shape = rng.uniform(-0.3, 0.3, (9, 3))
    shape[0] = (1.0, 0.8, 0.6)
    b = rng.uniform(-0.15, 0.15, 3)
    field = lambda x: (2.0 + (x - m[:3, 3]) @ b)[:, None, None] * shape  # noqa: E731
    coeffs = field(positions.reshape(-1, 3)).reshape(*res, 9, 3).astype(np.float32)
    vol = cp.IrradianceVolume("V", m, res, coeffs)
    local = rng.uniform(-1.0, 1.0, (500, 3))
    inside = local @ m[:3, :3].T + m[:3, 3]
    np.testing.assert_allclose(vol.sample_sh(inside, extrapolate=True), field(inside), rtol=1e-4,
                               atol=1e-6)
    beyond = local * rng.uniform(1.0, 2.0, (500, 1)) / np.abs(local).max(1, keepdims=True)
    face = np.clip(beyond, -1.0, 1.0) @ m[:3, :3].T + m[:3, 3]
    np.testing.assert_allclose(vol.sample_sh(beyond @ m[:3, :3].T + m[:3, 3], extrapolate=True),
                               field(face), rtol=1e-4, atol=1e-6)


def test_reflection_probe_weight_falls_off_at_its_radius():
    probe = cp.ReflectionProbe("R", np.zeros(3), radius=2.0, falloff=0.25, mips={}, sh=None)
    d = np.array([[0, 0, 0], [1.5, 0, 0], [1.75, 0, 0], [2.0, 0, 0], [3, 0, 0]], np.float32)
    np.testing.assert_allclose(probe.weight(d), [1, 1, 0.5, 0, 0], atol=1e-6)


def directional_sh(direction, power=1.0, ambient=0.1):
    """SH of a narrow light of ``power`` from ``direction`` plus a uniform ``ambient``."""
    d = np.asarray(direction, np.float64)[None]
    coeffs = np.repeat(sh.basis(d)[0][:, None] * power, 3, 1)
    coeffs[0] += 2.0 * np.sqrt(np.pi) * ambient
    return coeffs.astype(np.float32)


def test_normalizations_follow_the_slides():
    """A probe lit from above; the pixel's own lighting has that light blocked (in shadow).

    BO1 (slide "Black Ops: normalization algorithm") scales by the ratio of the SH constant
    terms, the same for every normal. BO2 (slide "Improved normalization algorithm") scales by
    the ratio of directional irradiance at the normal: reflections on surfaces facing the
    blocked light darken much more than on surfaces facing away, where BO1 darkens both alike.
    """
    lit = directional_sh([0, 0, 1], power=4.0)
    shadowed = directional_sh([0, 0, 1], power=0.0)
    size = 8
    mips = [np.ones((6, size >> m, size >> m, 3), np.float32) for m in range(4)]
    probe = cp.ReflectionProbe("R", np.zeros(3), 10.0, 0.1, {"bo2": mips, "bo1": mips}, lit)
    shadow_volume = cp.IrradianceVolume("V", np.eye(4) * 10, (1, 1, 1),
                                        shadowed.reshape(1, 1, 1, 9, 3), influence=1.0)
    # a black world: the pixel's lighting is the volume's alone (the world's is added to it)
    probes = cp.Probes(world_sh=lit * 0.0, world_mips={"bo2": mips, "bo1": mips},
                       reflection=[probe], volumes=[shadow_volume])
    normals = np.array([[0, 0, 1], [0, 0, -1]], np.float32)  # facing the light, facing away
    pts = np.zeros((2, 3), np.float32)
    args = (np.zeros((2, 3), np.float32), np.ones((2, 3), np.float32),
            np.full(2, 0.5, np.float32))
    spec = {}
    for norm in cp.NORMALIZATIONS:
        _, spec[norm] = cp.indirect(probes, pts, normals, normals, *args, normalization=norm,
                                    env_brdf="table")
    e = env_brdf.environment_brdf(0.5, 1.0, 1.0, "table")
    np.testing.assert_allclose(spec["none"], e, rtol=1e-5)  # the cube map is 1 everywhere
    # BO1: pixel DC / probe DC, for both normals
    dc = shadowed[0, 0] / lit[0, 0]
    np.testing.assert_allclose(spec["bo1"], e * dc, rtol=1e-4)
    # BO2: pixel irradiance at n / probe's (tinted scalar) irradiance at n
    pixel_e = sh.irradiance(shadowed, normals)
    scalar, tint = sh.to_tinted(lit)
    probe_e = sh.tinted_irradiance(scalar, tint, normals)
    np.testing.assert_allclose(spec["bo2"], e * pixel_e / probe_e, rtol=1e-3)
    facing, away = spec["bo2"][:, 0]
    assert facing < 0.5 * spec["bo1"][0, 0] and away > spec["bo1"][1, 0]


def test_normalization_is_bounded_and_names_are_checked():
    dark = np.zeros((9, 3), np.float32)
    mips = [np.ones((6, 4 >> m, 4 >> m, 3), np.float32) for m in range(3)]
    bright = directional_sh([0, 0, 1], power=0.0, ambient=100.0)
    probes = cp.Probes(world_sh=dark, world_mips={"bo2": mips, "bo1": mips},
                       volumes=[cp.IrradianceVolume("V", np.eye(4) * 5, (1, 1, 1),
                                                    bright.reshape(1, 1, 1, 9, 3))])
    n = np.array([[0, 0, 1]], np.float32)
    _, spec = cp.indirect(probes, np.zeros((1, 3), np.float32), n, n, n * 0, n * 0 + 1,
                          np.array([1.0], np.float32), normalization="bo2", env_brdf="table")
    e = env_brdf.environment_brdf(1.0, 1.0, 1.0, "table")
    np.testing.assert_allclose(spec[0], e * cp.MAX_NORMALIZATION, rtol=1e-5)
    with pytest.raises(ValueError, match="unknown normalization"):
        cp.indirect(probes, np.zeros((1, 3), np.float32), n, n, n, n, np.ones(1, np.float32),
                    normalization="bo3")
    with pytest.raises(ValueError, match="unknown prefilter"):
        cp.indirect(probes, np.zeros((1, 3), np.float32), n, n, n, n, np.ones(1, np.float32),
                    prefilter="bo3")


def test_world_cube_follows_the_equirect_mapping():
    """A world texture that is bright only around +Y lights the +Y face of the cube."""
    from bo2_lighting.addon.core.formulas import texture

    h, w = 64, 128
    img = np.zeros((h, w, 3), np.float32)
    # u = 0.5 - atan2(y, x) / 2pi: +Y (atan2 = pi/2) is u = 0.25
    img[:, int(0.2 * w):int(0.3 * w)] = 1.0
    world = World(texture=texture.make_texture(img, srgb=False), strength=2.0)
    cube = world_cube(world, 16)
    plus_y = 2  # face order +X, -X, +Y, -Y, +Z, -Z
    assert cube[plus_y, 8, 8].min() > 1.9 and cube[plus_y - 1].max() == 0.0
    assert cubemap.FACES[plus_y][0].tolist() == [0, 1, 0]
    # A Mapping rotation of 90 degrees about Z (x -> y): the +X face now reads the +Y band.
    world.rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    turned = world_cube(world, 16)
    assert turned[0, 8, 8].min() > 1.9 and turned[plus_y, 8, 8].max() == 0.0


def _direction_coded_probes(proxy, proxy_to_world, size=64):
    """One reflection probe at the origin whose radiance along d is 0.5 d + 0.5 (so a look-up
    tells the direction it read), reaching every test point, and a black world."""
    cube = (0.5 * cubemap.texel_directions(size) + 0.5).astype(np.float32)
    chains = {"bo2": [cube], "bo1": [cube]}
    probe = cp.ReflectionProbe("P", np.zeros(3), radius=50.0, falloff=0.1, mips=chains,
                               sh=np.zeros((9, 3), np.float32), proxy=proxy,
                               proxy_to_world=proxy_to_world)
    black = [np.zeros((6, 4, 4, 3), np.float32)]
    return cp.Probes(world_sh=np.zeros((9, 3), np.float32),
                     world_mips={"bo2": black, "bo1": black}, reflection=[probe])


def _march(p, r, inside, step=1e-4):
    """Where the ray p + t r leaves the region ``inside`` (a predicate), by small steps: the
    reference the closed-form parallax correction is held to."""
    x = np.array(p, np.float64)
    r = np.asarray(r, np.float64)
    while inside(x):
        x = x + step * r
    return x


@pytest.mark.parametrize("proxy", ["sphere", "box"])
def test_parallax_proxy_reads_where_the_reflection_leaves_the_room(proxy):
    half = np.array([2.0, 1.5, 1.0])
    m = np.diag([*half, 1.0])
    if proxy == "sphere":
        def inside(x):
            return np.sum((x / half) ** 2) < 1.0
    else:
        def inside(x):
            return np.max(np.abs(x) / half) < 1.0
    probes = _direction_coded_probes(proxy, m)
    n = np.array([[0.0, 0.0, 1.0]] * 3, np.float32)
    v = np.array([[0.3, 0.5, 0.8], [-0.6, 0.2, 0.77], [0.1, -0.9, 0.42]], np.float32)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    p = np.array([[0.5, -0.6, 0.3], [-1.2, 0.4, -0.5], [1.0, 0.9, 0.0]], np.float32)
    rf0, gloss = np.ones((3, 3), np.float32), np.ones(3, np.float32)
    _, spec = cp.indirect(probes, p, n, v, rf0 * 0, rf0, gloss, normalization="none",
                          env_brdf="table")
    nv = np.sum(n * v, axis=1)
    r = 2 * nv[:, None] * n - v
    e = env_brdf.environment_brdf(1.0, nv, 1.0, "table")
    for i in range(3):
        hit = _march(p[i], r[i], inside)
        d = hit / np.linalg.norm(hit)
        np.testing.assert_allclose(spec[i] / e[i], 0.5 * d + 0.5, atol=4e-3)
        assert np.abs(spec[i] / e[i] - (0.5 * r[i] + 0.5)).max() > 0.05  # not the plain lookup
    # a point on the proxy's surface (a floor on its bottom face) is corrected like one inside
    floor = np.array([[0.4, -0.3, -1.0]], np.float32)
    if proxy == "sphere":
        floor = np.array([[0.0, 0.0, -1.0]], np.float32)
    _, spec = cp.indirect(probes, floor, n[:1], v[:1], rf0[:1] * 0, rf0[:1], gloss[:1],
                          normalization="none", env_brdf="table")
    hit = _march(floor[0] + 1e-4 * r[0], r[0], inside)
    np.testing.assert_allclose(spec[0] / e[0], 0.5 * hit / np.linalg.norm(hit) + 0.5, atol=4e-3)
    # a point outside its proxy, the reflection leaving it behind, reads along the reflection
    far = np.array([[0.0, 0.0, 3.0]], np.float32)
    _, spec = cp.indirect(probes, far, n[:1], v[:1], rf0[:1] * 0, rf0[:1], gloss[:1],
                          normalization="none", env_brdf="table")
    np.testing.assert_allclose(spec[0] / e[0], 0.5 * r[0] + 0.5, atol=4e-3)


def test_the_gpu_names_volumes_too_large_for_its_depth_texture():
    """The volumes' depth moments (600 texels a sample) go in one texture of at most 16384
    rows of 1024: 27,962 samples; beyond, the GPU path declines with the reason (the frame
    then renders on the CPU)."""
    from bo2_lighting.addon.gpu_backend import probes as gpu_probes

    def volume(res):
        moments = np.broadcast_to(np.float32(1.0), (*res, 6, 8, 8, 2))
        return cp.IrradianceVolume("V", np.eye(4), res, np.zeros((*res, 9, 3), np.float32),
                                   moments=moments)

    probes = constant_probes([1.0, 1.0, 1.0])
    probes.volumes = [volume((30, 30, 31))]  # 27,900 samples
    assert gpu_probes.unsupported(probes) is None
    probes.volumes.append(volume((4, 4, 4)))
    assert "Visibility Test" in gpu_probes.unsupported(probes)
    assert gpu_probes.unsupported(probes, visibility=False) is None
    probes.volumes[1].moments = None  # baked before the test: no depth to upload
    assert gpu_probes.unsupported(probes) is None
