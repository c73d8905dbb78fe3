"""Tests of addon/core/formulas/brdf.py (Lazarov 2013, direct-lighting terms) against independent
values.

Independent values used here:
- hand arithmetic for the spot values (written out next to each number);
- composite Gauss-Legendre quadrature on geometric panels of x = 1 - n.h (panel edges from
  1e-10 or 1e-7 up to 1), which resolves the lobe of alpha = 8192, for the NDF normalization
  and the directional albedo; the albedo integrates over the half vector with
  d(omega_l) = 4 (v.h) d(omega_h);
- a one-dimensional integral written directly from the talk's formulas (not through
  ``direct_brdf``) for the directional albedo at normal incidence;
- 100001 samples of 2^(-10 x) - (1 - x)^5 for the Fresnel error bound.
"""

import math
import warnings

import numpy as np
import pytest

from bo2_lighting.addon.core.formulas import brdf

GLOSSES = (0.0, 0.25, 0.5, 0.75, 1.0)
N = np.array([0.0, 0.0, 1.0])


def gauss_legendre_panels(edges, order):
    t, w = np.polynomial.legendre.leggauss(order)
    a, b = edges[:-1, None], edges[1:, None]
    return (0.5 * (b - a) * t + 0.5 * (b + a)).ravel(), (0.5 * (b - a) * w).ravel()


def unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def specular_albedo(model, gloss, n_dot_v, rf0=1.0):
    """Directional albedo of the specular term, the integral of f(l, v) (n.l) over l, for each
    n.v, by quadrature over the half vector h (30 geometric panels of 1 - n.h x 12 points,
    64 points in azimuth over [0, pi], doubled by the symmetry of v in the xz plane)."""
    x, wx = gauss_legendre_panels(np.concatenate([[0.0], np.geomspace(1e-7, 1.0, 30)]), 12)
    phi, wphi = gauss_legendre_panels(np.array([0.0, np.pi]), 64)
    c = 1.0 - x[:, None]
    s = np.sqrt(np.maximum(0.0, 1.0 - c * c))
    h = np.stack(np.broadcast_arrays(s * np.cos(phi), s * np.sin(phi), c), axis=-1)
    nv = np.asarray(n_dot_v, dtype=np.float64)[:, None, None]
    v = np.stack(np.broadcast_arrays(np.sqrt(1.0 - nv * nv), 0.0 * nv, nv), axis=-1)
    v_dot_h = np.sum(v * h, axis=-1)
    l = 2.0 * v_dot_h[..., None] * h - v  # mirror of v about h
    weight = 2.0 * 4.0 * v_dot_h * (v_dot_h > 0) * wx[:, None] * wphi[None, :]
    _, spec = brdf.direct_brdf(N, v, l, np.zeros(3), np.full(3, rf0), np.float64(gloss), model)
    return np.sum(spec[..., 0] * weight, axis=(1, 2))


# --- normalization and energy ------------------------------------------------------------------


@pytest.mark.parametrize("gloss", GLOSSES)
def test_ndf_integrates_to_one_over_projected_hemisphere(gloss):
    # integral of D(h) (n.h) d(omega) = 2 pi * integral_0^1 D(1 - x) (1 - x) dx, x = 1 - n.h;
    # D depends on n.h only, so the azimuth gives exactly 2 pi.
    x, w = gauss_legendre_panels(np.concatenate([[0.0], np.geomspace(1e-10, 1.0, 51)]), 16)
    alpha = brdf.specular_power(np.float64(gloss))
    total = 2.0 * np.pi * np.sum(brdf.ndf_blinn_phong(1.0 - x, alpha) * (1.0 - x) * w)
    assert abs(total - 1.0) < 1e-4
    # the point-light form is pi/4 of it (slide "Black Ops: Microfacet BRDF")
    c = np.linspace(0.0, 1.0, 11)
    np.testing.assert_allclose(
        brdf.ndf_blinn_phong_pl(c, alpha), np.pi / 4 * brdf.ndf_blinn_phong(c, alpha), rtol=1e-12
    )


