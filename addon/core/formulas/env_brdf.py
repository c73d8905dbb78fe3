"""Environment BRDF: the talk's ground truth, its BO1 and BO2 approximations, a table and our fit.

Slides "Environment lighting: split approximation" and "Environment BRDF: reflectance
interpolation" (Lazarov 2013). The environment BRDF is the directional albedo of the specular
BRDF of the talk,

    E(g, n.v, rf0) = integral over the hemisphere of  D_env(h) F(l, h) V(l, v, h) (n.l) dl,
    D_env(h) = (alpha + 2) / (8 pi) (n.h)^alpha,     alpha = 8192^g,

and, with Schlick's F = rf0 + (1 - rf0)(1 - h.l)^5, it splits into two parts that do not
depend on rf0:

    E = rf0 a1(g, n.v) + (1 - rf0) a0(g, n.v),
    a1 = integral of D_env V (n.l)                  (the "rf0 = 1" curves),
    a0 = integral of D_env V (1 - h.l)^5 (n.l)      (the "rf0 = 0" curves).

``ground_truth`` integrates both parts by deterministic quadrature over the half vector;
``ground_truth_sampled`` integrates them by importance sampling of the lobe (a second,
independent method: the tests hold them to each other). ``V`` is the talk's Schlick-Smith
visibility (``visibility="reference"``) or the BO2 optimized visibility (``"bo2"``).

Models of ``environment_brdf`` (``MODELS``):

- "truth":  the quadrature itself (slow; for tools and tests);
- "table":  bilinear look-up in the shipped 64 x 64 table of the quadrature
  (``env_brdf_table.npz``, written by ``tools/make_env_brdf_table.py``);
- "bo1":    Black Ops' environment "Fresnel", rf0 + (1 - rf0)(1 - n.v)^5 / (4 - 3g)
  (slide "Black Ops: environment map 'Fresnel'");
- "bo2":    Black Ops II's ``EnvironmentBRDF(g, NoV, rf0)`` (slide "Final approximation");
- "fit":    our own fit, BO2's cost plus two operations (``tools/fit_env_brdf.py``;
  docs/env_brdf.md).

Inputs are clamped: gloss to [0, 1], n.v to [N_DOT_V_MIN, 1], rf0 to [0, 1]; NaN stays NaN.

References
----------
- D. Lazarov, "Getting More Physical in Call of Duty: Black Ops II", SIGGRAPH 2013 course
  "Physically Based Shading in Theory and Practice" (slides cited per function).
- C. Schlick, "An Inexpensive BRDF Model for Physically-based Rendering", Computer Graphics
  Forum 13(3), 1994.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np

from . import brdf

__all__ = [
    "FIT_A0",
    "FIT_A1",
    "MODELS",
    "N_DOT_V_MIN",
    "TABLE_PATH",
    "a004",
    "a0r",
    "a1vf",
    "bo1_environment_fresnel",
    "diffuse_layering",
    "environment_brdf",
    "environment_brdf_bo2",
    "fit_parts",
    "ground_truth",
    "ground_truth_sampled",
    "table_parts",
]

MODELS = ("truth", "table", "bo1", "bo2", "fit")
"""Model names accepted by :func:`environment_brdf`."""

N_DOT_V_MIN = 1e-4
"""Lower clamp of n.v (the integrals are finite at n.v = 0, the table's first column)."""

TABLE_PATH = Path(__file__).with_name("env_brdf_table.npz")
"""The shipped table: arrays ``gloss`` (G,), ``n_dot_v`` (N,) and ``reference`` / ``bo2``
(2, G, N) float32 with the parts a0 (index 0) and a1 (index 1) of each visibility."""

# Our fit (tools/fit_env_brdf.py prints these numbers; docs/env_brdf.md shows its error).
# t = c g + d,  m = min(t.y, 2^(k n.v)),  a0 = t.x m + t.z,  a1 = min(s m + t.w, 1):
FIT_A0 = (0.9291, 0.0076, 0.5635, -0.0212, -0.0196, 0.0050,  # cx, dx, cy, dy, cz, dz
          -8.2329)  # k
FIT_A1 = (1.4364, 0.3397, -2.3334)  # cw, dw, s


def _clamped(gloss, n_dot_v):
    g = np.clip(np.asarray(gloss, np.float64), 0.0, 1.0)
    nv = np.clip(np.asarray(n_dot_v, np.float64), N_DOT_V_MIN, 1.0)
    return g, nv


# --------------------------------------------------------------------------------------------
# ground truth


def _visibility(visibility: str, nl, nv, vh, alpha, g):
    if visibility == "reference":
        return brdf.visibility_schlick_smith(nl, nv, alpha)
    if visibility == "bo2":
        return brdf.visibility_bo2(vh, g)
    raise ValueError(f"unknown visibility {visibility!r}; expected 'reference' or 'bo2'")


def _gauss_legendre(n: int, a, b):
    """Nodes and weights of n-point Gauss-Legendre on [a, b] (broadcast): (..., n) each."""
    x, w = np.polynomial.legendre.leggauss(n)
    a, b = np.asarray(a, np.float64)[..., None], np.asarray(b, np.float64)[..., None]
    half = 0.5 * (b - a)
    return a + half * (x + 1.0), half * w


def _phi_limit(cos_v, sin_v, c_h, s_h):
    """Azimuth phi0 in [0, pi] of the half vector beyond which l = reflect(v, h) goes below
    the horizon: n.l = 2 (v.h)(n.h) - n.v > 0  <=>  cos(phi) > c0."""
    with np.errstate(divide="ignore", invalid="ignore"):
        c0 = (cos_v / (2.0 * c_h) - cos_v * c_h) / (sin_v * s_h)
    c0 = np.where(np.isfinite(c0), c0, np.where(cos_v / (2.0 * c_h) > cos_v * c_h, 1.0, -1.0))
    return np.arccos(np.clip(c0, -1.0, 1.0))


def _parts_given_h(c_h, s_h, phi, cos_v, sin_v, alpha, g, visibility):
    """Integrand F-parts times V (n.l)(v.h)/(n.h) at half vectors (c_h, s_h, phi)."""
    vh = sin_v * s_h * np.cos(phi) + cos_v * c_h
    nl = 2.0 * vh * c_h - cos_v
    ok = nl > 0.0
    nl = np.where(ok, nl, 0.0)
    vis = _visibility(visibility, nl, cos_v, vh, alpha, g)
    common = np.where(ok, vis * nl * vh / c_h, 0.0)
    t = 1.0 - np.clip(vh, 0.0, 1.0)  # l.h = v.h
    return common * (t * t) * (t * t) * t, common


def ground_truth(gloss, n_dot_v, visibility: str = "reference", nodes: int = 48):
    """Parts (a0, a1) of the environment BRDF by deterministic quadrature, float64.

    Slide "Environment BRDF: reflectance interpolation" (Lazarov 2013). With the half vector
    h as variable (dl = 4 (v.h) dh) and u = (n.h)^(alpha + 2), the lobe's cumulative
    distribution, the integral becomes

        a = integral_0^1 du  (1/pi) integral_0^phi0(u) dphi  F V (n.l)(v.h)/(n.h),

    smooth in phi on [0, phi0] (phi0: where l crosses the horizon, known in closed form) and
    in u once split where phi0 reaches 0 or pi. Each piece is ``nodes``-point Gauss-Legendre
    in both variables.

    gloss, n_dot_v: broadcast together, shape S (clamped, see the module docstring)
    visibility: "reference" (Schlick-Smith) or "bo2" (BO2 optimized)
    returns: (a0, a1), each of shape S, float64
    """
    g, nv = _clamped(gloss, n_dot_v)
    g, nv = np.broadcast_arrays(g, nv)
    shape = g.shape
    g, nv = g.reshape(-1), nv.reshape(-1)
    out0, out1 = np.zeros(g.size), np.zeros(g.size)
    with np.errstate(divide="ignore", invalid="ignore"):  # u = 0, c_h = 0: weight 0
        for lo in range(0, g.size, 64):  # bounded memory: 64 x 2 x nodes^2 evaluations at once
            sl = slice(lo, lo + 64)
            out0[sl], out1[sl] = _ground_truth_flat(g[sl], nv[sl], visibility, nodes)
    return out0.reshape(shape), out1.reshape(shape)


def _horizon_breaks(cos_v, sin_v):
    """cos(theta_h) where phi0 leaves pi (c0 = -1) and where it reaches 0 (c0 = +1), (M,) each.

    c0 falls monotonically from +inf (c_h -> 0) to -inf (c_h -> 1), so each is found by
    bisection; 60 halvings reach float64 resolution."""
    def c0(c_h):
        s_h = np.sqrt(np.maximum(1.0 - c_h * c_h, 0.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            return (cos_v / (2.0 * c_h) - cos_v * c_h) / np.maximum(sin_v * s_h, 1e-300)

    breaks = []
    for target in (-1.0, 1.0):
        lo, hi = np.full_like(cos_v, 1e-9), np.ones_like(cos_v)  # c0 decreases as c_h grows
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            above = c0(mid) > target
            lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
        breaks.append(0.5 * (lo + hi))
    return breaks[0], breaks[1]


def _ground_truth_flat(g, nv, visibility, nodes):
    alpha = brdf.specular_power(g).astype(np.float64)
    cos_v, sin_v = nv, np.sqrt(np.maximum(1.0 - nv * nv, 0.0))
    c_pi, c_zero = _horizon_breaks(cos_v, sin_v)  # c_zero < c_pi: phi0 = 0 below c_zero
    # u = c^(alpha + 2) at the breaks, computed in logs (c^8194 underflows for small c)
    u_zero = np.exp((alpha + 2.0) * np.log(c_zero))
    u_pi = np.exp((alpha + 2.0) * np.log(c_pi))
    a0 = np.zeros(g.size)
    a1 = np.zeros(g.size)
    for u_lo, u_hi in ((u_zero, u_pi), (u_pi, np.ones_like(u_pi))):
        u, wu = _gauss_legendre(nodes, u_lo, u_hi)  # (M, n)
        with np.errstate(divide="ignore"):
            c_h = np.exp(np.log(u) / (alpha + 2.0)[:, None])
        s_h = np.sqrt(np.maximum(1.0 - c_h * c_h, 0.0))
        cv, sv = cos_v[:, None], sin_v[:, None]
        phi0 = _phi_limit(cv, sv, c_h, s_h)
        phi, wphi = _gauss_legendre(nodes, np.zeros_like(phi0), phi0)  # (M, n, n)
        f0, f1 = _parts_given_h(c_h[..., None], s_h[..., None], phi, cv[..., None],
                                sv[..., None], alpha[:, None, None], g[:, None, None],
                                visibility)
        weight = wu[..., None] * wphi / np.pi
        a0 += (f0 * weight).sum((1, 2))
        a1 += (f1 * weight).sum((1, 2))
    return a0, a1


def ground_truth_sampled(gloss, n_dot_v, visibility: str = "reference", samples: int = 1 << 16):
    """Parts (a0, a1) by importance sampling of the lobe, float64: the independent check.

    Half vectors are drawn from D(h)(n.h), cos(theta_h) = u^(1/(alpha + 2)), phi = 2 pi w,
    with (u, w) a rank-1 lattice (Fibonacci) over ``samples`` points randomly shifted by a
    fixed seed; l = reflect(v, h) and the estimator of each part is F V (n.l)(v.h)/(n.h)
    (0 below the horizon), the lobe's pdf having cancelled D.

    gloss, n_dot_v: broadcast together, shape S;  returns: (a0, a1) of shape S
    """
    g, nv = _clamped(gloss, n_dot_v)
    g, nv = np.broadcast_arrays(g, nv)
    shape = g.shape
    g, nv = g.reshape(-1), nv.reshape(-1)
    fib = [1, 1]
    while fib[-1] < samples:
        fib.append(fib[-1] + fib[-2])
    n, step = fib[-1], fib[-2]
    i = np.arange(n, dtype=np.float64)
    shift = np.random.default_rng(2013).random(2)
    u = (i / n + shift[0]) % 1.0
    w = (i * step / n + shift[1]) % 1.0
    a0, a1 = np.zeros(g.size), np.zeros(g.size)
    for k in range(g.size):
        alpha = float(brdf.specular_power(g[k]))
        c_h = np.exp(np.log(np.maximum(u, 1e-300)) / (alpha + 2.0))
        s_h = np.sqrt(np.maximum(1.0 - c_h * c_h, 0.0))
        cos_v = nv[k]
        sin_v = np.sqrt(max(1.0 - cos_v * cos_v, 0.0))
        with np.errstate(divide="ignore", invalid="ignore"):
            f0, f1 = _parts_given_h(c_h, s_h, 2.0 * np.pi * w, cos_v, sin_v, alpha, g[k],
                                    visibility)
        a0[k], a1[k] = f0.mean(), f1.mean()
    return a0.reshape(shape), a1.reshape(shape)


# --------------------------------------------------------------------------------------------
# the table


@lru_cache(maxsize=1)
def table_arrays() -> dict[str, np.ndarray]:
    with np.load(TABLE_PATH) as data:
        return {name: data[name] for name in data.files}


def table_parts(gloss, n_dot_v, visibility: str = "reference"):
    """Parts (a0, a1) by bilinear look-up in the shipped table ("Ground truth (table)").

    gloss, n_dot_v: broadcast together, shape S (clamped);  returns: float32 (a0, a1) of S
    """
    t = table_arrays()
    if visibility not in ("reference", "bo2"):
        raise ValueError(f"unknown visibility {visibility!r}; expected 'reference' or 'bo2'")
    g, nv = _clamped(gloss, n_dot_v)
    gs, nvs = t["gloss"].astype(np.float64), t["n_dot_v"].astype(np.float64)
    fg = np.interp(g, gs, np.arange(gs.size))
    fn = np.interp(nv, nvs, np.arange(nvs.size))
    i0 = np.clip(np.floor(np.nan_to_num(fg)).astype(np.int64), 0, gs.size - 2)
    j0 = np.clip(np.floor(np.nan_to_num(fn)).astype(np.int64), 0, nvs.size - 2)
    tg, tn = fg - i0, fn - j0
    parts = t[visibility].astype(np.float64)
    out = []
    for p in parts:
        top = p[i0, j0] * (1.0 - tn) + p[i0, j0 + 1] * tn
        bottom = p[i0 + 1, j0] * (1.0 - tn) + p[i0 + 1, j0 + 1] * tn
        out.append((top * (1.0 - tg) + bottom * tg).astype(np.float32))
    return out[0], out[1]


# --------------------------------------------------------------------------------------------
# the talk's approximations


def bo1_environment_fresnel(gloss, n_dot_v, rf0):
    """Black Ops' environment "Fresnel" rf0 + (1 - rf0)(1 - n.v)^5 / (4 - 3g).

    Slide "Black Ops: environment map 'Fresnel'" (Lazarov 2013).

    gloss, n_dot_v: (...,);  rf0: (...,) or (..., 3), broadcast with gloss[..., None] for RGB
    returns: broadcast shape, float32
    """
    g, nv = _clamped(gloss, n_dot_v)
    f0 = np.clip(np.asarray(rf0, np.float64), 0.0, 1.0)
    t = 1.0 - nv
    return (f0 + (1.0 - f0) * (t * t) * (t * t) * t / (4.0 - 3.0 * g)).astype(np.float32)


def a1vf(g):
    """The rf0 = 1 part of BO2: 0.25 g + 0.75 (slide "Focus on rf0 = 0.04", where it is
    printed as ``alvf``; ``a0r`` calls it ``a1vf``)."""
    return 0.25 * np.asarray(g, np.float64) + 0.75


def a004(g, n_dot_v):
    """BO2's environment BRDF of rf0 = 0.04 (slide "Approximate curves: rf0 = 0.04"):
    t = min(0.475 g, 2^(-9.28 n.v));  (t + 0.0275) g + 0.015."""
    g = np.asarray(g, np.float64)
    t = np.minimum(0.475 * g, np.exp2(-9.28 * np.asarray(n_dot_v, np.float64)))
    return (t + 0.0275) * g + 0.015


def a0r(g, n_dot_v):
    """BO2's rf0 = 0 part, (a004 - 0.04 a1vf) / 0.96 (slide "Final approximation")."""
    return (a004(g, n_dot_v) - a1vf(g) * 0.04) / 0.96


def environment_brdf_bo2(gloss, n_dot_v, rf0):
    """BO2's ``EnvironmentBRDF(g, NoV, rf0)``, the packed float4 form of slide "Final
    approximation" (Lazarov 2013), operation for operation::

        t  = float4(1/0.96, 0.475, (0.0275 - 0.25 0.04)/0.96, 0.25) g
           + float4(0, 0, (0.015 - 0.75 0.04)/0.96, 0.75)
        a0 = t.x min(t.y, 2^(-9.28 NoV)) + t.z;   a1 = t.w
        return saturate(a0 + rf0 (a1 - a0))

    gloss, n_dot_v: (...,) (clamped);  rf0: (...,) or (..., 3) with gloss[..., None]
    returns: broadcast shape, float32
    """
    g, nv = _clamped(gloss, n_dot_v)
    f0 = np.clip(np.asarray(rf0, np.float64), 0.0, 1.0)
    tx = g * (1.0 / 0.96)
    ty = g * 0.475
    tz = g * ((0.0275 - 0.25 * 0.04) / 0.96) + (0.015 - 0.75 * 0.04) / 0.96
    tw = g * 0.25 + 0.75
    a0 = tx * np.minimum(ty, np.exp2(-9.28 * nv)) + tz
    a1 = tw
    return np.clip(a0 + f0 * (a1 - a0), 0.0, 1.0).astype(np.float32)


def diffuse_layering(layer, layer_f0, gloss, n_dot_v):
    """The weight of a diffuse under a specular layer, as Cycles' Principled BSDF layers them:
    one less the specular's directional albedo toward the eye, which is the environment BRDF,
    here BO2's (``environment_brdf_bo2``), of the layer's largest rf0 channel f0:

        w = 1 - saturate(layer a0 + layer_f0 (a1 - a0))

    with a0 and a1 its parts (``a0r``, ``a1vf``: the BRDF is saturate(a0 + rf0 (a1 - a0))), so
    that a mix of closures
    mixes ``layer`` and ``layer_f0 = layer f0`` (``Closure``: 1 and the dielectric's rf0 for a
    Principled BSDF, whose metal lies beside its diffuse, not above it; 0 for a Diffuse BSDF or
    the BO2 Material group, which adds its two lobes as the talk does).

    layer, layer_f0, gloss, n_dot_v: (N,)
    returns: (N,) float32 in [0, 1]

    Reference: Cycles' ``closure_layering_weight`` (intern/cycles/kernel/closure/
    bsdf_util.h), which scales the closures under a layer by one less the layer's largest
    albedo channel.
    """
    g, nv = _clamped(gloss, n_dot_v)
    a0, a1 = a0r(g, nv), a1vf(g)
    e = np.clip(np.asarray(layer) * a0 + np.asarray(layer_f0) * (a1 - a0), 0.0, 1.0)
    return (1.0 - e).astype(np.float32)


# --------------------------------------------------------------------------------------------
# our fit


def fit_parts(gloss, n_dot_v, a0_coeffs=FIT_A0, a1_coeffs=FIT_A1):
    """Parts (a0, a1) of our fit: BO2's curve of slide "Final approximation" with every
    coefficient free, and a metal part on the same capped exponential (docs/env_brdf.md)::

        t  = c g + d                       (t.x, t.y, t.z, t.w)
        m  = min(t.y, 2^(k n.v))
        a0 = t.x m + t.z
        a1 = min(s m + t.w, 1)

    with (cx, dx, cy, dy, cz, dz, k) = ``a0_coeffs`` and (cw, dw, s) = ``a1_coeffs``, fitted by
    ``tools/fit_env_brdf.py`` to beat BO2's maximum, mean and maximum relative error for
    rf0 = 0, 0.04 and 1 over g in [0, 1], n.v in [0.05, 1]. 10 operations (a float4 MAD, a
    multiply, exp2, min, MAD, MAD, min), two more than BO2's parts; the shader then shares
    BO2's saturate(a0 + rf0 (a1 - a0)).

    gloss, n_dot_v: broadcast together, shape S (clamped);  returns: float64 (a0, a1) of S
    """
    g, nv = _clamped(gloss, n_dot_v)
    cx, dx, cy, dy, cz, dz, k = a0_coeffs
    cw, dw, s = a1_coeffs
    m = np.minimum(cy * g + dy, np.exp2(k * nv))
    return (cx * g + dx) * m + (cz * g + dz), np.minimum(s * m + (cw * g + dw), 1.0)


# --------------------------------------------------------------------------------------------
# all models


def environment_brdf(gloss, n_dot_v, rf0, model: str = "bo2"):
    """The environment BRDF E(g, n.v, rf0) of one of ``MODELS``.

    gloss, n_dot_v: (...,) gloss in [0, 1] and cosine of the view to the normal (clamped)
    rf0:     (...,) or (..., 3) specular colour; for RGB pass gloss and n_dot_v with a
             trailing axis of 1 or use shapes that broadcast
    model:   "truth", "table", "bo1", "bo2" or "fit"
    returns: broadcast shape, float32, dimensionless (the fraction of a uniform environment's
             radiance reflected towards the eye)
    """
    if model == "bo1":
        return bo1_environment_fresnel(gloss, n_dot_v, rf0)
    if model == "bo2":
        return environment_brdf_bo2(gloss, n_dot_v, rf0)
    if model == "truth":
        a0, a1 = ground_truth(gloss, n_dot_v)
    elif model == "table":
        a0, a1 = table_parts(gloss, n_dot_v)
    elif model == "fit":
        a0, a1 = fit_parts(gloss, n_dot_v)
    else:
        raise ValueError(f"unknown model {model!r}; expected one of: {', '.join(MODELS)}")
    f0 = np.clip(np.asarray(rf0, np.float64), 0.0, 1.0)
    e = np.asarray(a0, np.float64) * (1.0 - f0) + np.asarray(a1, np.float64) * f0
    if model == "fit":  # the shader's saturate (its a0 dips below 0 by 0.012 at most)
        e = np.clip(e, 0.0, 1.0)
    return e.astype(np.float32)
