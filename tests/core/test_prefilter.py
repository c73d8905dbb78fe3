"""Prefiltered environment maps: the BO2 cosine-power chain and the BO1 angular-Gaussian chain.

Independent values: brute-force convolutions in float64 over every texel of the finest source,
with texel directions from the documented formula and exact solid angles from the
Van Oosterom-Strackee formula for spherical triangles (the module uses Oehrstroem's area
element); the powers and resolutions of Lazarov 2013 (slides "Black Ops: environment map
pre-filtering" and "Improved environment map pre-filtering"); AMD CubeMapGen's default angles;
lobe second moments from 1D quadrature over the sphere.
"""

import math

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import cubemap, prefilter

TABLE = np.array(
    [
        [[1, 0, 0], [0, -1, 0], [0, 0, 1]],
        [[-1, 0, 0], [0, 1, 0], [0, 0, 1]],
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
        [[0, -1, 0], [-1, 0, 0], [0, 0, 1]],
        [[0, 0, 1], [-1, 0, 0], [0, 1, 0]],
        [[0, 0, -1], [-1, 0, 0], [0, -1, 0]],
    ],
    float,
)


def directions(size):
    """(6 S^2, 3) float64 texel directions from the documented formula, face-major."""
    t = (2.0 * np.arange(size) + 1.0) / size - 1.0
    a = t[None, :, None]
    b = -t[:, None, None]
    out = []
    for f, r, u in TABLE:
        d = f + a * r + b * u
        out.append(d / np.linalg.norm(d, axis=-1, keepdims=True))
    return np.stack(out).reshape(-1, 3)


def solid_angles(size):
    """(6 S^2,) exact texel solid angles: two spherical triangles per texel (Van Oosterom and
    Strackee 1983, tan(Omega / 2) = |a.(b x c)| / (1 + a.b + b.c + c.a))."""
    e = np.linspace(-1.0, 1.0, size + 1)
    corners = np.stack(np.broadcast_arrays(1.0, e[None, :], e[:, None]), -1)
    corners /= np.linalg.norm(corners, axis=-1, keepdims=True)
    p00, p01 = corners[:-1, :-1], corners[:-1, 1:]
    p10, p11 = corners[1:, :-1], corners[1:, 1:]

    def tri(a, b, c):
        num = np.abs(np.einsum("...c,...c->...", a, np.cross(b, c)))
        den = 1.0 + (a * b).sum(-1) + (b * c).sum(-1) + (c * a).sum(-1)
        return 2.0 * np.arctan2(num, den)

    omega = tri(p00, p01, p11) + tri(p00, p11, p10)
    return np.broadcast_to(omega, (6, size, size)).reshape(-1)


def environment(size):
    """(6, S, S, 3) float32: a gradient plus bright caps, one at a cube corner, one across an
    edge, one small and very bright; point-sampled at texel centres."""
    d = directions(size)
    lum = 0.3 + 0.2 * d[:, 0] + 0.1 * d[:, 2]
    caps = [([0.3, 0.5, 0.81], 0.95, 5.0), ([1, 1, 1], 0.98, 8.0), ([-1, 0.02, 0], 0.9, 3.0),
            ([0.1, -1, 0.05], 0.995, 20.0)]
    for centre, cos_radius, boost in caps:
        c = np.array(centre, float) / np.linalg.norm(centre)
        lum = lum + boost * (d @ c > cos_radius)
    rgb = np.stack([lum, 1.5 * lum, 0.5 + 0.1 * d[:, 1]], -1)
    return rgb.reshape(6, size, size, 3).astype(np.float32)


def brute_force(out_dirs, src_dirs, src_omega, values, kernel, chunk=256):
    """sum_d kernel(r.d) L(d) dOmega / sum_d kernel(r.d) dOmega, float64, all texels."""
    values = np.asarray(values, np.float64).reshape(len(src_dirs), -1)
    out = np.empty((len(out_dirs), values.shape[1]))
    den = np.empty(len(out_dirs))
    for i in range(0, len(out_dirs), chunk):
        w = kernel(out_dirs[i : i + chunk] @ src_dirs.T) * src_omega
        den[i : i + chunk] = w.sum(1)
        out[i : i + chunk] = (w @ values) / np.where(den[i : i + chunk] > 0, den[i : i + chunk],
                                                     1.0)[:, None]
    return out, den


