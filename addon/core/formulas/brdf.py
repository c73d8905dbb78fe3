"""Direct-lighting BRDF of Black Ops / Black Ops II: NDF, Fresnel and visibility terms.

The specular BRDF is the Cook-Torrance microfacet form rewritten as in the talk (slide
"Black Ops: Microfacet BRDF")::

    f(l, v) = D(h) F(l, h) G(l, v, h) / (4 (n.l)(n.v)) = (1/pi) D_pl(h) F(l, h) V(l, v, h)

    with  D_pl(h) = (pi/4) D(h)      (the "point light" NDF)
          V(l, v, h) = G(l, v, h) / ((n.l)(n.v))

so every visibility function here is ``V = G / ((n.l)(n.v))``, *without* the factor 1/4 that
some texts fold into their "visibility" term; the 1/4 lives in ``D_pl``. The diffuse BRDF is
Lambert, ``albedo / pi`` (slide "Black Ops: shading model").

Conventions: gloss g in [0, 1], specular power alpha = 8192^g; directions are unit vectors of
shape (..., 3), ``v`` pointing from the surface to the eye and ``l`` from the surface to the
light; ``h = normalize(l + v)``. Functions compute in float64 when any floating-point array
argument is float64 and in float32 otherwise (Python floats, ints and integer arrays give
float32); the result has that dtype.

References
----------
- D. Lazarov, "Getting More Physical in Call of Duty: Black Ops II", SIGGRAPH 2013 course
  "Physically Based Shading in Theory and Practice" (slides cited per function).
- R. L. Cook, K. E. Torrance, "A Reflectance Model for Computer Graphics", ACM Transactions
  on Graphics 1(1), 1982.
- C. Schlick, "An Inexpensive BRDF Model for Physically-based Rendering", Computer Graphics
  Forum 13(3), 1994.
- C. Kelemen, L. Szirmay-Kalos, "A Microfacet Based Coupled Specular-Matte BRDF Model with
  Importance Sampling", Eurographics 2001 short presentations.
- B. Walter, S. R. Marschner, H. Li, K. E. Torrance, "Microfacet Models for Refraction
  through Rough Surfaces", Eurographics Symposium on Rendering 2007 (Phong/Beckmann
  parameter conversion).
"""

import math

import numpy as np

__all__ = [
    "MODELS",
    "N_DOT_V_MIN",
    "beckmann_to_blinn_phong",
    "blinn_phong_to_beckmann",
    "blinn_phong_to_phong",
    "direct_brdf",
    "fresnel_bo2",
    "fresnel_schlick",
    "gloss_to_roughness",
    "ndf_blinn_phong",
    "ndf_blinn_phong_pl",
    "roughness_to_gloss",
    "schlick_smith_k",
    "specular_power",
    "visibility_bo2",
    "visibility_cook_torrance",
    "visibility_kelemen",
    "visibility_none",
    "visibility_schlick_smith",
]

MODELS = ("reference", "bo2", "none", "cook_torrance", "kelemen")
"""Model names accepted by :func:`direct_brdf`."""

N_DOT_V_MIN = 1e-5
"""Lower clamp of n.v in :func:`direct_brdf` (views from below the horizon, e.g. normal maps)."""

_EPS = 1e-6  # lower clamp of the cosines that appear in denominators (v.h, l.h, n.l)
_LOG2_8192 = 13.0  # 8192 = 2^13
_INV_PI = 1.0 / math.pi


def _dtype(*args):
    """float64 if any floating-point array argument is float64 (or wider), else float32."""
    kinds = [
        a.dtype for a in args if isinstance(a, (np.ndarray, np.generic)) and a.dtype.kind == "f"
    ]
    return np.result_type(np.float32, *kinds)


def _arrays(*args):
    dt = _dtype(*args)
    return dt, [np.asarray(a, dtype=dt) for a in args]


def _clip01(x):
    return np.clip(x, 0.0, 1.0)


def specular_power(gloss):
    """Blinn-Phong specular power alpha = 8192^g.

    Slide "Black Ops: normal distribution function" (Lazarov 2013).

    gloss:   (...,) gloss g; out-of-range gloss is clamped to [0, 1], NaN stays NaN
    returns: (...,) alpha in [1, 8192], dimensionless
    """
    dt, (g,) = _arrays(gloss)
    return np.asarray(np.exp2(_LOG2_8192 * _clip01(g)), dtype=dt)


