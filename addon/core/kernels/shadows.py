"""Shadow filtering kernel: the visibility of every query point, one point at a time.

The filter is ``shadows``'s (module docstring): the point's map and linearized projection
(``_setup_perspective``, ``_setup_ortho``), the disc rotation, the blocker-search region from the
min-depth pyramid, the PCSS blocker search and the PCF kernel, the receiver-plane depth with its
clamp and bias, the pyramid test that proves a footprint fully lit or fully blocked, the texel
test of small footprints, and the exact look-up of taps that leave their map. Arithmetic is
float32, in the order the formulas are written in ``shadows``; the independent checks are
``tests/core/test_shadows.py`` (ray casts of hard shadows and of the visible fraction of disc
lights, penumbra widths, acne and peter-panning).

Per-point set-up values live in a small scratch vector (``F_*`` slots) reused point after
point; the map's constants and the filter's (``shadow_filter.MAX_SLOPE`` ...) come packed by
``shadow_filter.packed`` (``P_*`` and ``I_*`` slots).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from . import mark_cached

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}

# map kinds
CUBE, PERSPECTIVE, ORTHO = 0, 1, 2

# integer constants of a map (``iparams``)
I_KIND, I_RES, I_LEVELS, I_JITTER, I_MIP_FIRST, I_REFINEMENTS, I_SKIP = range(7)
I_SIZE = 7  # I_SKIP: 1, the search region's pyramid test may skip the blocker search

# how each point was decided (``visibility``'s ``how``): not queried (inactive, outside the
# maps), the search region proven lit or dark by the pyramid (no blocker search), a blocker
# search then PCF, the one-texel PCF of hard shadows
HOW_NONE, HOW_PROVEN, HOW_SEARCHED, HOW_HARD = range(4)

# float32 constants of a map (``fparams``)
(P_TAN, P_HALF_RES, P_NEAR, P_NEAR2, P_OFFSET, P_TEXEL, P_INV, P_SIZE, P_MIN_DEPTH,
 P_SLACK, P_CAP, P_NEAR_FLOOR, P_OX, P_OY, P_OZ, P_HALF_INV, P_ONE_HALF_INV, P_MAX_SLOPE,
 P_BIAS_REL, P_BIAS_TEXELS, P_MIN_FILTER) = range(21)
P_SIZE_ALL = 21

# per-point slots of the scratch vector
(F_CX, F_RY, F_JC1, F_JC2, F_JR1, F_JR2, F_W0, F_DIST, F_TEXEL, F_K, F_A, F_B, F_C, F_BIAS,
 F_L1C, F_L1R, F_JC, F_JR, F_DR, F_DU, F_NR, F_NU, F_NF, F_XW, F_YW, F_AC, F_BC, F_AR, F_BR,
 F_COS, F_SIN, F_M) = range(32)
F_SIZE = 32

_NEG = np.float32(-1e-30)
_NEG_INF = np.float32(-np.inf)
_M32 = np.uint64(0xFFFFFFFF)


@nb.njit(**_OPTIONS)
def _mn(a, b):
    """np.minimum of two scalars (NaN wins)."""
    return a if a <= b or a != a else b


@nb.njit(**_OPTIONS)
def _mx(a, b):
    """np.maximum of two scalars (NaN wins)."""
    return a if a >= b or a != a else b


@nb.njit(**_OPTIONS)
def _level(width, first):
    """max(ceil(log2(width)), ``first`` pyramid level) of an integer-valued float width >= 1."""
    iw = np.int64(width)
    level = 0
    while (np.int64(1) << level) < iw:
        level += 1
    return max(level, first)


@nb.njit(**_OPTIONS)
def _unit_normal(nx, ny, nz, ax, ay, az):
    """Unit normal turned against a (light -> point); a zero normal becomes -a / |a|."""
    length = np.sqrt(nx * nx + ny * ny + nz * nz)
    if not length > np.float32(1e-6):
        inv = np.float32(-1.0) / _mx(np.sqrt(ax * ax + ay * ay + az * az), np.float32(1e-12))
        return ax * inv, ay * inv, az * inv
    scale = -length if (nx * ax + ny * ay + nz * az) > np.float32(0.0) else length
    return nx / scale, ny / scale, nz / scale


@nb.njit(**_OPTIONS)
def _cube_face(x, y, z):
    """Cube face (+X, -X, +Y, -Y, +Z, -Z) of a direction and its selectors (fx, fy, fz, sign)."""
    ax, ay, az = abs(x), abs(y), abs(z)
    zero, one = np.float32(0.0), np.float32(1.0)
    if ax >= ay and ax >= az:
        axis, fx, fy, fz, major = 0, one, zero, zero, x
    elif ay >= az:
        axis, fx, fy, fz, major = 1, zero, one, zero, y
    else:
        axis, fx, fy, fz, major = 2, zero, zero, one, z
    neg = major < zero
    return 2 * axis + (1 if neg else 0), fx, fy, fz, (-one if neg else one)


@nb.njit(**_OPTIONS)
def _to_face(fx, fy, fz, sign, x, y, z):
    """(x, y, z) in the (R, U, F) frame of a cube face (signed permutations, exact)."""
    r = ((fy - fz) * x - fx * y) * sign
    u = y * fz + z * (fx + fy)
    f = (x * fx + y * fy + z * fz) * sign
    return r, u, f


@nb.njit(**_OPTIONS)
def _find_cascade(rects, x, y):
    """Finest cascade whose square holds the light-plane point (x, y), or -1; ``rects`` rows
    (cx, cy, half side, z_min) (``shadow_filter._cascades``)."""
    for c in range(rects.shape[0]):
        if abs(x - rects[c, 0]) <= rects[c, 2] and abs(y - rects[c, 1]) <= rects[c, 2]:
            return c
    return -1


@nb.njit(**_OPTIONS)
def _plane_in_texels(fr, fp, res, nf, bx, by):
    """A, B, C of the plane term nf + bx xc + by yc over ndc texel centres (xc, yc)."""
    inv = fp[P_INV]
    fr[F_A] = (nf + bx * fp[P_HALF_INV]) + by * fp[P_ONE_HALF_INV]
    fr[F_B] = bx * inv
    fr[F_C] = -by * inv


@nb.njit(**_OPTIONS)
def _setup_perspective(fr, fp, ip, basis, px, py, pz, nx, ny, nz):
    """Set-up of a point for a cube or spot map; False when no map holds it."""
    cube = ip[I_KIND] == CUBE
    res = ip[I_RES]
    s, h = fp[P_TAN], fp[P_HALF_RES]
    dx, dy, dz = px - fp[P_OX], py - fp[P_OY], pz - fp[P_OZ]
    if cube:
        w = _mx(_mx(abs(dx), abs(dy)), abs(dz))
    else:
        w = _mx(dx * basis[2, 0] + dy * basis[2, 1] + dz * basis[2, 2], np.float32(0.0))
    nx, ny, nz = _unit_normal(nx, ny, nz, dx, dy, dz)
    w = w * fp[P_OFFSET]
    dx, dy, dz = dx + nx * w, dy + ny * w, dz + nz * w
    if cube:
        face, fx, fy, fz, sg = _cube_face(dx, dy, dz)
        dr, du, w = _to_face(fx, fy, fz, sg, dx, dy, dz)
        nr, nu, nf = _to_face(fx, fy, fz, sg, nx, ny, nz)
    else:
        face = 0
        dr = dx * basis[0, 0] + dy * basis[0, 1] + dz * basis[0, 2]
        du = dx * basis[1, 0] + dy * basis[1, 1] + dz * basis[1, 2]
        w = dx * basis[2, 0] + dy * basis[2, 1] + dz * basis[2, 2]
        nr = nx * basis[0, 0] + ny * basis[0, 1] + nz * basis[0, 2]
        nu = nx * basis[1, 0] + ny * basis[1, 1] + nz * basis[1, 2]
        nf = nx * basis[2, 0] + ny * basis[2, 1] + nz * basis[2, 2]
    dist = np.sqrt(dr * dr + du * du + w * w)
    if not dist > fp[P_NEAR2]:
        return False
    inv_sw = np.float32(1.0) / (s * w)
    x0 = dr * inv_sw
    y0 = du * inv_sw
    if not cube and not (w > fp[P_NEAR] and abs(x0) <= np.float32(1.0)
                         and abs(y0) <= np.float32(1.0)):
        return False
    fr[F_M] = np.float32(face)
    fr[F_CX] = (x0 + np.float32(1.0)) * h
    fr[F_RY] = (np.float32(1.0) - y0) * h
    inv_d = np.float32(1.0) / dist
    er, eu, ef = dr * inv_d, du * inv_d, w * inv_d
    g = h * inv_sw
    q = g / (ef * (np.float32(1.0) + ef))
    fr[F_JC2] = er * eu * q
    fr[F_JC1] = g + er * er * q
    fr[F_JR1] = -fr[F_JC2]
    fr[F_JR2] = -(g + eu * eu * q)
    fr[F_W0], fr[F_DIST] = w, dist
    fr[F_TEXEL] = fp[P_TEXEL] * w
    fr[F_K] = dr * nr + du * nu + w * nf
    _plane_in_texels(fr, fp, res, nf, s * nr, s * nu)
    fr[F_BIAS] = fp[P_BIAS_REL] * w + fp[P_BIAS_TEXELS] * fr[F_TEXEL]
    fr[F_L1C] = abs(fr[F_JC1]) + abs(fr[F_JC2])
    fr[F_L1R] = abs(fr[F_JR1]) + abs(fr[F_JR2])
    fr[F_DR], fr[F_DU], fr[F_NR], fr[F_NU], fr[F_NF] = dr, du, nr, nu, nf
    return True


@nb.njit(**_OPTIONS)
def _setup_ortho(fr, fp, ip, basis, rects, px, py, pz, nx, ny, nz):
    """Set-up of a point for sun cascades; False when no cascade holds it."""
    res = ip[I_RES]
    h = fp[P_HALF_RES]
    nx, ny, nz = _unit_normal(nx, ny, nz, basis[2, 0], basis[2, 1], basis[2, 2])
    casc = _find_cascade(rects, px * basis[0, 0] + py * basis[0, 1] + pz * basis[0, 2],
                         px * basis[1, 0] + py * basis[1, 1] + pz * basis[1, 2])
    off = rects[max(casc, 0), 2] * fp[P_OFFSET]
    px, py, pz = px + nx * off, py + ny * off, pz + nz * off
    x = px * basis[0, 0] + py * basis[0, 1] + pz * basis[0, 2]
    y = px * basis[1, 0] + py * basis[1, 1] + pz * basis[1, 2]
    z = px * basis[2, 0] + py * basis[2, 1] + pz * basis[2, 2]
    casc = _find_cascade(rects, x, y)
    if casc < 0:
        return False
    cx, cy, half = rects[casc, 0], rects[casc, 1], rects[casc, 2]
    fr[F_M] = np.float32(casc)
    g = h / half
    fr[F_CX] = (x - cx) * g + h
    fr[F_RY] = h - (y - cy) * g
    fr[F_JC1], fr[F_JC2], fr[F_JR1], fr[F_JR2] = g, np.float32(0.0), np.float32(0.0), -g
    fr[F_W0], fr[F_K] = z, np.float32(0.0)
    fr[F_TEXEL] = fp[P_INV] * half
    nr = nx * basis[0, 0] + ny * basis[0, 1] + nz * basis[0, 2]
    nu = nx * basis[1, 0] + ny * basis[1, 1] + nz * basis[1, 2]
    nf = _mn(nx * basis[2, 0] + ny * basis[2, 1] + nz * basis[2, 2], np.float32(-1e-6))
    inv_nf = np.float32(1.0) / nf
    z0 = z - ((cx - x) * nr + (cy - y) * nu) * inv_nf
    _plane_in_texels(fr, fp, res, z0, -half * nr * inv_nf, -half * nu * inv_nf)
    fr[F_BIAS] = fp[P_BIAS_REL] * abs(z - rects[casc, 3]) + fp[P_BIAS_TEXELS] * fr[F_TEXEL]
    fr[F_XW], fr[F_YW], fr[F_NR], fr[F_NU], fr[F_NF] = x, y, nr, nu, nf
    fr[F_L1C], fr[F_L1R] = g, g
    return True


@nb.njit(**_OPTIONS)
def _rotation_index(bits):
    """One of 1024 disc rotations from a white-noise hash of three 32-bit words ("lowbias32"
    finaliser, C. Wellons)."""
    h = (np.uint64(bits[0]) * np.uint64(0x9E3779B1)) & _M32
    h ^= (np.uint64(bits[1]) * np.uint64(0x85EBCA77)) & _M32
    h ^= (np.uint64(bits[2]) * np.uint64(0xC2B2AE3D)) & _M32
    h ^= h >> np.uint64(16)
    h = (h * np.uint64(0x7FEB352D)) & _M32
    h ^= h >> np.uint64(15)
    h = (h * np.uint64(0x846CA68B)) & _M32
    h ^= h >> np.uint64(16)
    return np.int64(h >> np.uint64(22))


@nb.njit(**_OPTIONS)
def _mip_row(ip, offsets, sides, m, level, col, row):
    """Row of the pyramid block of ``level`` that holds texel (col, row) of map m."""
    li = level - ip[I_MIP_FIRST]
    side = sides[li]
    return offsets[li] + (m * side + (row >> level)) * side + (col >> level)


@nb.njit(**_OPTIONS)
def _receiver_depth(t, k, lo, hi, persp):
    """Clamped receiver-plane depth from the plane term t."""
    if persp:
        t = k / _mn(t, _NEG)
    return _mn(_mx(t, lo), hi)


@nb.njit(**_OPTIONS)
def _footprint_min(fr, ip, mips, offsets, sides, radius):
    """Least map value in the square of half-side ``radius`` metres around the point (the
    2 x 2 pyramid blocks over it); -inf where the square leaves the point's map."""
    res, levels = ip[I_RES], ip[I_LEVELS]
    if levels == 0:
        return _NEG_INF
    rc = radius * fr[F_L1C]
    rr = radius * fr[F_L1R]
    c0, c1 = np.floor(fr[F_CX] - rc), np.floor(fr[F_CX] + rc)
    r0, r1 = np.floor(fr[F_RY] - rr), np.floor(fr[F_RY] + rr)
    fres = np.float32(res)
    if not (c0 >= 0 and c1 < fres and r0 >= 0 and r1 < fres):
        return _NEG_INF
    level = _level(_mx(c1 - c0, r1 - r0) + np.float32(1.0), ip[I_MIP_FIRST])
    if level > ip[I_MIP_FIRST] + levels - 1:
        return _NEG_INF
    m = np.int64(fr[F_M])
    a, b, c, d = np.int64(c0), np.int64(c1), np.int64(r0), np.int64(r1)
    best = mips[3 * _mip_row(ip, offsets, sides, m, level, a, c)]
    best = _mn(best, mips[3 * _mip_row(ip, offsets, sides, m, level, b, c)])
    best = _mn(best, mips[3 * _mip_row(ip, offsets, sides, m, level, a, d)])
    return _mn(best, mips[3 * _mip_row(ip, offsets, sides, m, level, b, d)])