def edge_and_random_texels(size, count, rng):
    """Face-major indices of every texel on a face edge (corners included) plus random ones."""
    r, c = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
    border = ((r == 0) | (c == 0) | (r == size - 1) | (c == size - 1)).ravel()
    idx = np.flatnonzero(np.tile(border, 6))
    extra = rng.choice(6 * size * size, min(count, 6 * size * size), replace=False)
    return np.unique(np.concatenate([idx, extra]))


# --- powers, gloss, resolutions ---------------------------------------------------------------


def test_mip_gloss_and_powers():
    g = prefilter.mip_gloss(128)
    np.testing.assert_allclose(g, 1.0 - np.arange(8) / 7.0)
    p = prefilter.mip_powers(128)
    # Mip 0: 8192 / 4 = 2048 (Blinn-Phong to Phong); the 1 x 1 mip: 8192^0 / 4.
    assert p[0] == pytest.approx(2048.0) and p[-1] == pytest.approx(0.25)
    np.testing.assert_allclose(p, 8192.0 ** (1.0 - np.arange(8) / 7.0) / 4.0)
    # The shader's lod = nMips - gloss * nMips reads mip m at gloss g_m.
    np.testing.assert_allclose(prefilter.gloss_to_lod(g, 7), np.arange(8), atol=1e-6)
    assert prefilter.gloss_to_lod(1.0, 7) == 0.0 and prefilter.gloss_to_lod(0.0, 7) == 7.0
    assert len(prefilter.mip_powers(256)) == 9
    np.testing.assert_allclose(prefilter.mip_gloss(1), [1.0])
    with pytest.raises(ValueError):
        prefilter.mip_powers(96)


def test_top_resolution_follows_the_talk():
    # "Dropped environment map resolution from 256x256 to 128x128" once the top power became
    # the Phong power 8192 / 4.
    assert prefilter.top_resolution(8192.0 / 4.0) == 128
    assert prefilter.top_resolution() == 128
    assert prefilter.top_resolution(8192.0) == 256
    assert prefilter.top_resolution(1.0) == 2
    # One texel spacing (2 / S rad at a face centre) per lobe standard deviation 1 / sqrt(p).
    for p in (3.0, 50.0, 700.0, 5000.0):
        s = prefilter.top_resolution(p)
        assert 2.0 / s <= 1.0 / math.sqrt(p) < 4.0 / s


def test_cone_angle():
    for p in (0.25, 3.0, 2048.0):
        theta = prefilter.cone_angle(p, 1e-4)
        if theta < math.pi / 2 - 1e-9:
            assert math.cos(theta) ** p == pytest.approx(1e-4, rel=1e-9)
    assert prefilter.cone_angle(2048.0, 1e-4) == pytest.approx(math.sqrt(2 * math.log(1e4) / 2048),
                                                               rel=0.01)


def test_cubemapgen_default_angles():
    half, sigma = prefilter.angular_gaussian_angles(128)
    # Base filter angle 20 -> half-angle 10; then 1, 2, 4, ... degree cones, halved, no smaller
    # than the source texel atan(1 / S_src) and no larger than 90 degrees.
    expect = [10.0, max(0.5, math.degrees(math.atan(1 / 128))), 1.0, 2.0, 4.0, 8.0, 16.0, 32.0]
    np.testing.assert_allclose(half, expect)
    assert prefilter.DEFAULT_BASE_ANGLE == 20.0
    assert prefilter.DEFAULT_INITIAL_MIP_ANGLE == 1.0
    assert prefilter.DEFAULT_MIP_ANGLE_SCALE == 2.0
    np.testing.assert_allclose(sigma, np.sqrt(np.cumsum((np.array(expect) / 3.0) ** 2)))
    half32, _ = prefilter.angular_gaussian_angles(32, 0.0, 1.0, 4.0)
    np.testing.assert_allclose(half32[:2], np.degrees(np.arctan([1 / 32, 1 / 32])))
    assert half32[-1] == 90.0