@pytest.mark.parametrize("model", brdf.MODELS)
def test_specular_albedo_never_exceeds_one(model):
    # rf0 = 1, albedo 0. Cook-Torrance reaches 1 (to rounding) for a mirror-like lobe: its G
    # is 1 around the specular direction, so the tolerance is rounding, not a margin.
    n_dot_v = np.array([1.0, 0.7, 0.4, 0.2, 0.1, 0.03, 0.01])
    albedos = np.array([specular_albedo(model, g, n_dot_v) for g in GLOSSES])
    assert np.all(albedos <= 1.0 + 1e-9), albedos.max()
    assert np.all(albedos > 0.0)
    # sanity bound, so that a vanishing lobe fails: a glossy lobe at normal incidence keeps
    # nearly all of its energy (every model: >= 0.9995 measured)
    assert albedos[-1, 0] > 0.99


@pytest.mark.parametrize("gloss", GLOSSES)
def test_reference_albedo_at_normal_incidence_matches_1d_integral(gloss):
    # v = n: h at angle theta gives l at 2 theta, so n.l = 2c^2 - 1 with c = n.h = v.h, and
    # (1/pi) D_pl V (n.l) 4 (v.h) d(omega_h), with d(omega_h) = 2 pi dc and
    # V = 1/((n.l)(1 - k) + k), is (alpha + 2) c^(alpha + 1) (n.l)/((n.l)(1 - k) + k) dc
    # for c in [1/sqrt(2), 1] (light above the horizon).
    alpha = 8192.0**gloss
    k = 2.0 / math.sqrt(math.pi * (alpha + 2.0))
    lo = 1.0 / math.sqrt(2.0)
    y, w = gauss_legendre_panels(np.concatenate([[0.0], np.geomspace(1e-10, 1.0 - lo, 60)]), 16)
    c = 1.0 - y
    nl = 2.0 * c * c - 1.0
    expected = np.sum((alpha + 2.0) * c ** (alpha + 1.0) * nl / (nl * (1.0 - k) + k) * w)
    got = specular_albedo("reference", gloss, [1.0])[0]
    assert got == pytest.approx(expected, abs=2e-4)
    assert expected > {0.0: 0.38, 0.25: 0.83}.get(gloss, 0.99)


# --- reciprocity -------------------------------------------------------------------------------


@pytest.mark.parametrize("model", brdf.MODELS)
def test_specular_is_reciprocal(model):
    # f(l, v) = f(v, l). All five models are: D and F depend on h and l.h, both symmetric
    # (l.h = v.h), Schlick-Smith, "none" and Cook-Torrance are symmetric in (n.l, n.v), and
    # the Kelemen and BO2 visibilities depend on l.h = v.h only. direct_brdf returns
    # f (n.l), so divide by the cosine of the light argument. (Only the horizon handling is
    # one-sided: a light below it gives 0, a view below it is clamped.)
    rng = np.random.default_rng(7)
    m = 2000
    n = unit(rng.normal(size=(m, 3)))
    a = unit(rng.normal(size=(m, 3)))
    b = unit(rng.normal(size=(m, 3)))
    a *= np.sign(np.sum(a * n, axis=-1))[:, None]
    b *= np.sign(np.sum(b * n, axis=-1))[:, None]
    ok = (np.sum(a * n, axis=-1) > 0.05) & (np.sum(b * n, axis=-1) > 0.05)
    n, a, b = n[ok], a[ok], b[ok]
    gloss = rng.uniform(0.0, 1.0, size=len(n))
    rf0 = rng.uniform(0.02, 1.0, size=(len(n), 3))
    _, s_ab = brdf.direct_brdf(n, a, b, np.zeros(3), rf0, gloss, model)
    _, s_ba = brdf.direct_brdf(n, b, a, np.zeros(3), rf0, gloss, model)
    f_ab = s_ab / np.sum(n * b, axis=-1)[:, None]
    f_ba = s_ba / np.sum(n * a, axis=-1)[:, None]
    np.testing.assert_allclose(f_ab, f_ba, rtol=1e-9, atol=1e-300)
    assert np.all(f_ab >= 0.0) and np.any(f_ab > 1.0)  # some samples hit the highlight


# --- spot values -------------------------------------------------------------------------------