def ndf_blinn_phong_pl(n_dot_h, alpha):
    """Point-light Blinn-Phong NDF D_pl(h) = (alpha + 2)/8 (n.h)^alpha.

    Slide "Black Ops: normal distribution function" (Lazarov 2013); D_pl = (pi/4) D, see
    :func:`ndf_blinn_phong`.

    n_dot_h: (...,) cosine between normal and half vector, clamped to [0, 1]
    alpha:   (...,) specular power (>= 0)
    returns: broadcast shape, dimensionless (its peak is (alpha + 2)/8 at n.h = 1)
    """
    dt, (c, a) = _arrays(n_dot_h, alpha)
    return np.asarray((a + 2.0) * 0.125 * np.power(_clip01(c), a), dtype=dt)


def ndf_blinn_phong(n_dot_h, alpha):
    """Normalized Blinn-Phong NDF D(h) = (alpha + 2)/(2 pi) (n.h)^alpha.

    Slide "Black Ops: Microfacet BRDF" (Lazarov 2013): D = (4/pi) D_pl. Normalized so that
    the integral of D(h) (n.h) over the hemisphere of h is 1.

    n_dot_h: (...,) cosine between normal and half vector, clamped to [0, 1]
    alpha:   (...,) specular power (>= 0)
    returns: broadcast shape, in 1/sr
    """
    dt, (c, a) = _arrays(n_dot_h, alpha)
    return np.asarray((a + 2.0) * (0.5 * _INV_PI) * np.power(_clip01(c), a), dtype=dt)


def fresnel_schlick(rf0, l_dot_h):
    """Schlick's Fresnel reflectance F = rf0 + (1 - rf0) (1 - l.h)^5.

    Slide "Black Ops: reflectance function" (Lazarov 2013); Schlick 1994.

    rf0:     (..., 3) or (...,) base reflectance (specular colour), linear, in [0, 1]
    l_dot_h: cosine between light and half vector, clamped to [0, 1]; broadcast with rf0 by
             ordinary NumPy rules, so for RGB pass ``l_dot_h[..., None]``
    returns: broadcast shape, dimensionless
    """
    dt, (f0, x) = _arrays(rf0, l_dot_h)
    t = 1.0 - _clip01(x)
    t2 = t * t
    return np.asarray(f0 + (1.0 - f0) * (t2 * t2 * t), dtype=dt)


def fresnel_bo2(rf0, l_dot_h):
    """Black Ops II optimized Fresnel F_opt = rf0 + (1 - rf0) 2^(-10 l.h).

    Bonus slide "Black Ops II: new Fresnel approximation" (Lazarov 2013). Its error against
    :func:`fresnel_schlick` is tabulated in docs/model.md.

    rf0:     (..., 3) or (...,) base reflectance, linear, in [0, 1]
    l_dot_h: cosine between light and half vector, clamped to [0, 1]; broadcast with rf0 by
             ordinary NumPy rules, so for RGB pass ``l_dot_h[..., None]``
    returns: broadcast shape, dimensionless
    """
    dt, (f0, x) = _arrays(rf0, l_dot_h)
    return np.asarray(f0 + (1.0 - f0) * np.exp2(-10.0 * _clip01(x)), dtype=dt)


def schlick_smith_k(alpha):
    """Schlick-Smith parameter k = 2 / sqrt(pi (alpha + 2)).

    Slide "Black Ops: visibility function" (Lazarov 2013). This is Schlick's k = m sqrt(2/pi)
    for the Beckmann width m = sqrt(2/(alpha + 2)) (see :func:`blinn_phong_to_beckmann`).

    alpha:   (...,) specular power
    returns: (...,) k, dimensionless; 0.6515 at alpha = 1, 0.01247 at alpha = 8192
    """
    dt, (a,) = _arrays(alpha)
    return np.asarray(2.0 / np.sqrt(math.pi * (a + 2.0)), dtype=dt)


