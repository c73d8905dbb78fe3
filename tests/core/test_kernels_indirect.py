"""The indirect-light kernel against the readable NumPy it replaced, point by point.

The reference below is written with the library's NumPy references only: ``sh.basis`` and the
band factors for the irradiance at the normal (Ramamoorthi & Hanrahan 2001), ``cubemap.sample``
for the seamless trilinear look-ups at lod = top - g top (slide "Black Ops: environment map
pre-filtering"), the probes' influence weights, and the "bo1" and "bo2" normalizations of
slides "Black Ops: normalization algorithm" and "Improved normalization algorithm" written out
here, and ``env_brdf.environment_brdf``. Random probes that overlap (weights summing over 1),
points outside every probe, a world cube or a world colour, shared and per-point pixel SH, every
normalization, both chains and every environment BRDF: relative difference below 2e-5 (float32
sums in another order).
"""

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import cubemap, env_brdf, sh
from bo2_lighting.addon.core.lighting import probes as cp

RNG = np.random.default_rng(17)
EPS = 1e-6
DC = np.eye(9, 3)[:, :1] * np.ones(3)  # 1 in the constant term's row


def chain(size, channels=3):
    """A random mip chain of (6, S, S, C) float32 levels, S, S/2, ..., 1."""
    out = []
    while size >= 1:
        out.append(RNG.uniform(0.05, 2.0, (6, size, size, channels)).astype(np.float32))
        size //= 2
    return out


def random_probes(world_color, volumes):
    reflection = [
        cp.ReflectionProbe(f"P{i}", RNG.uniform(-1, 1, 3), float(RNG.uniform(1.0, 2.0)),
                           float(RNG.uniform(0.1, 0.9)),
                           {"bo2": chain(16, 4), "bo1": chain(8)},
                           (RNG.normal(size=(9, 3)) * 0.3 + DC * 2.0).astype(np.float32))
        for i in range(3)
    ]
    world_sh = (RNG.normal(size=(9, 3)) * 0.2 + DC * [1.5, 1.2, 1.0]).astype(np.float32)
    probes = cp.Probes(world_sh=world_sh, world_mips={"bo2": chain(16), "bo1": chain(8)},
                       world_color=np.float32([0.4, 0.5, 0.6]) if world_color else None,
                       reflection=reflection)
    if volumes:
        coeffs = (RNG.normal(size=(3, 2, 2, 9, 3)) * 0.2 + 1.0).astype(np.float32)
        probes.volumes.append(cp.IrradianceVolume("V", np.diag([1.5, 1.5, 1.5, 1.0]), (3, 2, 2),
                                                  coeffs, influence=0.5))
    return probes