@nb.njit(**_OPTIONS)
def _search_radius(fr, fp, ip, mips, offsets, sides):
    """Radius at the receiver, metres, of the region where blockers can hide the light."""
    size = fp[P_SIZE]
    ortho = ip[I_KIND] == ORTHO
    d_near = fp[P_MIN_DEPTH]
    if ortho:
        d_r = fr[F_W0]
    else:
        d_r = fr[F_DIST]
        d_near = _mx(d_near, fp[P_NEAR_FLOOR])
    cap = fp[P_CAP] * fr[F_TEXEL]
    radius = cap
    for it in range(ip[I_REFINEMENTS] + 1):
        gap = _mx(d_r - d_near, np.float32(0.0))
        radius = _mn(size * gap if ortho else size * gap / d_near, cap)
        if it < ip[I_REFINEMENTS]:
            d_near = _mx(d_near, _footprint_min(fr, ip, mips, offsets, sides, radius))
    return radius


@nb.njit(**_OPTIONS)
def _footprint(fr, fp, radius, reach):
    """Texel rectangle (c0, c1, r0, r1) of every tap of a disc of ``reach`` scaled to
    ``radius``, whatever its rotation."""
    ec = radius * (reach * fr[F_JC]) + fp[P_SLACK]
    er = radius * (reach * fr[F_JR]) + fp[P_SLACK]
    return (np.floor(fr[F_CX] - ec), np.floor(fr[F_CX] + ec), np.floor(fr[F_RY] - er),
            np.floor(fr[F_RY] + er))