def visibility_schlick_smith(n_dot_l, n_dot_v, alpha):
    """Schlick-Smith visibility V = 1 / (((n.l)(1 - k) + k) ((n.v)(1 - k) + k)).

    Slide "Black Ops: visibility function" (Lazarov 2013); Schlick 1994. V = G/((n.l)(n.v))
    with G the product of Schlick's two masking terms.

    n_dot_l: (...,) cosine between normal and light, clamped to [0, 1]
    n_dot_v: (...,) cosine between normal and view, clamped to [0, 1]
    alpha:   (...,) specular power
    returns: broadcast shape, dimensionless (1 at normal incidence, at most 1/k^2)
    """
    dt, (nl, nv, a) = _arrays(n_dot_l, n_dot_v, alpha)
    k = schlick_smith_k(a)
    one_k = 1.0 - k
    return np.asarray(1.0 / ((_clip01(nl) * one_k + k) * (_clip01(nv) * one_k + k)), dtype=dt)


def visibility_bo2(v_dot_h, gloss):
    """Black Ops II optimized visibility V_opt = 1 / (k (v.h)^2 + (1 - k)), k = min(1, g + 0.545).

    Bonus slide "Black Ops II: new visibility function approximation" (Lazarov 2013):
    "visually matched in game (not an exact fit)". For g >= 0.455 it equals the Kelemen form
    1/(v.h)^2. Its error against :func:`visibility_schlick_smith` is tabulated in
    docs/model.md.

    v_dot_h: (...,) cosine between view and half vector, clamped to [1e-6, 1]
    gloss:   (...,) gloss; out-of-range gloss is clamped to [0, 1], NaN stays NaN
    returns: broadcast shape, dimensionless
    """
    dt, (x, g) = _arrays(v_dot_h, gloss)
    k = np.minimum(1.0, _clip01(g) + 0.545)
    x = np.clip(x, _EPS, 1.0)
    return np.asarray(1.0 / (k * (x * x) + (1.0 - k)), dtype=dt)


def visibility_none(n_dot_l, n_dot_v):
    """No visibility term: V = 1 (G = (n.l)(n.v), the "implicit" geometry term).

    Slide "Black Ops: visibility function" (Lazarov 2013), listed as a comparison.

    n_dot_l: (...,) cosine between normal and light (only its shape and dtype are used)
    n_dot_v: (...,) cosine between normal and view (only its shape and dtype are used)
    returns: broadcast shape, ones
    """
    dt, (nl, nv) = _arrays(n_dot_l, n_dot_v)
    return np.ones(np.broadcast_shapes(nl.shape, nv.shape), dtype=dt)


def visibility_cook_torrance(n_dot_l, n_dot_v, n_dot_h, v_dot_h):
    """Cook-Torrance visibility V = G/((n.l)(n.v)).

    G = min(1, 2(n.h)(n.v)/(v.h), 2(n.h)(n.l)/(v.h)).

    Slide "Black Ops: visibility function" (Lazarov 2013), listed as a comparison; Cook &
    Torrance 1982 (V-cavity geometry term, independent of gloss). Evaluated as
    min(1/((n.l)(n.v)), 2(n.h)/((v.h)(n.l)), 2(n.h)/((v.h)(n.v))), the same value without the
    0/0 at grazing angles; n.l, n.v and v.h are clamped to [1e-6, 1], n.h to [0, 1].

    n_dot_l, n_dot_v, n_dot_h, v_dot_h: (...,) cosines, broadcast together
    returns: broadcast shape, dimensionless
    """
    dt, (nl, nv, nh, vh) = _arrays(n_dot_l, n_dot_v, n_dot_h, v_dot_h)
    nl = np.clip(nl, _EPS, 1.0)
    nv = np.clip(nv, _EPS, 1.0)
    vh = np.clip(vh, _EPS, 1.0)
    two_nh_vh = 2.0 * _clip01(nh) / vh
    v = np.minimum(1.0 / (nl * nv), np.minimum(two_nh_vh / nl, two_nh_vh / nv))
    return np.asarray(v, dtype=dt)


