"""Indirect light kernel: SH irradiance and the normalized, prefiltered reflections of every
shaded point (``probes.indirect``, which gives the method and the talk's slides).

References (the NumPy this kernel is held to, point by point, in tests/core/test_kernels_indirect):
``sh.basis`` and ``sh.irradiance`` (Ramamoorthi & Hanrahan 2001), ``cubemap.sample`` (seamless
trilinear cube-map look-ups, the shader's texCUBElod), ``ReflectionProbe.weight``, and the
"none" / "bo1" / "bo2" normalizations of ``probes``'s module docstring (slides "Black Ops:
normalization algorithm" and "Improved normalization algorithm"), written out in the test, and
``env_brdf.environment_brdf`` (the models "table", "bo1", "bo2" and "fit"; "truth" integrates
per point and is for tools and tests only).

Cube-map chains come packed (``probes.packed_chains``): every level of every chain padded with
its one-texel seamless border (``cubemap.with_border``) in one flat float32 array, chain c's
level m at ``level_offset[c, m]`` with side ``level_size[c, m]`` (padded side minus 2).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from . import mark_cached

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}

NONE, BO1, BO2 = 0, 1, 2  # normalizations
NORMALIZATIONS = {"none": NONE, "bo1": BO1, "bo2": BO2}
TABLE, ENV_BO1, ENV_BO2, FIT = 0, 1, 2, 3  # environment BRDFs
PROXIES = {"none": 0, "sphere": 1, "box": 2}  # reflection probes' parallax proxies
ENV_MODELS = {"table": TABLE, "bo1": ENV_BO1, "bo2": ENV_BO2, "fit": FIT}
NEAREST = 2  # reflection probes that stand in for the world where a point does not see it

_C0 = 0.5 / math.sqrt(math.pi)  # sh._C0 ...
_C1 = math.sqrt(3.0 / (4.0 * math.pi))
_C2 = math.sqrt(15.0 / (4.0 * math.pi))
_C20 = math.sqrt(5.0 / (16.0 * math.pi))
_C22 = math.sqrt(15.0 / (16.0 * math.pi))


@nb.njit(**_OPTIONS)
def _basis(nx, ny, nz, band, y):
    """``sh.basis`` of a float32 direction (in float64, rounded to float32) times the
    float32 band factors ``band`` (9,): into ``y`` (9,) float32."""
    x, yy, z = np.float64(nx), np.float64(ny), np.float64(nz)
    y[0] = np.float32(_C0) * band[0]
    y[1] = np.float32(_C1 * yy) * band[1]
    y[2] = np.float32(_C1 * z) * band[2]
    y[3] = np.float32(_C1 * x) * band[3]
    y[4] = np.float32(_C2 * x * yy) * band[4]
    y[5] = np.float32(_C2 * yy * z) * band[5]
    y[6] = np.float32(_C20 * (3.0 * z * z - 1.0)) * band[6]
    y[7] = np.float32(_C2 * x * z) * band[7]
    y[8] = np.float32(_C22 * (x * x - yy * yy)) * band[8]


@nb.njit(**_OPTIONS)
def _bilinear(chains, base, size, face, x, y, c):
    """``cubemap._bilinear_padded``: channel c of a padded level (side ``size`` + 2, at
    ``base`` in ``chains``) at continuous texel coordinates x, y of ``face``."""
    s = size
    fx, fy = x - 0.5, y - 0.5
    x0 = min(max(np.floor(fx), -1.0), s - 1.0)
    y0 = min(max(np.floor(fy), -1.0), s - 1.0)
    tx = np.float32(min(max(fx - x0, 0.0), 1.0))
    ty = np.float32(min(max(fy - y0, 0.0), 1.0))
    xi, yi = np.int64(x0) + 1, np.int64(y0) + 1
    row = s + 2
    at = base + ((face * row + yi) * row + xi) * 3 + c
    one = np.float32(1.0)
    top = chains[at] * (one - tx) + chains[at + 3] * tx
    below = at + row * 3
    bottom = chains[below] * (one - tx) + chains[below + 3] * tx
    return top * (one - ty) + bottom * ty


@nb.njit(**_OPTIONS)
def _face_uv(faces, dx, dy, dz):
    """``cubemap.direction_to_face`` of one direction (float64): face, and u, v in [0, 1]
    along its columns and rows; a zero or non-finite direction maps to +X's centre."""
    d0, d1, d2 = np.float64(dx), np.float64(dy), np.float64(dz)
    if not (np.isfinite(d0) and np.isfinite(d1) and np.isfinite(d2)) or \
            not max(abs(d0), abs(d1), abs(d2)) > 0.0:
        d0, d1, d2 = 1.0, 0.0, 0.0
    a0, a1, a2 = abs(d0), abs(d1), abs(d2)
    if a0 >= a1 and a0 >= a2:
        axis, depth, comp = 0, a0, d0
    elif a1 >= a2:
        axis, depth, comp = 1, a1, d1
    else:
        axis, depth, comp = 2, a2, d2
    face = 2 * axis + (1 if comp < 0.0 else 0)
    a = ((d0 * faces[face, 1, 0] + d1 * faces[face, 1, 1]) + d2 * faces[face, 1, 2]) / depth
    b = ((d0 * faces[face, 2, 0] + d1 * faces[face, 2, 1]) + d2 * faces[face, 2, 2]) / depth
    return face, (min(max(a, -1.0), 1.0) + 1.0) * 0.5, (1.0 - min(max(b, -1.0), 1.0)) * 0.5


