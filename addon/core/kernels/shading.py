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

from . import mark_cached

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}

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
            lit = lit or e != 0.0  # a negative light takes light away, as in Cycles
        lit = lit and faces
        if not lit:
            e_out[i, 0] = e_out[i, 1] = e_out[i, 2] = 0.0
        l_out[i, 0], l_out[i, 1], l_out[i, 2] = lx, ly, lz
        lit_out[i] = lit


@nb.njit(nb.void(_F3, _F3, _F3, _F3, nb.float32[::1], _F3, _F3, nb.float32[::1], nb.int64,
                 _F3, _F3), **_OPTIONS)
def accumulate(n, v, l, irradiance, shadow, albedo, rf0, gloss, model, diffuse, specular):
    """Add one light's reflected radiance to ``diffuse`` and ``specular`` (N, 3):
    f(l, v) (n.l) E with the terms of ``brdf.direct_brdf`` for ``model`` (a value of
    ``MODELS``), E = ``irradiance`` (N, 3) (0 where unlit) times the visibility ``shadow`` (N,)
    (the product in float32)."""
    for i in range(n.shape[0]):
        e0, e1, e2 = (irradiance[i, 0] * shadow[i], irradiance[i, 1] * shadow[i],
                      irradiance[i, 2] * shadow[i])
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
            e = np.float64(irradiance[i, c] * shadow[i])
            diffuse[i, c] += np.float32(albedo[i, c] * dl * e)
            specular[i, c] += np.float32(s * (f0 + (1.0 - f0) * f_weight) * e)


_SURFACE = nb.void(
    nb.int32[::1], _F3, nb.float32[:, :, ::1], nb.float32[:, :, ::1], nb.float32[:, :, ::1],
    _F3, _F3, _F3, _F3, _F3,
)


@nb.njit(inline="always", **_OPTIONS)
def triangle_normal(corners, t):
    """The geometric normal of triangle ``t`` of ``corners`` (T, 3, 3), not normalized:
    (c1 - c0) x (c2 - c0), its length twice the area; in the corners' float type."""
    ax = corners[t, 1, 0] - corners[t, 0, 0]
    ay = corners[t, 1, 1] - corners[t, 0, 1]
    az = corners[t, 1, 2] - corners[t, 0, 2]
    bx = corners[t, 2, 0] - corners[t, 0, 0]
    by = corners[t, 2, 1] - corners[t, 0, 1]
    bz = corners[t, 2, 2] - corners[t, 0, 2]
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@nb.njit(_SURFACE, **_OPTIONS)
def surface(tri, bary, positions, normals, uvs, v, p_out, n_out, geo_out, uv_out):
    """The surface under N camera samples: position ``p_out``, unit shading normal ``n_out``
    and geometric normal ``geo_out`` (both turned towards the camera when the triangle is seen
    from behind), UV ``uv_out`` (N, 2). Float32 arithmetic in the order of the NumPy it
    replaced (the weighted sums, the cross product, the norms): bit for bit the same values,
    so that the shadow filter's per-point rotation, hashed from the position's bits, stays.

    tri, bary: (N,) triangle and (N, 3) perspective-correct weights of its corners
    positions, normals: (T, 3, 3) corners; uvs: (T, 3, 2), or (0, 3, 2) when no triangle has
               UVs (0 then)
    v:         (N, 3) unit directions to the eye (``Camera.rays``, reversed)
    """
    tiny_n, tiny_g = np.float32(1e-20), np.float32(1e-30)
    for i in range(tri.shape[0]):
        t = tri[i]
        b0, b1, b2 = bary[i, 0], bary[i, 1], bary[i, 2]
        for c in range(3):
            p_out[i, c] = (b0 * positions[t, 0, c] + b1 * positions[t, 1, c]) \
                + b2 * positions[t, 2, c]
            n_out[i, c] = (b0 * normals[t, 0, c] + b1 * normals[t, 1, c]) \
                + b2 * normals[t, 2, c]
        length = np.sqrt((n_out[i, 0] * n_out[i, 0] + n_out[i, 1] * n_out[i, 1])
                         + n_out[i, 2] * n_out[i, 2])
        length = max(length, tiny_n)
        gx, gy, gz = triangle_normal(positions, t)
        g_len = max(np.sqrt((gx * gx + gy * gy) + gz * gz), tiny_g)
        gx, gy, gz = gx / g_len, gy / g_len, gz / g_len
        flip = (gx * v[i, 0] + gy * v[i, 1]) + gz * v[i, 2] < np.float32(0.0)
        for c in range(3):
            n_out[i, c] = n_out[i, c] / length
            if flip:  # seen from behind: shade the side facing the camera
                n_out[i, c] = -n_out[i, c]
        if flip:
            gx, gy, gz = -gx, -gy, -gz
        geo_out[i, 0], geo_out[i, 1], geo_out[i, 2] = gx, gy, gz
        for c in range(2):
            if uvs.shape[0] == 0:  # no triangle has UVs
                uv_out[i, c] = np.float32(0.0)
            else:
                uv_out[i, c] = (b0 * uvs[t, 0, c] + b1 * uvs[t, 1, c]) + b2 * uvs[t, 2, c]