def visibility_kelemen(l_dot_h):
    """Kelemen/Szirmay-Kalos visibility V = G/((n.l)(n.v)) ~= 1/(l.h)^2.

    Slide "Black Ops: visibility function" (Lazarov 2013), listed as a comparison; Kelemen &
    Szirmay-Kalos 2001 approximate G/((n.l)(n.v)) by 2/(1 + l.v) = 1/(l.h)^2 (independent of
    gloss). In the talk's convention f = (1/pi) D_pl F V this gives f = D F / (4 (l.h)^2);
    texts whose visibility includes the 1/4 write it as 1/(4 (l.h)^2).

    l_dot_h: (...,) cosine between light and half vector (= v.h), clamped to [1e-6, 1]
    returns: (...,) dimensionless, >= 1
    """
    dt, (x,) = _arrays(l_dot_h)
    x = np.clip(x, _EPS, 1.0)
    return np.asarray(1.0 / (x * x), dtype=dt)


def blinn_phong_to_beckmann(alpha):
    """Beckmann roughness m = sqrt(2/(alpha + 2)) of a Blinn-Phong power alpha.

    Slide "Black Ops: normal distribution function" (Lazarov 2013): "cheaper replacement for
    Beckmann NDF (with parameter conversion)"; the conversion is Walter et al. 2007 (section
    on the Phong distribution: alpha_p = 2 alpha_b^-2 - 2).

    alpha:   (...,) specular power (>= 0)
    returns: (...,) Beckmann m (RMS slope), in (0, sqrt(2)]
    """
    dt, (a,) = _arrays(alpha)
    return np.asarray(np.sqrt(2.0 / (a + 2.0)), dtype=dt)


def beckmann_to_blinn_phong(m):
    """Blinn-Phong power alpha = 2/m^2 - 2 of a Beckmann roughness m (Walter et al. 2007).

    Slide "Black Ops: normal distribution function" (Lazarov 2013); inverse of
    :func:`blinn_phong_to_beckmann`.

    m:       (...,) Beckmann roughness (RMS slope), > 0
    returns: (...,) specular power (negative for m > sqrt(2): no Blinn-Phong equivalent)
    """
    dt, (mm,) = _arrays(m)
    return np.asarray(2.0 / (mm * mm) - 2.0, dtype=dt)


def blinn_phong_to_phong(alpha):
    """Phong power of a Blinn-Phong power: alpha_phong = alpha_blinn_phong / 4.

    Slide "Improved environment map pre-filtering" (Lazarov 2013).

    alpha:   (...,) Blinn-Phong specular power
    returns: (...,) Phong specular power
    """
    dt, (a,) = _arrays(alpha)
    return np.asarray(a * 0.25, dtype=dt)


def gloss_to_roughness(gloss):
    """Blender Principled BSDF roughness r of a gloss g: r = (2/(alpha + 2))^(1/4).

    Built from alpha = 8192^g (slide "Black Ops: normal distribution function", Lazarov
    2013), the Blinn-Phong/Beckmann conversion m = sqrt(2/(alpha + 2)) (Walter et al. 2007),
    the usual equivalence Beckmann m ~= GGX alpha_ggx, and Blender's alpha_ggx = r^2. Gloss
    0 maps to r = (2/3)^(1/4) ~= 0.904 and gloss 1 to r = (2/8194)^(1/4) ~= 0.125.

    gloss:   (...,) gloss; out-of-range gloss is clamped to [0, 1], NaN stays NaN
    returns: (...,) roughness in [0.125, 0.904]
    """
    dt, (g,) = _arrays(gloss)
    alpha = specular_power(g)
    return np.asarray(np.sqrt(np.sqrt(2.0 / (alpha + 2.0))), dtype=dt)


def roughness_to_gloss(roughness):
    """Gloss of a Blender Principled BSDF roughness r: g = log(2/r^4 - 2) / log(8192).

    Inverse of :func:`gloss_to_roughness` (same construction: Walter et al. 2007, Beckmann
    m ~= r^2, slide "Black Ops: normal distribution function", Lazarov 2013). The gloss range
    covers only part of Blender's: r above (2/3)^(1/4) ~= 0.904 maps to gloss 0 and r below
    (2/8194)^(1/4) ~= 0.125 to gloss 1.

    roughness: (...,) roughness; clamped to [0, 1], NaN stays NaN
    returns:   (...,) gloss in [0, 1]
    """
    dt, (r,) = _arrays(roughness)
    r2 = _clip01(r)
    r2 = r2 * r2
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = 2.0 / (r2 * r2) - 2.0
        # alpha <= 0 (r >= 0.904...) gives -inf or NaN from the log; both mean gloss 0
        g = np.log2(np.maximum(alpha, 0.0)) / _LOG2_8192
    return np.asarray(_clip01(g), dtype=dt)