@nb.njit(**_OPTIONS)
def _block_test(fr, ip, mips, offsets, sides, c0, c1, r0, r1, lo, hi, dark_cap):
    """(lit, dark) of a footprint inside its map: proven by the least and greatest depth of
    the 2 x 2 pyramid blocks over it and the extreme receiver-plane depths at its corners."""
    persp = ip[I_KIND] != ORTHO
    fa, fb, fc = fr[F_A], fr[F_B], fr[F_C]
    b0, b1 = c0 * fb, c1 * fb
    g0, g1 = r0 * fc, r1 * fc
    t0 = (_mn(b0, b1) + fa) + _mn(g0, g1)
    t1 = (_mx(b0, b1) + fa) + _mx(g0, g1)
    t0 = _receiver_depth(t0, fr[F_K], lo, hi, persp)
    t1 = _receiver_depth(t1, fr[F_K], lo, hi, persp)
    t_lo, t_hi = _mn(t0, t1), _mx(t0, t1)
    t_lo = _mn(t_lo, dark_cap)
    level = _level(_mx(_mx(c1 - c0, r1 - r0), np.float32(1.0)), ip[I_MIP_FIRST])
    if level > ip[I_MIP_FIRST] + ip[I_LEVELS] - 1:
        return False, False
    m = np.int64(fr[F_M])
    a, b, c, d = np.int64(c0), np.int64(c1), np.int64(r0), np.int64(r1)
    rows = (_mip_row(ip, offsets, sides, m, level, a, c),
            _mip_row(ip, offsets, sides, m, level, b, c),
            _mip_row(ip, offsets, sides, m, level, a, d),
            _mip_row(ip, offsets, sides, m, level, b, d))
    lo_d, hi_d = mips[3 * rows[0] + 1], mips[3 * rows[0] + 2]
    for i in range(1, 4):
        lo_d = _mn(lo_d, mips[3 * rows[i] + 1])
        hi_d = _mx(hi_d, mips[3 * rows[i] + 2])
    bias = fr[F_BIAS]
    return lo_d + bias >= t_hi, hi_d + bias < t_lo