@nb.njit(**_OPTIONS)
def sample_chain(chains, level_offset, level_size, levels, chain, faces, dx, dy, dz, gloss, out):
    """``cubemap.sample`` of ``chain`` along (dx, dy, dz) (float32) at lod = top - g top,
    g = gloss clamped to [0, 1] (slide "Black Ops: environment map pre-filtering", in
    float32): RGB into ``out`` (3,) float32; 0 for a chain without levels."""
    face, u, v = _face_uv(faces, dx, dy, dz)
    top = levels[chain] - 1
    g = gloss
    if g != g:
        g = np.float32(np.nan)
    else:
        g = min(max(g, np.float32(0.0)), np.float32(1.0))
    lod = np.float64(np.float32(top) - g * np.float32(top))
    if lod != lod:
        lod = np.float64(top)
    lod = min(max(lod, 0.0), np.float64(top))
    base = np.int64(np.floor(lod))
    frac = np.float32(lod - base)
    for c in range(3):
        out[c] = np.float32(0.0)
    if top < 0:
        return
    for k in range(base, base + 2):
        if k > top:
            break
        w = (np.float32(1.0) - frac) if k == base else frac
        if not w > 0.0:
            continue
        size = level_size[chain, k]
        offset = level_offset[chain, k]
        for c in range(3):
            out[c] += w * _bilinear(chains, offset, size, face, u * size, v * size, c)