@nb.njit(nb.void(nb.int32[::1], _F3, nb.float32[:, :, ::1], _F3), **_OPTIONS)
def interpolate(tri, bary, corners, out):
    """Corner values ``corners`` (T, 3, K) of triangles ``tri`` (N,) weighted by ``bary``
    (N, 3): ``out`` (N, K), float32, summed in corner order."""
    for i in range(tri.shape[0]):
        t = tri[i]
        b0, b1, b2 = bary[i, 0], bary[i, 1], bary[i, 2]
        for k in range(corners.shape[2]):
            out[i, k] = (b0 * corners[t, 0, k] + b1 * corners[t, 1, k]) + b2 * corners[t, 2, k]


@nb.njit(nb.void(nb.int32[::1], nb.float32[:, :, ::1], _F3, _F3, _F3, _F3), **_OPTIONS)
def plane_hits(tri, positions, origins, directions, bary_out, p_out):
    """Where rays (``origins``, ``directions`` (N, 3)) meet the planes of triangles ``tri``:
    barycentrics ``bary_out`` (N, 3) (outside the triangle too) and points ``p_out`` (N, 3),
    float64 arithmetic; NaN where a ray runs along the plane or the triangle has no area."""
    for i in range(tri.shape[0]):
        t = tri[i]
        ax, ay, az = (np.float64(positions[t, 0, 0]), np.float64(positions[t, 0, 1]),
                      np.float64(positions[t, 0, 2]))
        e1x, e1y, e1z = positions[t, 1, 0] - ax, positions[t, 1, 1] - ay, positions[t, 1, 2] - az
        e2x, e2y, e2z = positions[t, 2, 0] - ax, positions[t, 2, 1] - ay, positions[t, 2, 2] - az
        nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        nn = nx * nx + ny * ny + nz * nz
        ox, oy, oz = np.float64(origins[i, 0]), np.float64(origins[i, 1]), np.float64(origins[i, 2])
        dx, dy, dz = (np.float64(directions[i, 0]), np.float64(directions[i, 1]),
                      np.float64(directions[i, 2]))
        denom = nx * dx + ny * dy + nz * dz
        if denom == 0.0 or nn == 0.0:
            for c in range(3):
                bary_out[i, c] = p_out[i, c] = np.nan
            continue
        s = (nx * (ax - ox) + ny * (ay - oy) + nz * (az - oz)) / denom
        hx, hy, hz = ox + s * dx, oy + s * dy, oz + s * dz
        rx, ry, rz = hx - ax, hy - ay, hz - az
        # b1 = (r x e2) . n / |n|^2, b2 = (e1 x r) . n / |n|^2
        b1 = ((ry * e2z - rz * e2y) * nx + (rz * e2x - rx * e2z) * ny
              + (rx * e2y - ry * e2x) * nz) / nn
        b2 = ((e1y * rz - e1z * ry) * nx + (e1z * rx - e1x * rz) * ny
              + (e1x * ry - e1y * rx) * nz) / nn
        bary_out[i, 0], bary_out[i, 1], bary_out[i, 2] = 1.0 - b1 - b2, b1, b2
        p_out[i, 0], p_out[i, 1], p_out[i, 2] = hx, hy, hz