def reference(probes, points, normals, view, albedo, rf0, gloss, normalization, prefilter,
              env_model, seen=None, nearest=True):
    """The NumPy indirect light: (diffuse (N, 3), specular (N, 3)) float32; ``seen`` (N,): the
    world's seen fraction (None: 1), whose complement of the weight the probes leave goes to
    the two nearest probes, each by 1/d^2 - 1/d3^2, d3 the third nearest's distance (with
    ``nearest``; else to the world)."""
    pixel_sh = cp._pixel_sh(probes, points, sky=None if seen is None else lambda k: seen[k])
    y = sh.basis(normals).astype(np.float32) * sh.BAND_FACTORS.astype(np.float32)
    if pixel_sh.ndim == 2:
        pixel_e = (y.astype(np.float64) @ pixel_sh.astype(np.float64)).astype(np.float32)
    else:
        pixel_e = np.einsum("nk,nkc->nc", y.astype(np.float64), pixel_sh).astype(np.float32)
    pixel_dc = np.broadcast_to(pixel_sh[..., 0, :], (len(points), 3))
    diffuse = albedo * pixel_e * np.float32(1.0 / np.pi)
    n_dot_v = np.einsum("nc,nc->n", normals, view)
    reflect = 2.0 * n_dot_v[:, None] * normals - view

    def normalized(s, probe_sh):
        if normalization == "none":
            return s
        probe_sh = np.asarray(probe_sh, np.float64)
        if normalization == "bo1":
            ratio = (pixel_dc + EPS) / (probe_sh[0] + EPS)
        else:
            scalar, tint = sh.to_tinted(probe_sh)
            probe_e = (y.astype(np.float64) @ scalar)[:, None] * tint
            ratio = (pixel_e + EPS) / (probe_e + EPS)
        return s * np.clip(ratio, 0.0, cp.MAX_NORMALIZATION).astype(np.float32)

    def lookup(mips):
        top = len(mips) - 1
        lod = (top - np.clip(gloss, 0.0, 1.0) * top).astype(np.float32)
        return cubemap.sample(mips, reflect, lod)[:, :3]

    total = np.zeros(len(points), np.float32)
    radiance = np.zeros((len(points), 3), np.float32)
    for probe in probes.reflection:
        w = probe.weight(points)
        radiance += w[:, None] * normalized(lookup(probe.mips[prefilter]), probe.sh)
        total += w
    over = total > 1.0
    radiance[over] /= total[over, None]
    world = np.maximum(1.0 - total, 0.0)
    if probes.world_color is not None:
        s = np.broadcast_to(probes.world_color, (len(points), 3)).astype(np.float32)
    else:
        s = lookup(probes.world_mips[prefilter])
    shown = np.ones(len(points)) if seen is None or not nearest else np.clip(seen, 0.0, 1.0)
    radiance += (world * shown)[:, None] * normalized(s, probes.world_sh)
    if seen is not None and nearest:
        positions = np.array([p.position for p in probes.reflection], np.float64)
        d2 = ((points[:, None].astype(np.float64) - positions[None]) ** 2).sum(-1)
        order = np.argsort(d2, axis=1, kind="stable")
        nearest = order[:, :2]
        inv = 1.0 / np.take_along_axis(d2, nearest, 1)
        if len(positions) > 2:
            inv -= 1.0 / np.take_along_axis(d2, order[:, 2:3], 1)
        inv /= inv.sum(1, keepdims=True)
        for k, probe in enumerate(probes.reflection):
            share = (inv * (nearest == k)).sum(1) * world * (1.0 - shown)
            radiance += share[:, None] * normalized(lookup(probe.mips[prefilter]), probe.sh)
    e = env_brdf.environment_brdf(gloss[:, None], n_dot_v[:, None], rf0, env_model)
    return diffuse.astype(np.float32), (radiance * e).astype(np.float32)


@pytest.mark.parametrize("normalization,env_model", [("none", "table"), ("bo1", "bo1"),
                                                     ("bo2", "bo2"), ("bo2", "fit")])
@pytest.mark.parametrize("prefilter", ["bo2", "bo1"])
@pytest.mark.parametrize("world_color,volumes", [(False, False), (True, True)])
@pytest.mark.parametrize("hidden", [False, True])
def test_indirect_kernel_matches_numpy(normalization, env_model, prefilter, world_color,
                                       volumes, hidden):
    probes = random_probes(world_color, volumes)
    n = 6000
    points = RNG.uniform(-3, 3, (n, 3)).astype(np.float32)
    normals = RNG.normal(size=(n, 3))
    normals = (normals / np.linalg.norm(normals, axis=1, keepdims=True)).astype(np.float32)
    view = RNG.normal(size=(n, 3)) + normals * 1.5
    view = (view / np.linalg.norm(view, axis=1, keepdims=True)).astype(np.float32)
    albedo, rf0 = (RNG.random((n, 3)).astype(np.float32) for _ in range(2))
    gloss = RNG.random(n).astype(np.float32)
    gloss[:4] = [0.0, 1.0, 0.5, 0.25]
    rf0[:3] = [[0.0, 0.04, 1.0], [1.0, 0.5, 0.0], [0.04, 0.04, 0.04]]
    view[:3] = normals[:3]  # n.v = 1, the table's last column
    args = (points, normals, view, albedo, rf0, gloss)
    seen = RNG.uniform(-0.2, 1.2, n).astype(np.float32) if hidden else None
    diffuse, specular = cp.indirect(probes, *args, normalization=normalization,
                                    prefilter=prefilter, env_brdf=env_model,
                                    sky=None if seen is None else lambda k: seen[k],
                                    nearest=True)
    d_ref, s_ref = reference(probes, *args, normalization, prefilter, env_model, seen)
    weights = np.stack([p.weight(points) for p in probes.reflection])
    assert (weights.sum(0) > 1).sum() > 20 and (weights.sum(0) == 0).sum() > 20  # both cases
    np.testing.assert_allclose(diffuse, d_ref, rtol=2e-5, atol=1e-7)
    np.testing.assert_allclose(specular, s_ref, rtol=2e-5, atol=1e-7)
    if hidden:  # the bakes' captures: the world wherever the probes leave weight
        _, specular = cp.indirect(probes, *args, normalization=normalization,
                                  prefilter=prefilter, env_brdf=env_model,
                                  sky=lambda k: seen[k], nearest=False)
        _, s_ref = reference(probes, *args, normalization, prefilter, env_model, seen, False)
        np.testing.assert_allclose(specular, s_ref, rtol=2e-5, atol=1e-7)