@nb.njit(**_OPTIONS)
def _parallax(proxy, kind, k, x, y, z, rx, ry, rz):
    """Distance t along the ray x + t r at which it leaves probe k's proxy, the unit sphere
    (kind 1) or the cube [-1, 1]^3 (kind 2) of the affine map ``proxy[k]`` (world -> proxy,
    3 x 4 row-major): the probe's cube map is then read towards x + t r, the point the
    reflection sees if the room were that shape (Lagarde and Zanuttini 2012). Affine maps keep
    the ray's parameter, so t is solved in the proxy's space. Points on the proxy (a floor on
    its bottom face) and outside it are corrected alike, so there is no seam at its surface;
    0 (no correction) when the ray leaves the proxy behind it or misses it."""
    m = proxy[k]
    qx = m[0] * x + m[1] * y + m[2] * z + m[3]
    qy = m[4] * x + m[5] * y + m[6] * z + m[7]
    qz = m[8] * x + m[9] * y + m[10] * z + m[11]
    dx = m[0] * rx + m[1] * ry + m[2] * rz
    dy = m[4] * rx + m[5] * ry + m[6] * rz
    dz = m[8] * rx + m[9] * ry + m[10] * rz
    if kind == 1:
        a = dx * dx + dy * dy + dz * dz
        b = qx * dx + qy * dy + qz * dz
        c = qx * qx + qy * qy + qz * qz - np.float32(1.0)
        disc = b * b - a * c
        if not (a > 0.0 and disc >= 0.0):
            return np.float32(0.0)
        t = (-b + np.sqrt(disc)) / a
        return t if t > 0.0 else np.float32(0.0)
    t = np.float32(np.inf)
    for q, d in ((qx, dx), (qy, dy), (qz, dz)):
        if d > 0.0:
            t = min(t, (np.float32(1.0) - q) / d)
        elif d < 0.0:
            t = min(t, (np.float32(-1.0) - q) / d)
        elif abs(q) > 1.0:  # parallel to this slab, outside it: the ray never meets the box
            return np.float32(0.0)
    return t if 0.0 < t < np.inf else np.float32(0.0)


@nb.njit(**_OPTIONS)
def _clamp(x, lo, hi):
    """x clamped to [lo, hi]; NaN stays NaN (``np.clip``)."""
    if x != x:
        return x
    return min(max(x, lo), hi)


@nb.njit(**_OPTIONS)
def _position(x, axis):
    """``np.interp(x, axis, arange(len(axis)))``: x's fractional index on an increasing axis."""
    n = axis.shape[0]
    if x != x:
        return x
    if x <= axis[0]:
        return 0.0
    if x >= axis[n - 1]:
        return np.float64(n - 1)
    j = np.searchsorted(axis, x, side="right") - 1
    return j + (x - axis[j]) / (axis[j + 1] - axis[j])


@nb.njit(**_OPTIONS)
def _table_part(part, fg, fn):
    """``env_brdf.table_parts``'s bilinear look-up of ``part`` (G, N) at fractional indices
    fg, fn, rounded to float32 as the NumPy does."""
    i0 = min(max(np.int64(np.floor(fg)) if fg == fg else 0, 0), part.shape[0] - 2)
    j0 = min(max(np.int64(np.floor(fn)) if fn == fn else 0, 0), part.shape[1] - 2)
    tg, tn = fg - i0, fn - j0
    top = part[i0, j0] * (1.0 - tn) + part[i0, j0 + 1] * tn
    bottom = part[i0 + 1, j0] * (1.0 - tn) + part[i0 + 1, j0 + 1] * tn
    return np.float64(np.float32(top * (1.0 - tg) + bottom * tg))