def test_specular_power_and_ndf_spot_values():
    # 8192^0 = 1, 8192^0.5 = 2^6.5 = 90.50967, 8192^1 = 8192
    np.testing.assert_allclose(brdf.specular_power([0.0, 0.5, 1.0]), [1, 90.50967, 8192], 1e-6)
    # D_pl(n.h = 1, g = 0.5) = (90.50967 + 2)/8 = 92.50967/8 = 11.563709
    assert float(brdf.ndf_blinn_phong_pl(1.0, 90.50967)) == pytest.approx(11.563709, rel=1e-6)
    # D_pl(n.h = 0.5, alpha = 1) = 3/8 * 0.5 = 0.1875
    assert float(brdf.ndf_blinn_phong_pl(0.5, 1.0)) == pytest.approx(0.1875, rel=1e-6)
    # D(n.h = 1, alpha = 1) = 3/(2 pi) = 0.4774648
    assert float(brdf.ndf_blinn_phong(1.0, 1.0)) == pytest.approx(0.4774648, rel=1e-6)
    # n.h below 0 is clamped to 0: no negative lobe
    assert float(brdf.ndf_blinn_phong_pl(-0.5, 1.0)) == 0.0


def test_fresnel_spot_values():
    # Schlick: l.h = 0 -> 1; l.h = 1 -> rf0; l.h = 0.5, rf0 = 0.04 -> 0.04 + 0.96/32 = 0.07
    np.testing.assert_allclose(brdf.fresnel_schlick(0.04, [0.0, 0.5, 1.0]), [1, 0.07, 0.04], 1e-6)
    # BO2: l.h = 0 -> 1; l.h = 0.5 -> 0.04 + 0.96 * 2^-5 = 0.07 (meets Schlick there);
    # l.h = 1 -> 0.04 + 0.96/1024 = 0.0409375
    np.testing.assert_allclose(
        brdf.fresnel_bo2(0.04, [0.0, 0.5, 1.0]), [1, 0.07, 0.0409375], rtol=1e-6
    )
    # RGB: rf0 (3,) with l.h[..., None]
    rgb = brdf.fresnel_schlick(np.array([0.04, 0.5, 1.0]), np.array([1.0, 0.0])[:, None])
    np.testing.assert_allclose(rgb, [[0.04, 0.5, 1.0], [1.0, 1.0, 1.0]], rtol=1e-6)


def test_visibility_spot_values():
    # k(g = 0) = 2/sqrt(3 pi) = 2/3.0699802 = 0.6514700; k(g = 1) = 2/sqrt(8194 pi)
    # = 2/160.44375 = 0.0124654
    np.testing.assert_allclose(brdf.schlick_smith_k([1.0, 8192.0]), [0.65147, 0.0124654], 1e-5)
    # Schlick-Smith, alpha = 1, n.l = n.v = 0.5: 0.5 * 0.34853 + 0.65147 = 0.825735,
    # V = 1/0.825735^2 = 1.466626; at n.l = n.v = 1: V = 1
    np.testing.assert_allclose(
        brdf.visibility_schlick_smith([0.5, 1.0], [0.5, 1.0], 1.0), [1.466626, 1.0], rtol=1e-5
    )
    # BO2: g = 0 (k = 0.545): v.h = 1 -> 1, v.h = 0 -> 1/0.455 = 2.197802;
    # g = 0.25 (k = 0.795), v.h = 0.5 -> 1/(0.795/4 + 0.205) = 1/0.40375 = 2.476780;
    # g = 1 (k = 1), v.h = 0.5 -> 4
    np.testing.assert_allclose(
        brdf.visibility_bo2([1.0, 0.0, 0.5, 0.5], [0.0, 0.0, 0.25, 1.0]),
        [1.0, 2.197802, 2.476780, 4.0],
        rtol=1e-5,
    )
    # Cook-Torrance: n.l = 0.5, n.v = 0.8, n.h = 0.9, v.h = 0.7: 2*0.9*0.8/0.7 = 2.057,
    # 2*0.9*0.5/0.7 = 1.286, G = 1, V = 1/0.4 = 2.5;
    # n.l = 0.2, n.v = 0.9, n.h = 0.6, v.h = 0.8: G = min(1, 1.35, 0.3) = 0.3,
    # V = 0.3/0.18 = 1.666667
    np.testing.assert_allclose(
        brdf.visibility_cook_torrance([0.5, 0.2], [0.8, 0.9], [0.9, 0.6], [0.7, 0.8]),
        [2.5, 1.666667],
        rtol=1e-5,
    )
    # Kelemen: 1/(l.h)^2 -> 1/0.25 = 4 (no factor 1/4 in the talk's V)
    assert float(brdf.visibility_kelemen(0.5)) == pytest.approx(4.0, rel=1e-6)
    np.testing.assert_array_equal(brdf.visibility_none(np.zeros((2, 1)), np.zeros(3)), 1.0)