def test_indirect_kernel_with_bad_input_stays_finite():
    probes = random_probes(False, False)
    n = 8
    points = np.zeros((n, 3), np.float32)
    normals = np.zeros((n, 3), np.float32)  # zero normal: the reflection is -view
    normals[1] = np.nan
    view = np.tile(np.float32([0, 0, 1]), (n, 1))
    gloss = np.float32([np.nan, 2.0, -1.0, 0.5, 0.5, 0.5, 0.5, 0.5])
    diffuse, specular = cp.indirect(probes, points, normals, view, view, view, gloss)
    # gloss out of range is clamped; NaN gloss reads the coarsest level (the environment BRDF
    # of a NaN gloss stays NaN, as in env_brdf); a NaN normal gives NaN, never a crash
    rows = [0, 2, 3, 4]
    assert np.isfinite(diffuse[rows]).all() and np.isfinite(specular[2:]).all()


def test_changed_probes_are_packed_again():
    probes = random_probes(True, False)
    n = 200
    points = RNG.uniform(-3, 3, (n, 3)).astype(np.float32)
    normals = np.tile(np.float32([0, 0, 1]), (n, 1))
    args = (points, normals, normals, np.ones((n, 3), np.float32),
            np.full((n, 3), 0.5, np.float32), np.full(n, 0.6, np.float32))
    cp.indirect(probes, *args)  # packs the chains with a world colour
    probes.world_color = None  # the world's chain is read from now on
    probes.reflection[0].mips["bo2"] = chain(16)  # and a probe's chain is replaced
    _, spec = cp.indirect(probes, *args, normalization="none")
    _, ref = reference(probes, *args, "none", "bo2", "bo2")
    np.testing.assert_allclose(spec, ref, rtol=2e-5, atol=1e-7)


@pytest.mark.parametrize("env_model", ["table", "bo1", "bo2", "fit"])
def test_environment_brdf_of_the_kernel_clamps_like_numpy(env_model):
    """Out-of-range gloss, n.v and rf0 (negative, over 1, infinite) are clamped as in
    env_brdf; the kernel's E, read through a white uniform world, is the NumPy value."""
    probes = cp.Probes(world_sh=DC.astype(np.float32) * 2.0, world_mips={"bo2": chain(4)},
                       world_color=np.float32([1.0, 1.0, 1.0]))
    gloss = np.float32([-1.0, 0.0, 0.3, 1.0, 2.0, 0.7, 0.5, 0.9])
    nv = np.float32([0.5, -0.2, 0.0, 1.0, 0.3, 1e-5, 0.999, 0.05])
    n = len(gloss)
    normals = np.tile(np.float32([0, 0, 1]), (n, 1))
    view = np.stack([np.sqrt(np.maximum(1 - nv * nv, 0)), np.zeros(n), nv], 1).astype(np.float32)
    rf0 = np.float32([[-0.5, 0.04, 2.0], [np.inf, 0.5, 1.0], [0.0, 0.2, 0.9],
                      [1.0, 1.0, 1.0], [0.04, -np.inf, 0.3], [0.6, 0.7, 0.8],
                      [0.0, 0.0, 0.0], [0.5, 0.25, 0.125]])
    _, spec = cp.indirect(probes, np.zeros((n, 3), np.float32), normals, view, rf0, rf0, gloss,
                          normalization="none", env_brdf=env_model)
    n_dot_v = np.einsum("nc,nc->n", normals, view)
    expected = env_brdf.environment_brdf(gloss[:, None], n_dot_v[:, None], rf0, env_model)
    assert np.isfinite(spec).all()
    np.testing.assert_allclose(spec, expected, rtol=2e-6, atol=1e-7)