# --- BO2: cosine power ------------------------------------------------------------------------


def test_cosine_power_matches_brute_force():
    # Brute force: every texel of the 64^2 input, exact solid angles, no cutoff, float64.
    size = 64
    rng = np.random.default_rng(5)
    cube = environment(size)
    src = directions(size)
    omega = solid_angles(size)
    mips = prefilter.prefilter_cosine_power(cube)
    assert len(mips) == 7
    for m, (level, power) in enumerate(zip(mips, prefilter.mip_powers(size), strict=True)):
        s = size >> m
        assert level.shape == (6, s, s, 3) and level.dtype == np.float32
        idx = edge_and_random_texels(s, 400, rng)
        ref, _ = brute_force(directions(s)[idx], src, omega, cube,
                             lambda x, p=power: np.maximum(x, 0.0) ** p)
        got = level.reshape(-1, 3)[idx]
        rel = np.abs(got - ref) / np.abs(ref)
        assert rel.max() < 0.01, (m, rel.max())


def test_cosine_power_small_cube_is_exact_to_the_cutoff():
    # A tiny cube: every mip reads the input itself, so only the 1e-4 cutoff separates the two.
    cube = environment(8)
    src = directions(8)
    omega = solid_angles(8)
    mips = prefilter.prefilter_cosine_power(cube, cutoff=1e-7)
    for m, power in enumerate(prefilter.mip_powers(8)):
        ref, _ = brute_force(directions(8 >> m), src, omega, cube,
                             lambda x, p=power: np.maximum(x, 0.0) ** p)
        np.testing.assert_allclose(mips[m].reshape(-1, 3), ref, rtol=2e-5)


def test_cosine_power_keeps_a_constant_environment():
    for size in (16, 32):
        cube = np.empty((6, size, size, 3), np.float32)
        cube[...] = [0.25, 1.0, 3.5]
        for level in prefilter.prefilter_cosine_power(cube):
            np.testing.assert_allclose(level, np.broadcast_to([0.25, 1.0, 3.5], level.shape),
                                       rtol=2e-6)


def test_cosine_power_threads_do_not_change_the_result():
    cube = environment(32)
    one = prefilter.prefilter_cosine_power(cube, workers=1)
    two = prefilter.prefilter_cosine_power(cube, workers=2)
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a, b)


def test_cosine_power_rejects_bad_cubes():
    with pytest.raises(ValueError):
        prefilter.prefilter_cosine_power(np.zeros((6, 12, 12, 3), np.float32))
    with pytest.raises(ValueError):
        prefilter.prefilter_cosine_power(np.zeros((5, 8, 8, 3), np.float32))


# --- BO1: angular Gaussian ------------------------------------------------------------------


def gaussian_kernel(half_deg):
    h = math.radians(half_deg)
    sigma = h / 3.0

    def kernel(x):
        theta = np.arccos(np.clip(x, -1.0, 1.0))
        # Texels exactly on the cone's edge count as inside (the module's tolerance).
        return np.where(theta <= h * (1.0 + 1e-5), np.exp(-theta**2 / (2.0 * sigma**2)), 0.0)

    return kernel


def test_angular_gaussian_matches_brute_force_cascade():
    # CubeMapGen's chain in float64: mip 0 from the input, mip m from mip m - 1, each pass a
    # truncated Gaussian over every source texel. Where no texel centre is inside the cone
    # (each output texel then sits on the corner of four source texels), the mean of those four.
    size = 32
    cube = environment(size)
    mips = prefilter.prefilter_angular_gaussian(cube)
    half, _ = prefilter.angular_gaussian_angles(size)
    assert len(mips) == 6
    source = cube.astype(np.float64)
    fallbacks = 0
    for m, level in enumerate(mips):
        s_src = source.shape[1]
        s = size >> m
        ref, den = brute_force(directions(s), directions(s_src), solid_angles(s_src), source,
                               gaussian_kernel(half[m]))
        empty = np.flatnonzero(den == 0)
        if empty.size:
            assert s_src == 2 * s
            blocks = source.reshape(6, s, 2, s, 2, 3).mean(axis=(2, 4)).reshape(-1, 3)
            ref[empty] = blocks[empty]
            fallbacks += empty.size
        got = level.reshape(-1, 3)
        rel = np.abs(got - ref) / np.abs(ref)
        assert rel.max() < 0.01, (m, rel.max())
        source = ref.reshape(6, s, s, 3)
    assert fallbacks > 0  # the default small angles do leave empty cones at face centres