@nb.njit(**_OPTIONS)
def _outside_tap(fr, fp, ip, depth, rects, faces, u, v, r, span):
    """Exact look-up of a tap that leaves its point's map: (stored, receiver depth); +inf,
    +inf where no map holds it. u, v: turned unit-disc position; r: kernel radius, metres."""
    kind, res = ip[I_KIND], ip[I_RES]
    inf = np.float32(np.inf)
    if kind == PERSPECTIVE:
        return inf, inf  # outside the spot's frustum: unshadowed
    h, inv = fp[P_HALF_RES], fp[P_INV]
    one, half_t, top = np.float32(1.0), np.float32(0.5), np.float32(res - 1)
    if kind == CUBE:
        m = np.int64(fr[F_M])
        dr, du, df, dist = fr[F_DR], fr[F_DU], fr[F_W0], fr[F_DIST]
        er, eu, ef = dr / dist, du / dist, df / dist
        k = np.float32(-1.0) / (one + ef)
        ou, ov = r * u, r * v
        lr = dr + ou * (one + er * er * k) + ov * (er * eu * k)
        lu = du + ou * (er * eu * k) + ov * (one + eu * eu * k)
        lf = df - ou * er - ov * eu
        fx, fy, fz, sg = faces[0, m], faces[1, m], faces[2, m], faces[3, m]
        fyz, fxy = fy - fz, fx + fy
        nr, nu, nf = fr[F_NR], fr[F_NU], fr[F_NF]
        wx = (fx * lf + fyz * lr) * sg
        wy = (fy * lf - fx * lr) * sg + fz * lu
        wz = fxy * lu + sg * fz * lf
        mx = (fx * nf + fyz * nr) * sg
        my = (fy * nf - fx * nr) * sg + fz * nu
        mz = fxy * nu + sg * fz * nf
        g, gx, gy, gz, gs = _cube_face(wx, wy, wz)
        x, y, w = _to_face(gx, gy, gz, gs, wx, wy, wz)
        nr, nu, nf = _to_face(gx, gy, gz, gs, mx, my, mz)
        col = _mn(_mx(np.floor((x / w + one) * h), np.float32(0.0)), top)
        row = _mn(_mx(np.floor((one - y / w) * h), np.float32(0.0)), top)
        stored = depth[(g * res + np.int64(row)) * res + np.int64(col)]
        xc, yc = (col + half_t) * inv - one, one - (row + half_t) * inv
        den = _mn(nf + xc * nr + yc * nu, _NEG)
        return stored, _mn(_mx(fr[F_K] / den, w - span), w + span)
    xw = fr[F_XW] + r * u  # sun: the finest other cascade that holds the tap
    yw = fr[F_YW] + r * v
    c = _find_cascade(rects, xw, yw)
    if c < 0:
        return inf, inf
    cx, cy, hs = rects[c, 0], rects[c, 1], rects[c, 2]
    col = _mn(_mx(np.floor(((xw - cx) / hs + one) * h), np.float32(0.0)), top)
    row = _mn(_mx(np.floor((one - (yw - cy) / hs) * h), np.float32(0.0)), top)
    stored = depth[(c * res + np.int64(row)) * res + np.int64(col)]
    xs = cx + ((col + half_t) * inv - one) * hs - fr[F_XW]
    ys = cy + (one - (row + half_t) * inv) * hs - fr[F_YW]
    z = fr[F_W0] - (xs * fr[F_NR] + ys * fr[F_NU]) / fr[F_NF]
    w0 = fr[F_W0]
    return stored, _mn(_mx(z, w0 - span), w0 + span)