@nb.njit(**_OPTIONS)
def _env_brdf(model, gloss, n_dot_v, rf0, table, table_gloss, table_nv, fit, nv_min, out):
    """``env_brdf.environment_brdf`` of ``model`` (``ENV_MODELS``) at float32 gloss, n.v and
    rf0 (3,), n.v clamped to [nv_min, 1], in float64 (slides "Black Ops: environment map
    'Fresnel'", "Final approximation"; docs/env_brdf.md for the fit): float32 E into ``out``.
    ``table`` (2, G, N) holds the parts a0, a1 over ``table_gloss`` (G,) x ``table_nv`` (N,);
    ``fit`` (10,) is (cx, dx, cy, dy, cz, dz, k, cw, dw, s), ``env_brdf.FIT_A0 + FIT_A1``."""
    g = _clamp(np.float64(gloss), 0.0, 1.0)
    nv = _clamp(np.float64(n_dot_v), nv_min, 1.0)
    a0 = a1 = 0.0
    if model == TABLE:
        fg, fn = _position(g, table_gloss), _position(nv, table_nv)
        a0 = _table_part(table[0], fg, fn)
        a1 = _table_part(table[1], fg, fn)
    elif model == ENV_BO2:
        tx = g * (1.0 / 0.96)
        ty = g * 0.475
        tz = g * ((0.0275 - 0.25 * 0.04) / 0.96) + (0.015 - 0.75 * 0.04) / 0.96
        a0 = tx * min(ty, np.exp2(-9.28 * nv)) + tz
        a1 = g * 0.25 + 0.75
    elif model == FIT:
        m = min(fit[2] * g + fit[3], np.exp2(fit[6] * nv))
        a0 = (fit[0] * g + fit[1]) * m + (fit[4] * g + fit[5])
        a1 = min(fit[9] * m + (fit[7] * g + fit[8]), 1.0)
    for c in range(3):
        f0 = _clamp(np.float64(rf0[c]), 0.0, 1.0)
        if model == ENV_BO1:
            t = 1.0 - nv
            e = f0 + (1.0 - f0) * (t * t) * (t * t) * t / (4.0 - 3.0 * g)
        elif model == TABLE:
            e = a0 * (1.0 - f0) + a1 * f0
        else:  # BO2 and the fit: the shader's saturate (the fit's a0 dips below 0 by 0.012)
            e = _clamp(a0 + f0 * (a1 - a0), 0.0, 1.0)
        out[c] = np.float32(e)


@nb.njit(**_OPTIONS)
def _chain_radiance(i, chain, n_probes, points, rx, ry, rz, gloss, e, y, pixel_sh, k_sh, chains,
                    level_offset, level_size, levels, faces, position, proxy, proxy_kind,
                    dc_eps, scalar, tint, has_world_color, world_color, normalization, eps32,
                    max_ratio, s):
    """Chain ``chain``'s radiance (a probe's, or the world's: ``n_probes``) along the
    reflection (rx, ry, rz) of point i, normalized: into ``s`` (3,)."""
    if chain == n_probes and has_world_color:
        for c in range(3):
            s[c] = world_color[c]
    else:
        t = np.float32(0.0)
        px = py = pz = np.float32(0.0)
        if chain < n_probes:
            px = points[i, 0] - position[chain, 0]
            py = points[i, 1] - position[chain, 1]
            pz = points[i, 2] - position[chain, 2]
            if proxy_kind[chain] != 0:
                t = _parallax(proxy, proxy_kind[chain], chain, points[i, 0], points[i, 1],
                              points[i, 2], rx, ry, rz)
        if t > 0.0:  # towards where the reflection leaves the proxy
            sample_chain(chains, level_offset, level_size, levels, chain, faces,
                         px + t * rx, py + t * ry, pz + t * rz, gloss, s)
        else:
            sample_chain(chains, level_offset, level_size, levels, chain, faces, rx, ry, rz,
                         gloss, s)
    if normalization == NONE:
        return
    probe_e = np.float32(0.0)
    if normalization == BO2:
        for k in range(9):
            probe_e += y[k] * scalar[chain, k]
    for c in range(3):
        if normalization == BO1:
            ratio = np.float32(min(max(
                (np.float64(pixel_sh[k_sh, 0, c] + eps32)) / dc_eps[chain, c], 0.0),
                max_ratio))
        else:
            ratio = (e[c] + eps32) / (probe_e * tint[chain, c] + eps32)
            ratio = min(max(ratio, np.float32(0.0)), np.float32(max_ratio))
        s[c] = s[c] * ratio