def test_angular_gaussian_keeps_a_constant_environment():
    cube = np.full((6, 32, 32, 2), 0.6, np.float32)
    for level in prefilter.prefilter_angular_gaussian(cube):
        np.testing.assert_allclose(level, 0.6, rtol=2e-6)
    for level in prefilter.prefilter_angular_gaussian(cube, 40.0, 5.0, 1.5):
        np.testing.assert_allclose(level, 0.6, rtol=2e-6)


# --- lobe widths --------------------------------------------------------------------------------


def lobe_width(level):
    """Mean squared chord between each output texel r and the directions its filter averages.

    The input is the direction itself, L(d) = d, so a filtered texel holds m(r) = E_K[d] and
    E_K[|d - r|^2] = 2 (1 - m(r).r), exactly, for any kernel K (shifted or not); averaged over
    the level with solid-angle weights.
    """
    s = level.shape[1]
    r = directions(s)
    m = level.reshape(-1, 3).astype(np.float64)
    omega = solid_angles(s)
    return float((2.0 * (1.0 - (m * r).sum(1)) * omega).sum() / omega.sum())


def lobe_chord(weight):
    """E[|d - r|^2] = E[2 (1 - cos theta)] of a lobe weight(theta) over the sphere (1D
    quadrature, sin theta dtheta)."""
    theta = np.linspace(0.0, math.pi, 400001)
    w = weight(theta) * np.sin(theta)
    w[[0, -1]] *= 0.5  # trapezoidal rule on a uniform grid
    return float((w * 2.0 * (1.0 - np.cos(theta))).sum() / w.sum())


def test_lobe_width_decreases_with_gloss():
    size = 128
    cube = directions(size).reshape(6, size, size, 3).astype(np.float32)
    bo2 = [lobe_width(level) for level in prefilter.prefilter_cosine_power(cube)]
    # Higher mip = lower gloss = wider lobe, all the way down the chain.
    assert np.all(np.diff(bo2) > 0), bo2
    # Each mip is the Phong lobe of its power, cos^p with p = 8192^(1 - m / M) / 4.
    for m, power in enumerate(prefilter.mip_powers(size)):
        expect = lobe_chord(lambda t, p=power: np.maximum(np.cos(t), 0.0) ** p)
        assert bo2[m] == pytest.approx(expect, rel=0.01), m
    bo1 = [lobe_width(level) for level in prefilter.prefilter_angular_gaussian(cube)]
    assert np.all(np.diff(bo1) > 0), bo1
    # Mip 0: the Gaussian of sigma = 10 / 3 degrees truncated at 10 degrees.
    h = math.radians(10.0)
    expect0 = lobe_chord(lambda t: np.where(t <= h, np.exp(-t**2 / (2 * (h / 3) ** 2)), 0.0))
    assert bo1[0] == pytest.approx(expect0, rel=0.01)
    # BO1's mip 4 is far sharper than the gloss it is read at (the problem BO2 fixed).
    assert bo1[4] < 0.25 * bo2[4]


# --- seamless ---------------------------------------------------------------------------------


def test_prefiltered_chain_is_seamless():
    cube = environment(32)
    for mips in (prefilter.prefilter_cosine_power(cube),
                 prefilter.prefilter_angular_gaussian(cube)):
        eps = 1e-7
        t = np.linspace(-0.99, 0.99, 101)
        for i in range(6):
            for j in range(i + 1, 6):
                fi, fj = TABLE[i, 0], TABLE[j, 0]
                if abs(fi @ fj) > 0.5:
                    continue
                p = fi + fj + t[:, None] * np.cross(fi, fj)
                for lod in np.linspace(0.0, len(mips) - 1, 7):
                    a = cubemap.sample(mips, p + eps * (fi - fj), lod)
                    b = cubemap.sample(mips, p - eps * (fi - fj), lod)
                    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-4)