_TAPS = nb.types.Tuple((nb.int64, nb.float32))(
    nb.float32[::1], nb.float32[::1], nb.int64[::1], nb.float32[::1], nb.float32[:, ::1],
    nb.float32[:, ::1], nb.float32, nb.float32[:, ::1], nb.boolean, nb.boolean)


@nb.njit(_TAPS, **_OPTIONS)  # one compiled form whatever the flags (compile time)
def _taps(fr, fp, ip, depth, rects, faces, radius, disc, measure, check):
    """Blocked taps of ``disc`` (K, 2) scaled to ``radius`` around the point, and (measure)
    their blocker measure sum: d_blocker / d_receiver along the tap's ray (perspective) or
    d_receiver - d_blocker in metres (sun). check: taps may leave the map (exact look-ups)."""
    res = ip[I_RES]
    persp = ip[I_KIND] != ORTHO
    fres = np.float32(res)
    float_index = res * res <= 1 << 24  # row * res + col exact in float32
    base = np.int64(fr[F_M]) * res * res
    ac, bc = radius * fr[F_AC], radius * fr[F_BC]
    ar, br = radius * fr[F_AR], radius * fr[F_BR]
    cx, ry = fr[F_CX], fr[F_RY]
    fa, fb, fc, fk, bias = fr[F_A], fr[F_B], fr[F_C], fr[F_K], fr[F_BIAS]
    span = fp[P_MAX_SLOPE] * (radius + fr[F_TEXEL])
    lo, hi = fr[F_W0] - span, fr[F_W0] + span
    cs, sn = fr[F_COS], fr[F_SIN]
    count = 0
    acc = 0.0
    for k in range(disc.shape[0]):
        a, b = disc[k, 0], disc[k, 1]
        colf = np.floor((ac * a + cx) + bc * b)
        rowf = np.floor((ar * a + ry) + br * b)
        if check and (min(colf, rowf) < np.float32(0.0) or max(colf, rowf) >= fres):
            stored, t = _outside_tap(fr, fp, ip, depth, rects, faces, a * cs - b * sn,
                                     a * sn + b * cs, radius, span)
        else:
            if float_index:
                index = np.int64(rowf * fres + colf)
            else:
                index = np.int64(rowf) * res + np.int64(colf)
            stored = depth[index + base]
            t = _receiver_depth((colf * fb + fa) + rowf * fc, fk, lo, hi, persp)
        if stored + bias < t:
            count += 1
            if measure:
                acc += np.float64(stored / t if persp else t - stored)
    return count, np.float32(acc)