@nb.njit(**_OPTIONS)
def _nearest_weights(points, i, position, near, near_d, weights):
    """The K = len(weights) probes nearest point i (fewer when there are fewer) into ``near``
    and their weights, summing to 1, into ``weights``; returns how many. A probe weighs
    1/d^2 - 1/d'^2, d' the distance of the (K + 1)th nearest (0 without one), so a probe
    enters and leaves the K with no weight: no seam where the K nearest change.
    ``near``, ``near_d``: (K + 1,) scratch."""
    size = near.shape[0]
    count = 0
    for q in range(position.shape[0]):
        dx = np.float64(points[i, 0]) - position[q, 0]
        dy = np.float64(points[i, 1]) - position[q, 1]
        dz = np.float64(points[i, 2]) - position[q, 2]
        dq = dx * dx + dy * dy + dz * dz
        j = min(count, size)
        while j > 0 and near_d[j - 1] > dq:
            if j < size:
                near[j], near_d[j] = near[j - 1], near_d[j - 1]
            j -= 1
        if j < size:
            near[j], near_d[j] = q, dq
            count = min(count + 1, size)
    k = min(count, weights.shape[0])
    beyond = 1.0 / max(near_d[k], 1e-12) if count > k else 0.0
    total = 0.0
    for j in range(k):
        weights[j] = 1.0 / max(near_d[j], 1e-12) - beyond
        total += weights[j]
    for j in range(k):
        weights[j] = weights[j] / total if total > 0.0 else 1.0 / k
    return k


_INDIRECT = nb.void(
    nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[:, ::1],  # points, normals, view (N, 3)
    nb.float32[:, ::1], nb.float32[:, ::1],  # albedo, rf0 (N, 3)
    nb.float32[::1], nb.float32[:, :, ::1],  # gloss (N,), pixel SH
    nb.float32[::1],  # the world's seen fraction (N,) or (1,)
    nb.float32[::1],  # band factors (9,)
    nb.float32[::1], nb.int64[:, ::1], nb.int64[:, ::1], nb.int64[::1],  # chains, level offsets,
    nb.float64[:, :, ::1],  # sides and counts; cube faces (6, 3, 3)
    nb.float32[:, ::1], nb.float32[:, ::1],  # probe positions (R, 3), radius and fade (R, 2)
    nb.float32[:, ::1], nb.int64[::1],  # parallax proxies: world -> unit shape (R, 12), kind (R,)
    nb.float64[:, ::1], nb.float32[:, ::1], nb.float32[:, ::1],  # SH constant term + eps,
    nb.boolean, nb.float32[::1], nb.int64,  # scalar SH, tint; world colour?, colour, normalization
    nb.float64[::1],  # eps, largest normalization ratio, smallest n.v of the environment BRDF
    nb.int64, nb.float64[:, :, ::1], nb.float64[::1], nb.float64[::1],  # environment BRDF,
    nb.float64[::1],  # its table (2, G, N) over gloss (G,) and n.v (N,); its fit (10,)
    nb.float32[:, ::1], nb.float32[:, ::1],  # out: diffuse, specular (N, 3)
)