def test_direct_brdf_spot_value():
    # n = v = l: h = n, g = 0.5 (D_pl = 11.563709), rf0 = 0.04 (F = 0.04), V = 1 (every
    # model at normal incidence; BO2 Fresnel adds 0.96/1024):
    # specular = 11.563709 * 0.04 / pi = 0.1472331; diffuse = 0.5/pi = 0.1591549
    for model in brdf.MODELS:
        d, s = brdf.direct_brdf(N, N, N, np.full(3, 0.5), np.full(3, 0.04), 0.5, model)
        np.testing.assert_allclose(d, 0.1591549, rtol=1e-6)
        f = 0.0409375 if model == "bo2" else 0.04
        np.testing.assert_allclose(s, 11.563709 * f / np.pi, rtol=1e-6)


def test_parameter_conversions():
    # m = sqrt(2/(alpha + 2)): alpha = 0 -> 1, alpha = 98 -> sqrt(0.02) = 0.1414214
    np.testing.assert_allclose(brdf.blinn_phong_to_beckmann([0.0, 98.0]), [1, 0.1414214], 1e-6)
    # 2/0.1^2 - 2 = 198
    assert float(brdf.beckmann_to_blinn_phong(0.1)) == pytest.approx(198.0, rel=1e-6)
    # 8192/4 = 2048
    assert float(brdf.blinn_phong_to_phong(8192.0)) == 2048.0
    alpha = np.geomspace(1.0, 8192.0, 50)
    np.testing.assert_allclose(
        brdf.beckmann_to_blinn_phong(brdf.blinn_phong_to_beckmann(alpha)), alpha, rtol=1e-9
    )


def test_gloss_roughness_mapping():
    # g = 0: (2/3)^(1/4) = 0.9036020; g = 1: (2/8194)^(1/4) = 0.1249924;
    # r = 0.5: alpha = 2/0.0625 - 2 = 30, g = log2(30)/13 = 4.9068906/13 = 0.3774531
    np.testing.assert_allclose(brdf.gloss_to_roughness([0.0, 1.0]), [0.903602, 0.1249924], 1e-6)
    assert float(brdf.roughness_to_gloss(0.5)) == pytest.approx(0.3774531, rel=1e-6)
    g = np.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(brdf.roughness_to_gloss(brdf.gloss_to_roughness(g)), g, atol=1e-12)
    r = np.linspace(0.125, 0.9036, 101)
    np.testing.assert_allclose(brdf.gloss_to_roughness(brdf.roughness_to_gloss(r)), r, rtol=1e-12)
    # outside the gloss range: clamped, without warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = brdf.roughness_to_gloss([0.0, 0.05, 0.95, 1.0, 1.5, -0.2])
    np.testing.assert_array_equal(out, [1.0, 1.0, 0.0, 0.0, 0.0, 1.0])
    assert np.all(np.diff(brdf.roughness_to_gloss(np.linspace(0, 1, 201))) <= 0.0)


# --- BO2 optimized terms against the exact ones ------------------------------------------------

# Bounds from the tables of docs/model.md (tools/measure_brdf_errors.py), rounded up a little.
FRESNEL_MAX_ABS = 0.093  # measured 0.0925 at l.h = 0.123 (rf0 = 0)
FRESNEL_MEAN_ABS = 0.027  # measured 0.0261
# |relative error of the specular directional albedo|, rf0 = 0.04, at n.v = 1, 0.5, 0.2, 0.1
ALBEDO_NV = (1.0, 0.5, 0.2, 0.1)
ALBEDO_BOUNDS = {
    0.0: (0.02, 0.01, 0.065, 0.095),  # measured +0.015 +0.005 -0.061 -0.088
    0.25: (0.05, 0.01, 0.195, 0.27),  # measured -0.043 -0.001 -0.188 -0.263
    0.5: (0.015, 0.2, 0.55, 1.19),  # measured +0.008 +0.196 +0.543 +1.180
    0.75: (0.025, 0.075, 0.045, 0.445),  # measured +0.021 +0.069 +0.039 +0.437
    1.0: (0.03, 0.03, 0.135, 0.055),  # measured +0.023 +0.024 -0.131 +0.050
}