def test_quadrature_is_not_a_shading_model():
    probes = random_probes(False, False)
    n = np.tile(np.float32([0, 0, 1]), (2, 1))
    with pytest.raises(ValueError, match="environment BRDF 'truth'"):
        cp.indirect(probes, np.zeros((2, 3), np.float32), n, n, n, n, np.ones(2, np.float32),
                    env_brdf="truth")


def _seen_numpy(vol, flat, sample, pts):
    """``sample_visibility.chebyshev`` of samples ``flat`` (N,) at world ``sample`` (N, 3) for
    points ``pts`` (N, 3) (their distances clamped as the moments are), the moments read with
    ``cubemap``'s seamless bilinear look-up, each sample's faces bordered on their own."""
    from bo2_lighting.addon.core.lighting import sample_visibility as sv

    m = vol.moments.reshape(-1, *vol.moments.shape[-4:])
    padded = np.concatenate([cubemap.with_border(s) for s in m])  # (S 6, M + 2, M + 2, 2)
    d = pts.astype(np.float64) - sample
    face, x, y = cubemap.direction_to_face(d, m.shape[-2])
    mean, square = cubemap._bilinear_padded(padded, flat * 6 + face, x, y).T
    cell = 2.0 * np.linalg.norm(vol.local_to_world[:3, :3], axis=0) / np.asarray(vol.resolution)
    far = 1.5 * np.linalg.norm(cell)  # the moments' clamp: 1.5 cell diagonals
    return sv.chebyshev(np.minimum(np.linalg.norm(d, axis=1), far), mean, square,
                        vol.variance_floor())


def _blend_numpy(vol, pts, f, normals, visibility=False):
    """The blend of the eight samples around grid coordinates ``f`` (N, 3), within
    [0, res - 1]: trilinear weights times validity, the facing weight and (``visibility``)
    the samples' visibility of the points; where those leave nothing, trilinear over the
    valid samples, or over all."""
    res = np.asarray(vol.resolution)
    i0 = np.minimum(np.floor(f).astype(np.int64), res - 2).clip(0)
    t = (f - i0).astype(np.float32)
    i1 = np.minimum(i0 + 1, res - 1)
    m = np.asarray(vol.local_to_world, np.float64)
    plain, kept, corners = [], [], []
    for corner in range(8):
        bits = [(corner >> k) & 1 for k in range(3)]
        idx = tuple(np.where(b, i1[:, k], i0[:, k]) for k, b in enumerate(bits))
        w = np.ones(len(pts), np.float32)
        for k, b in enumerate(bits):
            w *= t[:, k] if b else 1.0 - t[:, k]
        keep = w * (1.0 if vol.validity is None else vol.validity[idx])
        local = (np.stack(idx, -1) + 0.5) / res * 2.0 - 1.0
        sample = (local @ m[:3, :3].T + m[:3, 3]).astype(np.float32)
        if normals is not None and vol.facing_bias is not None:
            to = sample - pts
            to /= np.maximum(np.linalg.norm(to, axis=-1, keepdims=True), 1e-6)
            keep = keep * np.maximum(np.einsum("nk,nk->n", to, normals) + vol.facing_bias, 0)
        if visibility:
            keep = keep * _seen_numpy(vol, np.ravel_multi_index(idx, tuple(res)), sample, pts)
        plain.append(w)
        kept.append(keep)
        corners.append(idx)
    plain, kept = np.stack(plain), np.stack(kept)
    if vol.validity is not None:
        valid = plain * np.stack([vol.validity[idx] for idx in corners])
        plain = np.where(valid.sum(0) > 1e-6, valid, plain)
    total = kept.sum(0)
    blend = np.where(total > 1e-6, kept / np.maximum(total, 1e-30),
                     plain / np.maximum(plain.sum(0), 1e-30))
    return sum(blend[c][:, None, None] * vol.sh[idx] for c, idx in enumerate(corners))