@nb.njit(**_OPTIONS)
def _pcf(fr, fp, ip, depth, mips, offsets, sides, rects, faces, radius, disc, reach):
    """Fraction of unblocked taps of ``disc`` scaled to ``radius``. Footprints of at most
    4 x 4 texels: each texel compared once (all blocked -> 0, none -> 1, else taps); wider
    ones: the pyramid test, then taps; footprints leaving the map: taps with exact look-ups."""
    res = ip[I_RES]
    fres = np.float32(res)
    c0, c1, r0, r1 = _footprint(fr, fp, radius, reach)
    scale = np.float32(1.0) / np.float32(disc.shape[0])
    if not (c0 >= 0 and r0 >= 0 and c1 < fres and r1 < fres):
        count, _ = _taps(fr, fp, ip, depth, rects, faces, radius, disc, False, True)
        return np.float32(1.0) - np.float32(count) * scale
    span = fp[P_MAX_SLOPE] * (radius + fr[F_TEXEL])
    lo, hi = fr[F_W0] - span, fr[F_W0] + span
    if _mx(c1 - c0, r1 - r0) < np.float32(4.0):
        persp = ip[I_KIND] != ORTHO
        base = np.int64(fr[F_M]) * res * res
        fa, fb, fc, fk, bias = fr[F_A], fr[F_B], fr[F_C], fr[F_K], fr[F_BIAS]
        blocked = 0
        cells = 0
        for row in range(np.int64(r0), np.int64(r1) + 1):
            for col in range(np.int64(c0), np.int64(c1) + 1):
                t = (np.float32(col) * fb + fa) + np.float32(row) * fc
                t = _receiver_depth(t, fk, lo, hi, persp)
                if depth[base + row * res + col] + bias < t:
                    blocked += 1
                cells += 1
        if blocked == 0:
            return np.float32(1.0)
        if blocked == cells:
            return np.float32(0.0)
    else:
        lit, dark = _block_test(fr, ip, mips, offsets, sides, c0, c1, r0, r1, lo, hi, hi)
        if dark:
            return np.float32(0.0)
        if lit:
            return np.float32(1.0)
    count, _ = _taps(fr, fp, ip, depth, rects, faces, radius, disc, False, False)
    return np.float32(1.0) - np.float32(count) * scale