def test_bo2_fresnel_within_documented_error():
    x = np.linspace(0.0, 1.0, 100001)
    err = np.abs(2.0 ** (-10.0 * x) - (1.0 - x) ** 5)
    assert err.max() <= FRESNEL_MAX_ABS and err.mean() <= FRESNEL_MEAN_ABS
    for rf0 in (0.0, 0.04, 0.5):
        e = np.abs(brdf.fresnel_bo2(rf0, x) - brdf.fresnel_schlick(rf0, x))
        np.testing.assert_allclose(e, (1.0 - rf0) * err, atol=1e-12)  # scales by (1 - rf0)
        assert e.max() <= (1.0 - rf0) * FRESNEL_MAX_ABS


@pytest.mark.parametrize("gloss", GLOSSES)
def test_bo2_specular_albedo_within_documented_error(gloss):
    ref = specular_albedo("reference", gloss, ALBEDO_NV, rf0=0.04)
    opt = specular_albedo("bo2", gloss, ALBEDO_NV, rf0=0.04)
    assert np.all(np.abs(opt / ref - 1.0) <= ALBEDO_BOUNDS[gloss])


def test_bo2_visibility_is_kelemen_above_gloss_0455():
    # k = min(1, g + 0.545) = 1 for g >= 0.455: V_opt = 1/(v.h)^2
    x = np.linspace(0.05, 1.0, 20)
    for g in (0.455, 0.7, 1.0):
        np.testing.assert_allclose(brdf.visibility_bo2(x, g), 1.0 / x**2, rtol=1e-6)


# --- shapes, dtypes, edge cases ----------------------------------------------------------------


def test_direct_brdf_broadcasts():
    h, w = 4, 5
    n = np.zeros((h, w, 3), np.float32)
    n[..., 2] = 1.0
    v = np.array([0.0, 0.0, 1.0], np.float32)
    l = np.array([0.6, 0.0, 0.8], np.float32)
    d, s = brdf.direct_brdf(n, v, l, np.float32([0.5, 0.4, 0.3]), np.float32([0.04] * 3), 0.5)
    assert d.shape == s.shape == (h, w, 3)
    # per-pixel gloss (H, W) with a single normal (3,) and per-pixel rf0
    gloss = np.linspace(0, 1, h * w, dtype=np.float32).reshape(h, w)
    d2, s2 = brdf.direct_brdf(v, v, l, np.float32([0.5] * 3), np.full((h, w, 3), 0.04), gloss)
    assert d2.shape == s2.shape == (h, w, 3)
    # diffuse = albedo/pi * n.l = 0.5/pi * 0.8
    np.testing.assert_allclose(d2, 0.4 / np.pi, rtol=1e-6)
    # same numbers as with every input expanded to (H, W, ...)
    full = [np.broadcast_to(a, (h, w, 3)) for a in (v, v, l, np.float32([0.5] * 3))]
    d3, s3 = brdf.direct_brdf(*full, np.full((h, w, 3), 0.04), gloss)
    np.testing.assert_array_equal(d2, d3)
    np.testing.assert_array_equal(s2, s3)
    assert len(np.unique(s2[..., 0])) == h * w  # the gloss varies per pixel


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("model", brdf.MODELS)
def test_direct_brdf_preserves_dtype(dtype, model):
    rng = np.random.default_rng(1)
    n = np.array([0.0, 0.0, 1.0], dtype)
    v = unit(rng.normal(size=(6, 3)) + [0, 0, 3]).astype(dtype)
    l = unit(rng.normal(size=(6, 3)) + [0, 0, 3]).astype(dtype)
    d, s = brdf.direct_brdf(n, v, l, np.full(3, 0.5, dtype), np.full(3, 0.04, dtype), 0.5, model)
    assert d.dtype == s.dtype == dtype
    assert np.all(np.isfinite(s)) and np.all(s >= 0)