@nb.njit(nb.void(nb.float64[::1], nb.float64[::1], nb.float64[:, ::1], _F3, _F3), **_OPTIONS)
def rays(x, y, planes, origins, directions):
    """Camera rays through window positions ``x``, ``y`` (N,): ``origins`` on the near plane
    and unit ``directions`` (N, 3). ``planes`` (4, 4): rows a, b of the clip-to-world matrix's
    x and y columns times 2 / width and -2 / height, and its images of the near (z = -1) and
    middle (z = 0) clip points at the corner; a plane point is h = a x + b y + c, divided by h_w
    (``scene.Camera.rays``, in the order of its NumPy arithmetic)."""
    ends = np.empty((2, 3))
    for i in range(x.shape[0]):
        for e in range(2):
            c = planes[2 + e]
            hw = (x[i] * planes[0, 3] + y[i] * planes[1, 3]) + c[3]
            for k in range(3):
                ends[e, k] = ((x[i] * planes[0, k] + y[i] * planes[1, k]) + c[k]) / hw
        d0, d1, d2 = ends[1, 0] - ends[0, 0], ends[1, 1] - ends[0, 1], ends[1, 2] - ends[0, 2]
        length = math.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
        for k in range(3):
            origins[i, k] = ends[0, k]
        directions[i, 0], directions[i, 1], directions[i, 2] = d0 / length, d1 / length, \
            d2 / length


@nb.njit(nb.void(_F3, nb.int64[::1], nb.float32[::1], _F3), **_OPTIONS)
def splat(acc, pixel, weight, values):
    """Add each shaded point's ``values`` (M, C) times its ``weight`` (M,) to its pixel's row
    of ``acc`` (P, C): acc[pixel[i]] += weight[i] values[i], in the order of the points."""
    for i in range(pixel.shape[0]):
        row, w = pixel[i], weight[i]
        for c in range(values.shape[1]):
            acc[row, c] += w * values[i, c]


COMPOSED = ("Combined", "Normal", "Position", "UV", "DiffDir", "GlossDir", "DiffInd",
            "GlossInd", "Emit", "Albedo", "Specular Color", "Gloss")

_COMPOSE = nb.void(_F3, nb.int64[::1], _F3, _F3, _F3, nb.boolean[::1], _F3, _F3, _F3, _F3, _F3,
                   _F3, _F3, nb.float32[::1])


@nb.njit(_COMPOSE, **_OPTIONS)
def compose(out, cols, n, p, uv, has_uv, diffuse, specular, diff_ind, gloss_ind, emission,
            albedo, rf0, gloss):
    """The shaded points' passes side by side in ``out`` (N, C): the first column of each
    pass of ``COMPOSED`` in ``cols``. Combined is the sum of the light terms (float32, in the
    order listed) with alpha 1; UV is (u, v, 1) where the triangle has UVs, else 0."""
    one, zero = np.float32(1.0), np.float32(0.0)
    for i in range(n.shape[0]):
        for c in range(3):
            out[i, cols[0] + c] = (((diffuse[i, c] + specular[i, c]) + diff_ind[i, c])
                                   + gloss_ind[i, c]) + emission[i, c]
            out[i, cols[1] + c] = n[i, c]
            out[i, cols[2] + c] = p[i, c]
            out[i, cols[4] + c] = diffuse[i, c]
            out[i, cols[5] + c] = specular[i, c]
            out[i, cols[6] + c] = diff_ind[i, c]
            out[i, cols[7] + c] = gloss_ind[i, c]
            out[i, cols[8] + c] = emission[i, c]
            out[i, cols[9] + c] = albedo[i, c]
            out[i, cols[10] + c] = rf0[i, c]
        out[i, cols[0] + 3] = one
        out[i, cols[3]] = uv[i, 0] if has_uv[i] else zero
        out[i, cols[3] + 1] = uv[i, 1] if has_uv[i] else zero
        out[i, cols[3] + 2] = one if has_uv[i] else zero
        out[i, cols[11]] = gloss[i]


mark_cached(__name__)  # every kernel above is compiled or loaded