def _dot(a, b):
    """Dot product over the last axis of size 3 (component-wise: a reduction over an axis of 3
    costs several times more in NumPy)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def direct_brdf(n, v, l, albedo, rf0, gloss, model="reference"):
    """Diffuse and specular response to one light: f(l, v) (n.l), split in two terms.

    Slides "Black Ops: shading model", "Black Ops: Microfacet BRDF" and the slides of each
    term (Lazarov 2013):

        diffuse  = albedo / pi * (n.l)                      (Lambert)
        specular = (1/pi) D_pl(h) F(l, h) V(l, v, h) * (n.l)

    i.e. the reflected radiance per unit irradiance of the light measured perpendicular to
    its direction (multiply by that irradiance, e.g. a sun's W/m^2, to get radiance).

    ``model`` selects the terms:

    - "reference": D_pl, Schlick Fresnel, Schlick-Smith visibility (Black Ops);
    - "bo2": D_pl, BO2 Fresnel, BO2 visibility (the optimized Black Ops II terms);
    - "none", "cook_torrance", "kelemen": D_pl, Schlick Fresnel and that visibility (the
      comparisons of slide "Black Ops: visibility function").

    A light below the horizon (n.l <= 0) gives exactly 0 in both terms. A view below the
    horizon (n.v <= 0, e.g. with normal maps) is shaded with n.v clamped to
    ``N_DOT_V_MIN`` = 1e-5.

    n, v, l: (..., 3) unit normal, direction to the eye, direction to the light
    albedo:  (..., 3) diffuse albedo, linear, in [0, 1]
    rf0:     (..., 3) specular base reflectance, linear, in [0, 1]
    gloss:   (...,) gloss (clamped to [0, 1], NaN stays NaN and gives a NaN specular)
    model:   one of ``MODELS``
    returns: (diffuse, specular), each of the broadcast shape (..., 3), in 1/sr (radiance
             per unit perpendicular irradiance); float64 if any floating input is float64,
             else float32
    """
    if model not in MODELS:
        raise ValueError(f"unknown model {model!r}; expected one of: {', '.join(MODELS)}")
    dt, (n, v, l, albedo, rf0, gloss) = _arrays(n, v, l, albedo, rf0, gloss)
    shape = np.broadcast_shapes(
        n.shape, v.shape, l.shape, albedo.shape, rf0.shape, gloss.shape + (1,)
    )
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        n_dot_l = _dot(n, l)
        lit = n_dot_l > 0.0
        n_dot_l = np.where(lit, n_dot_l, 0.0).astype(dt, copy=False)
        n_dot_v = np.maximum(_dot(n, v), N_DOT_V_MIN).astype(dt, copy=False)
        h = l + v
        h = h / np.maximum(np.sqrt(_dot(h, h)), _EPS)[..., None]
        n_dot_h = _dot(n, h)
        l_dot_h = _dot(l, h)
        v_dot_h = _dot(v, h)
        alpha = specular_power(gloss)
        d_pl = ndf_blinn_phong_pl(n_dot_h, alpha)
        if model == "bo2":
            fresnel = fresnel_bo2(rf0, l_dot_h[..., None])
            vis = visibility_bo2(v_dot_h, gloss)
        else:
            fresnel = fresnel_schlick(rf0, l_dot_h[..., None])
            if model == "reference":
                vis = visibility_schlick_smith(n_dot_l, n_dot_v, alpha)
            elif model == "none":
                vis = visibility_none(n_dot_l, n_dot_v)
            elif model == "cook_torrance":
                vis = visibility_cook_torrance(n_dot_l, n_dot_v, n_dot_h, v_dot_h)
            else:
                vis = visibility_kelemen(l_dot_h)
        spec = (d_pl * vis * n_dot_l * _INV_PI)[..., None] * fresnel
        spec = np.where(lit[..., None], spec, 0.0)
        diffuse = np.where(lit[..., None], albedo * (n_dot_l * _INV_PI)[..., None], 0.0)
    diffuse = np.array(np.broadcast_to(diffuse, shape), dtype=dt)
    specular = np.array(np.broadcast_to(spec, shape), dtype=dt)
    return diffuse, specular