def volume_sh_numpy(vol, points, normals=None, extrapolate=False, visibility=False):
    """The NumPy form of ``IrradianceVolume.sample_sh`` (no biases): the blend at the point
    clamped to the outermost samples; with ``extrapolate``, between them and the box's faces,
    scaled by 1 plus, per axis past them, the distance past (in cells) times the DC
    luminance's change from one cell inward, over the DC luminance (the scale within
    ``probes.EXTRAPOLATION``); ``visibility``: as ``_blend_numpy``'s."""
    res = np.asarray(vol.resolution)
    pts = np.asarray(points, np.float32)
    grid = (vol._local(pts) + 1.0) * 0.5 * res - 0.5
    f = np.clip(grid, 0.0, res - 1.0)
    past = np.where(res > 1, np.clip(grid, -0.5, res - 0.5) - f, 0.0)
    base = _blend_numpy(vol, pts, f, normals, visibility)
    luma = lambda sh: sh[:, 0] @ np.float32([0.2126, 0.7152, 0.0722])  # noqa: E731
    extra = np.zeros(len(pts))
    for a in range(3):
        g = f.copy()
        g[:, a] -= np.sign(past[:, a])
        extra += np.abs(past[:, a]) * (luma(base)
                                       - luma(_blend_numpy(vol, pts, g, normals, visibility)))
    low, high = cp.EXTRAPOLATION if extrapolate else (1.0, 1.0)
    y = luma(base)
    scale = np.where(y > 0, np.clip(1.0 + extra / np.where(y > 0, y, 1.0), low, high), 1.0)
    return base * scale[:, None, None]


@pytest.mark.parametrize("facing_bias,extrapolate,visibility", [
    (None, False, False), (0.0, False, False), (0.5, False, True), (1.0, False, False),
    (None, True, True), (0.5, True, False)])
def test_volume_look_up_kernel_matches_numpy(facing_bias, extrapolate, visibility):
    rng = np.random.default_rng(5)
    m = np.diag([2.0, 1.5, 1.0, 1.0])
    m[:3, 3] = (0.3, -0.2, 1.0)
    res = (4, 3, 5)
    validity = (rng.random(res) > 0.3).astype(np.float32)
    validity[0, 0, 0] = 0.0
    coeffs = rng.normal(size=(*res, 9, 3)).astype(np.float32)
    coeffs[..., 0, :] += 2.0  # light's DC terms are positive: the extrapolation scales them
    mean = rng.uniform(0.2, 2.0, (*res, 6, 4, 4))
    moments = np.stack([mean, mean * mean + rng.uniform(0, 0.2, mean.shape)], -1)
    vol = cp.IrradianceVolume("v", m, res, coeffs, 0.5, validity, facing_bias=facing_bias,
                              moments=moments.astype(np.float32))
    points = (rng.uniform(-1.3, 1.3, size=(2000, 3)) * (2.0, 1.5, 1.0)
              + (0.3, -0.2, 1.0)).astype(np.float32)
    normals = rng.normal(size=(2000, 3)).astype(np.float32)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(
        vol.sample_sh(points, normals, extrapolate=extrapolate, visibility=visibility),
        volume_sh_numpy(vol, points, normals, extrapolate, visibility), rtol=1e-4, atol=1e-5)
    if visibility:  # the test changed the light of many points
        held = vol.sample_sh(points, normals, extrapolate=extrapolate)
        assert (np.abs(held - volume_sh_numpy(vol, points, normals, extrapolate, True))
                > 1e-3).any(axis=(1, 2)).mean() > 0.2
    plain = cp.IrradianceVolume("v", m, res, vol.sh, 0.5)
    np.testing.assert_allclose(plain.sample_sh(points, extrapolate=extrapolate),
                               volume_sh_numpy(plain, points, extrapolate=extrapolate),
                               rtol=1e-4, atol=1e-5)