@nb.njit(_INDIRECT, **_OPTIONS)
def indirect(points, normals, view, albedo, rf0, gloss, pixel_sh, seen, band, chains,
             level_offset, level_size, levels, faces, position, radius_fade, proxy, proxy_kind,
             dc_eps, scalar, tint,
             has_world_color, world_color, normalization, limits, env_model, table, table_gloss,
             table_nv, fit, diffuse, specular):
    """Indirect diffuse ``diffuse`` (N, 3) (albedo / pi times the SH irradiance at the normal)
    and specular ``specular`` (N, 3): the normalized prefiltered radiance along the reflection
    vector times the environment BRDF (slide "Environment lighting: split approximation"). The
    radiance is the reflection probes' chains 0 .. R - 1 weighted by their influence (divided
    by the sum where it exceeds 1); the weight they leave goes to the world (chain R, or
    ``world_color``) in the share of the world's light the point sees (``seen``, (N,) or (1,)
    shared, clamped to [0, 1]; NaN: 1), and the rest to the ``NEAREST`` probes nearest the
    point (``_nearest_weights``): where the world is hidden, what surrounds the point is more
    like what the nearest probes saw than like the sky. ``pixel_sh`` is (N, 9, 3), or
    (1, 9, 3) shared by every point. A probe with a parallax proxy (``_parallax``) is looked up
    towards the point where the reflected ray leaves its proxy rather than along the ray's
    direction."""
    n_probes = position.shape[0]
    y = np.empty(9, np.float32)
    e = np.empty(3, np.float32)
    s = np.empty(3, np.float32)
    acc = np.empty(3, np.float32)
    brdf = np.empty(3, np.float32)
    chosen = np.empty(n_probes + 1 + NEAREST, np.int64)  # the chains that reflect, their weights
    chosen_w = np.empty(n_probes + 1 + NEAREST, np.float32)
    near = np.empty(NEAREST + 1, np.int64)
    near_d = np.empty(NEAREST + 1, np.float64)
    near_w = np.empty(NEAREST, np.float64)
    eps32 = np.float32(limits[0])
    max_ratio = limits[1]
    inv_pi = np.float32(1.0 / np.pi)
    for i in range(points.shape[0]):
        k_sh = i if pixel_sh.shape[0] > 1 else 0
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        _basis(nx, ny, nz, band, y)
        for c in range(3):
            total = np.float32(0.0)
            for k in range(9):
                total += y[k] * pixel_sh[k_sh, k, c]
            e[c] = total
            diffuse[i, c] = albedo[i, c] * total * inv_pi
        vx, vy, vz = view[i, 0], view[i, 1], view[i, 2]
        n_dot_v = (nx * vx + ny * vy) + nz * vz
        two = np.float32(2.0) * n_dot_v
        rx, ry, rz = two * nx - vx, two * ny - vy, two * nz - vz
        count = 0
        weight_sum = np.float32(0.0)
        for chain in range(n_probes):
            px = points[i, 0] - position[chain, 0]
            py = points[i, 1] - position[chain, 1]
            pz = points[i, 2] - position[chain, 2]
            d = np.sqrt((px * px + py * py) + pz * pz)
            w = (radius_fade[chain, 0] - d) / radius_fade[chain, 1]
            w = min(max(w, np.float32(0.0)), np.float32(1.0))
            if w > 0.0:
                chosen[count], chosen_w[count] = chain, w
                count += 1
                weight_sum += w
        if weight_sum > np.float32(1.0):
            for j in range(count):
                chosen_w[j] = chosen_w[j] / weight_sum
        left = max(np.float32(1.0) - weight_sum, np.float32(0.0))
        if left > 0.0:
            shown = seen[i if seen.shape[0] > 1 else 0]
            if shown != shown or n_probes == 0:
                shown = np.float32(1.0)
            shown = min(max(shown, np.float32(0.0)), np.float32(1.0))
            if shown > 0.0:
                chosen[count], chosen_w[count] = n_probes, left * shown
                count += 1
            hidden = left * (np.float32(1.0) - shown)
            if hidden > 0.0:
                found = _nearest_weights(points, i, position, near, near_d, near_w)
                for j in range(found):
                    chosen[count], chosen_w[count] = near[j], hidden * np.float32(near_w[j])
                    count += 1
        for c in range(3):
            acc[c] = np.float32(0.0)
        for j in range(count):
            _chain_radiance(i, chosen[j], n_probes, points, rx, ry, rz, gloss[i], e, y,
                            pixel_sh, k_sh, chains, level_offset, level_size, levels, faces,
                            position, proxy, proxy_kind, dc_eps, scalar, tint,
                            has_world_color, world_color, normalization, eps32, max_ratio, s)
            for c in range(3):
                acc[c] += chosen_w[j] * s[c]
        _env_brdf(env_model, gloss[i], n_dot_v, rf0[i], table, table_gloss, table_nv, fit,
                  limits[2], brdf)
        for c in range(3):
            specular[i, c] = acc[c] * brdf[c]


