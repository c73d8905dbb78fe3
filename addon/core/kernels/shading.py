"""Direct lighting kernels: each point's incidence from one light, and the talk's BRDF
accumulated over the lights.

References (the NumPy these kernels are held to, pointwise): ``brdf.direct_brdf`` (slides
"Black Ops: shading model", "Black Ops: Microfacet BRDF", the slides of each term and the bonus
slides of the Black Ops II terms) and the light units of ``shade``'s module docstring. The
arithmetic is float64, the results float32.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

_OPTIONS = {"cache": True, "nogil": True}

POINT, SPOT, SUN, AREA = 0, 1, 2, 3
KINDS = {"POINT": POINT, "SPOT": SPOT, "SUN": SUN, "AREA": AREA}
MODELS = {"reference": 0, "bo2": 1, "none": 2, "cook_torrance": 3, "kelemen": 4}
N_DOT_V_MIN = 1e-5  # brdf.N_DOT_V_MIN
_EPS = 1e-6  # brdf._EPS
_INV_PI = 1.0 / math.pi

_F3 = nb.float32[:, ::1]


@nb.njit(nb.float64(nb.float64), **_OPTIONS)
def _clip01(x):
    if x != x:  # NaN stays NaN, as np.clip
        return x
    return min(max(x, 0.0), 1.0)


@nb.njit(nb.void(_F3, _F3, nb.int64, nb.float32[::1], nb.float32[::1], nb.float32[::1],
                 nb.float64, nb.float64, _F3, _F3, nb.boolean[::1]), **_OPTIONS)
def incidence(p, geo, kind, color, position, axis, cos_half, blend, l_out, e_out, lit_out):
    """Direction to one light ``l_out`` (N, 3), its irradiance on a surface facing it
    ``e_out`` (N, 3), W/m^2, and whether the point's geometric normal ``geo`` faces it and it
    gives light (``lit_out``; irradiance 0 where not).

    kind:     ``POINT``, ``SPOT``, ``SUN`` or ``AREA``; color: (3,) colour times power
    position: (3,) the light's position; axis: (3,) the direction it shines along
    cos_half, blend: a spot's cos(size / 2) and its blend
    """
    for i in range(p.shape[0]):
        if kind == SUN:
            lx, ly, lz = -np.float64(axis[0]), -np.float64(axis[1]), -np.float64(axis[2])
            scale = 1.0
        else:
            dx = np.float64(position[0]) - p[i, 0]
            dy = np.float64(position[1]) - p[i, 1]
            dz = np.float64(position[2]) - p[i, 2]
            d2 = dx * dx + dy * dy + dz * dz
            inv = 1.0 / max(math.sqrt(d2), 1e-20)
            lx, ly, lz = dx * inv, dy * inv, dz * inv
            inv_d2 = 1.0 / max(d2, 1e-8)
            cos_axis = -(lx * axis[0] + ly * axis[1] + lz * axis[2])
            if kind == AREA:
                scale = max(0.0, cos_axis) * inv_d2 * _INV_PI
            else:
                scale = inv_d2 * (0.25 * _INV_PI)
                if kind == SPOT:
                    if blend > 0.0:
                        x = min(max((cos_axis - cos_half) / ((1.0 - cos_half) * blend), 0.0),
                                1.0)
                        scale *= x * x * (3.0 - 2.0 * x)
                    elif not cos_axis > cos_half:
                        scale = 0.0
        faces = lx * geo[i, 0] + ly * geo[i, 1] + lz * geo[i, 2] > 0.0
        lit = False
        for c in range(3):
            e = scale * color[c]
            e_out[i, c] = e
            lit = lit or e > 0.0
        lit = lit and faces
        if not lit:
            e_out[i, 0] = e_out[i, 1] = e_out[i, 2] = 0.0
        l_out[i, 0], l_out[i, 1], l_out[i, 2] = lx, ly, lz
        lit_out[i] = lit


@nb.njit(nb.void(_F3, _F3, _F3, _F3, _F3, _F3, nb.float32[::1], nb.int64, _F3, _F3),
         **_OPTIONS)
def accumulate(n, v, l, irradiance, albedo, rf0, gloss, model, diffuse, specular):
    """Add one light's reflected radiance to ``diffuse`` and ``specular`` (N, 3):
    f(l, v) (n.l) E with the terms of ``brdf.direct_brdf`` for ``model`` (a value of
    ``MODELS``), E = ``irradiance`` (N, 3) (shadowed, 0 where unlit)."""
    for i in range(n.shape[0]):
        e0, e1, e2 = irradiance[i, 0], irradiance[i, 1], irradiance[i, 2]
        if e0 == 0.0 and e1 == 0.0 and e2 == 0.0:
            continue
        nx, ny, nz = np.float64(n[i, 0]), np.float64(n[i, 1]), np.float64(n[i, 2])
        vx, vy, vz = np.float64(v[i, 0]), np.float64(v[i, 1]), np.float64(v[i, 2])
        lx, ly, lz = np.float64(l[i, 0]), np.float64(l[i, 1]), np.float64(l[i, 2])
        n_dot_l = nx * lx + ny * ly + nz * lz
        if not n_dot_l > 0.0:  # below the horizon: exactly 0
            continue
        n_dot_v = max(nx * vx + ny * vy + nz * vz, N_DOT_V_MIN)
        hx, hy, hz = lx + vx, ly + vy, lz + vz
        inv_h = 1.0 / max(math.sqrt(hx * hx + hy * hy + hz * hz), _EPS)
        hx, hy, hz = hx * inv_h, hy * inv_h, hz * inv_h
        n_dot_h = nx * hx + ny * hy + nz * hz
        l_dot_h = lx * hx + ly * hy + lz * hz
        v_dot_h = vx * hx + vy * hy + vz * hz
        g = _clip01(np.float64(gloss[i]))
        alpha = 2.0 ** (13.0 * g)
        d_pl = (alpha + 2.0) * 0.125 * _clip01(n_dot_h) ** alpha
        if model == 1:  # BO2 Fresnel and visibility
            f_weight = 2.0 ** (-10.0 * _clip01(l_dot_h))
            k = min(1.0, g + 0.545)
            x = min(max(v_dot_h, _EPS), 1.0)
            vis = 1.0 / (k * (x * x) + (1.0 - k))
        else:
            t = 1.0 - _clip01(l_dot_h)
            t2 = t * t
            f_weight = t2 * t2 * t
            if model == 0:  # Schlick-Smith
                k = 2.0 / math.sqrt(math.pi * (alpha + 2.0))
                one_k = 1.0 - k
                vis = 1.0 / ((_clip01(n_dot_l) * one_k + k) * (_clip01(n_dot_v) * one_k + k))
            elif model == 2:
                vis = 1.0
            elif model == 3:  # Cook-Torrance
                nl = min(max(n_dot_l, _EPS), 1.0)
                nv = min(max(n_dot_v, _EPS), 1.0)
                vh = min(max(v_dot_h, _EPS), 1.0)
                two = 2.0 * _clip01(n_dot_h) / vh
                vis = min(1.0 / (nl * nv), min(two / nl, two / nv))
            else:  # Kelemen
                x = min(max(l_dot_h, _EPS), 1.0)
                vis = 1.0 / (x * x)
        s = d_pl * vis * n_dot_l * _INV_PI
        dl = n_dot_l * _INV_PI
        for c in range(3):
            f0 = np.float64(rf0[i, c])
            e = np.float64(irradiance[i, c])
            diffuse[i, c] += np.float32(albedo[i, c] * dl * e)
            specular[i, c] += np.float32(s * (f0 + (1.0 - f0) * f_weight) * e)