@nb.njit(**_OPTIONS)
def _pcss(fr, fp, ip, depth, mips, offsets, sides, rects, faces, r_search, r_min,
          blocker_disc, pcf_disc, pcf_reach):
    """Percentage-closer soft shadows (Fernando 2005) of the point: the pyramid test of the
    search region (``I_SKIP``), the blocker search, then PCF with the penumbra radius;
    (visibility, HOW_PROVEN or HOW_SEARCHED)."""
    res = ip[I_RES]
    fres = np.float32(res)
    c0, c1, r0, r1 = _footprint(fr, fp, r_search, np.float32(1.0))
    inside = c0 >= 0 and r0 >= 0 and c1 < fres and r1 < fres
    if inside and ip[I_SKIP] != 0:
        span = fp[P_MAX_SLOPE] * (r_search + fr[F_TEXEL])
        cap = fr[F_W0] + fp[P_MAX_SLOPE] * (r_min + fr[F_TEXEL])
        lit, dark = _block_test(fr, ip, mips, offsets, sides, c0, c1, r0, r1,
                                fr[F_W0] - span, fr[F_W0] + span, cap)
        if dark:
            return np.float32(0.0), HOW_PROVEN
        if lit:
            return np.float32(1.0), HOW_PROVEN
    count, acc = _taps(fr, fp, ip, depth, rects, faces, r_search, blocker_disc, True,
                       not inside)
    if count == 0:
        return np.float32(1.0), HOW_SEARCHED
    mean = acc / np.float32(count)
    size = fp[P_SIZE]
    if ip[I_KIND] == ORTHO:
        radius = size * mean  # tan(angle / 2) (d_r - d_b)
    else:  # R (d_r - d_b) / d_b
        radius = size * (np.float32(1.0) - mean) / _mx(mean, np.float32(1e-6))
    radius = _mn(_mx(radius, r_min), r_search)
    return _pcf(fr, fp, ip, depth, mips, offsets, sides, rects, faces, radius, pcf_disc,
                pcf_reach), HOW_SEARCHED