@nb.njit(**_OPTIONS)
def _moment(moments, row, face, x, y, c):
    """Channel c of sample ``row``'s padded moments (S, 6, M + 2, M + 2, 2) on ``face`` at
    continuous texel coordinates x, y in [0, M] (``cubemap._bilinear_padded``)."""
    s = moments.shape[2] - 2
    fx, fy = x - 0.5, y - 0.5
    x0 = min(max(math.floor(fx), -1.0), s - 1.0)
    y0 = min(max(math.floor(fy), -1.0), s - 1.0)
    tx = min(max(fx - x0, 0.0), 1.0)
    ty = min(max(fy - y0, 0.0), 1.0)
    xi, yi = int(x0) + 1, int(y0) + 1
    m = moments[row, face]
    top = m[yi, xi, c] * (1.0 - tx) + m[yi, xi + 1, c] * tx
    bottom = m[yi + 1, xi, c] * (1.0 - tx) + m[yi + 1, xi + 1, c] * tx
    return top * (1.0 - ty) + bottom * ty


@nb.njit(**_OPTIONS)
def _visibility(moments, faces, floor, far, row, sample, point):
    """``sample_visibility.chebyshev``: the weight of sample ``row`` at ``sample`` (3,) for
    ``point`` (3,), from its padded moments towards the point, its distance clamped at ``far``
    as theirs are."""
    dx = point[0] - sample[0]
    dy = point[1] - sample[1]
    dz = point[2] - sample[2]
    r = min(math.sqrt(dx * dx + dy * dy + dz * dz), far)
    face, u, v = _face_uv(faces, dx, dy, dz)
    size = moments.shape[2] - 2
    mean = _moment(moments, row, face, u * size, v * size, 0)
    if r <= mean:
        return 1.0
    var = max(_moment(moments, row, face, u * size, v * size, 1) - mean * mean, floor)
    bound = var / (var + (r - mean) * (r - mean))
    return bound * bound * bound


@nb.njit(**_OPTIONS)
def _blend(f, res, positions, validity, has_validity, point, normal, facing, facing_bias,
           moments, visible, faces, floor, far, samples, acc, rows, w_plain, w_kept):
    """Add to ``acc`` (K,) the blend of the eight samples around grid coordinates ``f`` (3,)
    (within [0, res - 1]): trilinear weights, times validity, times the facing weight
    max(0, unit(sample - point) . normal + facing_bias) when ``facing``, times the sample's
    visibility of the point (``_visibility``) when ``visible``; where those leave nothing,
    trilinear over the valid samples, or over all."""
    k = acc.shape[0]
    i0 = np.empty(3, np.int64)
    t = np.empty(3, np.float32)
    for a in range(3):
        j = min(int(math.floor(f[a])), res[a] - 2)
        j = max(j, 0)
        i0[a] = j
        t[a] = f[a] - j
    kept_sum = 0.0
    valid_sum = 0.0
    plain_sum = 0.0
    for c in range(8):
        w = 1.0
        idx = np.int64(0)
        for a in range(3):
            bit = (c >> a) & 1
            j = min(i0[a] + bit, res[a] - 1)
            idx = idx * res[a] + j
            w *= t[a] if bit else 1.0 - t[a]
        rows[c] = idx
        w_plain[c] = w
        v = validity[idx] if has_validity else 1.0
        kept = w * v
        if facing:
            dx = positions[idx, 0] - point[0]
            dy = positions[idx, 1] - point[1]
            dz = positions[idx, 2] - point[2]
            length = max(math.sqrt(dx * dx + dy * dy + dz * dz), 1e-6)
            dot = (dx * normal[0] + dy * normal[1] + dz * normal[2]) / length
            kept *= max(dot + facing_bias, 0.0)
        if visible and kept > 0.0:
            kept *= _visibility(moments, faces, floor, far, idx, positions[idx], point)
        w_kept[c] = kept
        kept_sum += kept
        valid_sum += w * v
        plain_sum += w
    for c in range(8):
        if kept_sum > 1e-6:
            b = w_kept[c] / kept_sum
        elif has_validity and valid_sum > 1e-6:
            b = w_plain[c] * validity[rows[c]] / valid_sum
        else:
            b = w_plain[c] / max(plain_sum, 1e-30)
        if b != 0.0:
            for j in range(k):
                acc[j] += b * samples[rows[c], j]