@pytest.mark.parametrize(
    ("func", "args"),
    [
        (brdf.specular_power, (0.5,)),
        (brdf.ndf_blinn_phong_pl, (0.9, 10.0)),
        (brdf.ndf_blinn_phong, (0.9, 10.0)),
        (brdf.fresnel_schlick, (0.04, 0.3)),
        (brdf.fresnel_bo2, (0.04, 0.3)),
        (brdf.schlick_smith_k, (10.0,)),
        (brdf.visibility_schlick_smith, (0.5, 0.6, 10.0)),
        (brdf.visibility_bo2, (0.5, 0.3)),
        (brdf.visibility_none, (0.5, 0.6)),
        (brdf.visibility_cook_torrance, (0.5, 0.6, 0.9, 0.7)),
        (brdf.visibility_kelemen, (0.5,)),
        (brdf.blinn_phong_to_beckmann, (10.0,)),
        (brdf.beckmann_to_blinn_phong, (0.3,)),
        (brdf.blinn_phong_to_phong, (10.0,)),
        (brdf.gloss_to_roughness, (0.5,)),
        (brdf.roughness_to_gloss, (0.5,)),
    ],
)
def test_term_dtypes(func, args):
    assert np.asarray(func(*args)).dtype == np.float32  # Python floats -> float32
    for dtype in (np.float32, np.float64):
        arrays = [np.full((2, 3), a, dtype) for a in args]
        out = func(*arrays)
        assert out.dtype == dtype and out.shape == (2, 3)
    # one float64 array among Python floats computes in float64
    mixed = [np.float64(args[0]), *args[1:]]
    assert np.asarray(func(*mixed)).dtype == np.float64


def test_gloss_clamp_and_nan():
    np.testing.assert_array_equal(brdf.specular_power([2.0, -1.0]), [8192.0, 1.0])
    v = unit(np.array([0.3, 0.0, 1.0]))
    l = unit(np.array([-0.2, 0.1, 1.0]))
    args = (N, v, l, np.full(3, 0.5), np.full(3, 0.04))
    for model in brdf.MODELS:
        for out_of_range, inside in ((2.0, 1.0), (-1.0, 0.0)):
            a = brdf.direct_brdf(*args, np.float64(out_of_range), model)[1]
            b = brdf.direct_brdf(*args, np.float64(inside), model)[1]
            np.testing.assert_array_equal(a, b)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            d, s = brdf.direct_brdf(*args, np.float64(np.nan), model)
            assert np.all(np.isnan(s)) and np.all(np.isfinite(d))
            assert np.isnan(brdf.specular_power(np.nan))
            assert np.isnan(brdf.gloss_to_roughness(np.nan))
            assert np.isnan(brdf.roughness_to_gloss(np.nan))
            assert np.isnan(brdf.visibility_bo2(0.5, np.nan))
    np.testing.assert_array_equal(
        brdf.gloss_to_roughness([2.0, -1.0]), brdf.gloss_to_roughness([1, 0])
    )


@pytest.mark.parametrize("model", brdf.MODELS)
def test_light_below_horizon_gives_exact_zero(model):
    l = unit(np.array([[0.5, 0.0, -0.1], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.3, 0.2, -0.9]]))
    v = unit(np.array([-0.5, 0.0, 0.1]))
    for gloss in (0.0, 1.0, np.nan):
        d, s = brdf.direct_brdf(N, v, l, np.full(3, 0.8), np.full(3, 1.0), np.float64(gloss), model)
        assert np.all(d == 0.0) and np.all(s == 0.0)


@pytest.mark.parametrize("model", brdf.MODELS)
def test_view_below_horizon_is_finite(model):
    # n.v <= 0 (normal-mapped surfaces) is shaded with n.v clamped to N_DOT_V_MIN
    v = unit(np.array([[0.8, 0.0, -0.2], [1.0, 0.0, 0.0], [-0.7, 0.0, 0.0]]))
    l = unit(np.array([0.7, 0.0, 0.1]))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d, s = brdf.direct_brdf(N, v, l, np.full(3, 0.8), np.full(3, 0.04), 0.7, model)
    assert np.all(np.isfinite(s)) and np.all(s >= 0.0) and np.all(d > 0.0)


def test_unknown_model_is_rejected():
    assert brdf.MODELS == ("reference", "bo2", "none", "cook_torrance", "kelemen")
    with pytest.raises(ValueError, match="reference.*bo2.*none.*cook_torrance.*kelemen"):
        brdf.direct_brdf(N, N, N, np.ones(3), np.ones(3), 0.5, model="ggx")