_VIS = nb.void(
    nb.float32[::1], nb.float32[::1], nb.int64[::1], nb.int64[::1],  # depth, mips, offsets, sides
    nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[:, ::1],  # basis, cascades, faces
    nb.float32[::1], nb.int64[::1],  # fparams, iparams
    nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[::1],  # discs, reaches
    nb.float32[::1], nb.float32[::1],  # rotation cos, sin
    nb.float32[:, ::1], nb.float32[:, ::1], nb.uint32[:, ::1],  # points, normals, seeds,
    nb.boolean[::1], nb.float32[::1], nb.uint8[::1],  # active; out, how
)


@nb.njit(_VIS, **_OPTIONS)
def visibility(depth, mips, offsets, sides, basis, rects, faces, fp, ip, blocker_disc,
               pcf_disc, hard_disc, reaches, rot_cos, rot_sin, points, normals, seeds, active,
               out, how):
    """Fraction of the light that reaches each point (``shadow_filter.shadow_visibility``):
    ``out`` (N,) for points (N, 3) and normals (N, 3) where ``active`` (N,) (elsewhere 1),
    each point's disc turned by the hash of its three ``seeds`` (N, 3); points outside every
    map, and points with non-finite coordinates, are lit (1). ``how`` (N,): how each point
    was decided (``HOW_*``)."""
    fr = np.zeros(F_SIZE, np.float32)
    ortho = ip[I_KIND] == ORTHO
    for i in range(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        nx, ny, nz = normals[i, 0], normals[i, 1], normals[i, 2]
        out[i] = np.float32(1.0)
        how[i] = HOW_NONE
        if not active[i] or not np.isfinite(px + py + pz + nx + ny + nz):
            continue
        if ortho:
            ok = _setup_ortho(fr, fp, ip, basis, rects, px, py, pz, nx, ny, nz)
        else:
            ok = _setup_perspective(fr, fp, ip, basis, px, py, pz, nx, ny, nz)
        if not ok:
            continue
        fr[F_JC] = np.sqrt(fr[F_JC1] * fr[F_JC1] + fr[F_JC2] * fr[F_JC2])
        fr[F_JR] = np.sqrt(fr[F_JR1] * fr[F_JR1] + fr[F_JR2] * fr[F_JR2])
        if ip[I_JITTER]:
            k = _rotation_index(seeds[i])
            c, s = rot_cos[k], rot_sin[k]
        else:
            c, s = np.float32(1.0), np.float32(0.0)
        fr[F_AC] = c * fr[F_JC1] + s * fr[F_JC2]  # texels per metre along the turned disc axes
        fr[F_BC] = c * fr[F_JC2] - s * fr[F_JC1]
        fr[F_AR] = c * fr[F_JR1] + s * fr[F_JR2]
        fr[F_BR] = c * fr[F_JR2] - s * fr[F_JR1]
        fr[F_COS], fr[F_SIN] = c, s
        r_min = fp[P_MIN_FILTER] * fr[F_TEXEL]
        if fp[P_SIZE] > 0:
            r_search = _search_radius(fr, fp, ip, mips, offsets, sides)
            if r_search > np.float32(1.5) * r_min:  # else too small a light: hard shadows
                out[i], how[i] = _pcss(fr, fp, ip, depth, mips, offsets, sides, rects, faces,
                                       _mx(r_search, r_min), r_min, blocker_disc, pcf_disc,
                                       reaches[1])
                continue
        how[i] = HOW_HARD
        out[i] = _pcf(fr, fp, ip, depth, mips, offsets, sides, rects, faces, r_min,
                      hard_disc, reaches[2])


mark_cached(__name__)  # every kernel above is compiled or loaded