@nb.njit(**_OPTIONS)
def _luminance(row):
    """Rec. 709 luminance of an SH row's DC term (its first three entries, RGB)."""
    return 0.2126 * row[0] + 0.7152 * row[1] + 0.0722 * row[2]


@nb.njit(nb.void(nb.float32[:, ::1], nb.int64[::1], nb.float32[:, ::1], nb.float32[::1],
                 nb.boolean, nb.float32[:, ::1], nb.float32[:, ::1], nb.boolean, nb.float32,
                 nb.float32[:, :, :, :, ::1], nb.boolean, nb.float64[:, :, ::1], nb.float64,
                 nb.float64, nb.float32[:, ::1], nb.float32, nb.float32, nb.float32[:, ::1]),
         **_OPTIONS)
def volume_blend(grid, res, positions, validity, has_validity, points, normals, facing,
                 facing_bias, moments, visible, faces, floor, far, samples, low, high, out):
    """An irradiance volume's look-up (``IrradianceVolume.sample_sh``, whose NumPy form the
    tests hold it to): ``out`` (N, K) at continuous grid coordinates ``grid`` (N, 3) of a
    volume of ``res`` (3,) samples, x-major, at world ``positions`` (S, 3) with ``validity``
    (S,) and rows ``samples`` (S, K), K = 3 m with the DC term first (SH (m, 3) flattened);
    with ``visible``, each sample's depth ``moments`` (S, 6, M + 2, M + 2, 2) with their
    seamless border (``cubemap.with_border``) test whether it sees the point (``_visibility``,
    the variance at least ``floor``, metres squared, the distances clamped at ``far``, metres;
    ``faces``: ``cubemap.FACES``).

    Within the outermost samples: ``_blend`` at the point. Between them and the box's faces
    (half a cell beyond), the blend at the clamped point, scaled by the ratio of its DC term's
    luminance extrapolated (along each such axis, the difference to the blend one cell inward
    times the distance past the samples in cells, at most 1/2) to its own, the ratio kept
    within [``low``, ``high``] (both 1: held); beyond the box, held."""
    n, k = out.shape
    w_plain = np.empty(8, np.float32)
    w_kept = np.empty(8, np.float32)
    rows = np.empty(8, np.int64)
    f = np.empty(3, np.float32)
    g = np.empty(3, np.float32)
    past = np.empty(3, np.float32)
    inward = np.empty(k, np.float32)
    for i in range(n):
        outside = False
        for a in range(3):
            f[a] = min(max(grid[i, a], 0.0), res[a] - 1.0)
            past[a] = 0.0
            if res[a] > 1:
                past[a] = min(max(grid[i, a], -0.5), res[a] - 0.5) - f[a]
                outside = outside or past[a] != 0.0
        row = out[i]
        row[:] = 0.0
        _blend(f, res, positions, validity, has_validity, points[i], normals[i], facing,
               facing_bias, moments, visible, faces, floor, far, samples, row, rows, w_plain,
               w_kept)
        luma = _luminance(row)
        if not outside or luma <= 0.0 or (low == 1.0 and high == 1.0):
            continue
        extra = 0.0
        for a in range(3):
            if past[a] == 0.0:
                continue
            g[:] = f
            g[a] = f[a] + (1.0 if past[a] < 0.0 else -1.0)
            inward[:] = 0.0
            _blend(g, res, positions, validity, has_validity, points[i], normals[i], facing,
                   facing_bias, moments, visible, faces, floor, far, samples, inward, rows,
                   w_plain, w_kept)
            extra += abs(past[a]) * (luma - _luminance(inward))
        scale = min(max(1.0 + extra / luma, low), high)
        for j in range(k):
            row[j] *= scale


mark_cached(__name__)  # every kernel above is compiled or loaded
