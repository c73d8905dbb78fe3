"""Rasterization kernels: every step of ``raster``'s module docstring but the clipping and the
scan order's sort (the docstring gives the method, the exactness argument and the references).

``place`` puts a mesh's triangles where each of its instances is; ``project`` takes world
corners to clip space; ``survivors`` and ``tile_survivors`` are step 1's
trivial rejection (non-finite corners, triangles wholly beyond one frustum plane), the latter
re-projecting a tile to the viewport; ``window`` and ``edges`` are step 2's set-up, bit for bit
the NumPy they replaced; ``scan`` walks each triangle's rows of samples, finds the covered span
of each row from the three edge functions (exact: integer floor divisions, or float64 where
the quotient is provably exact), and keeps the smallest packed key (quantized depth, triangle
index) of every pixel; ``resolve`` turns every pixel's key into the original triangle,
perspective-correct weights and clip w. ``nearest`` does all of that for a perspective view
without the set-up, each triangle walked straight from its corners (views drawn once or a few
times). For shadow maps: ``reduction`` builds the min/max pyramid, ``ortho_depths`` and
``perspective_depths`` a map's depths straight from its triangles (no set-up: a map without
transparent casters needs no triangle indices nor weights), ``corner_sum`` the depths of the
texels a raster found, ``clipped_depths`` the depth range of the geometry inside a camera's
frustum or a sun cascade's square, ``extent`` and ``distances`` the geometry's reach along
directions and from a light.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from . import mark_cached

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}
EMPTY = np.uint64(0xFFFF_FFFF_FFFF_FFFF)
_FAR_COLUMN = 2.0**39  # the bound of a horizontal edge: beyond any image
NEVER = 2.0**-40  # |A| standing in for a horizontal edge: its bound is +-2^39 columns
# texels a depth map's triangle reaches beyond its edges (``ortho_depths``): a centre on an edge
# shared by two triangles is covered by both whatever the rounding of their bounds (no cracks)
_REACH = 1e-7

_SCAN = nb.void(
    nb.int64[:, ::1], nb.int64[:, ::1], nb.int64[:, ::1],  # ea, eb, ec (3, N)
    nb.float64[:, ::1], nb.float64[:, ::1], nb.float64[:, ::1],  # eb_f, ea_abs, half (3, N)
    nb.float64[::1], nb.float64[::1],  # off_lo, off_hi (N,)
    nb.int64[::1], nb.int64[::1],  # ymin, rows (N,)
    nb.float64[::1], nb.float64[::1], nb.float64[::1],  # za, zb, zc (N,)
    nb.boolean[::1], nb.uint64[::1],  # tame, sid (N,)
    nb.int64, nb.int64, nb.int64, nb.int64, nb.int64,  # width, height, sub_bits, oxi, oyi
    nb.float64, nb.float64, nb.float64, nb.int64, nb.boolean,  # ox, oy, qmax, ibits, exact_int
    nb.uint64[::1], nb.uint64[::1],  # keyfloor, keybuf (H * W,)
)


@nb.njit(_SCAN, **_OPTIONS)
def scan(ea, eb, ec, eb_f, ea_abs, half, off_lo, off_hi, ymin, rows, za, zb, zc, tame, sid,
         width, height, sub_bits, oxi, oyi, ox, oy, qmax, ibits, exact_int, keyfloor, keybuf):
    """Depth-resolve every covered (triangle, sample) into ``keybuf`` (the minimum key wins).
    Keys (depth, then sub-triangle: a total order) not above ``keyfloor`` are refused, so a
    second scan with the first's keys as the floor peels the next layer (all zeros: none).

    Per triangle in scan order: edges (left, right, either) as fixed-point edge functions
    E_j = ea_j x + eb_j y + ec_j (top-left rule folded into ec), its first sample row, rows
    scanned, the key depth u = za x + zb y + zc (x, y in pixels) and its index ``sid``.
    """
    unit_m1 = (np.int64(1) << sub_bits) - 1
    m0 = np.empty(3, np.int64)
    f = np.empty(3, np.float64)
    for t in range(ea.shape[1]):
        r0 = min((ymin[t] - oyi + unit_m1) >> sub_bits, height)
        r_top = max(min(r0, height - rows[t]), 0)
        for j in range(3):  # floor(-E(column 0, row 0) / 2^S); on row r: m0 - eb r
            m0[j] = (-(eb[j, t] * oyi + ec[j, t] + ea[j, t] * oxi)) >> sub_bits
        for k in range(rows[t]):
            r = r_top + k
            for j in range(3):
                if exact_int:
                    m = m0[j] - eb[j, t] * r
                    if ea[j, t] == 0:
                        f[j] = -_FAR_COLUMN if m < 0 else _FAR_COLUMN
                    else:
                        f[j] = np.float64(m // abs(ea[j, t]))
                else:
                    f[j] = ((np.float64(m0[j]) + half[j, t]) - eb_f[j, t] * np.float64(r)) \
                        / ea_abs[j, t]
            lo = max(f[0], f[2] + off_lo[t])
            hi = max(f[1], f[2] + off_hi[t])
            lo = max(np.floor(lo), -1.0)
            hi = max(np.floor(hi), -np.float64(width))
            if not lo + hi < -1.0:
                continue
            first = np.int64(lo) + 1
            n = np.int64(-1.0 - (lo + hi))
            zrow = zb[t] * (np.float64(r) + oy)
            base = r * width
            for c in range(first, first + n):
                u = (np.float64(c) + ox) * za[t]
                u += zrow
                u += zc[t]
                if not tame[t]:
                    if not u <= qmax:  # beyond the far plane
                        continue
                    u = max(u, 0.0)
                key = (np.uint64(u) << np.uint64(ibits)) | sid[t]
                if key < keybuf[base + c] and (key > keyfloor[base + c] or
                                               keyfloor[base + c] == 0):
                    keybuf[base + c] = key


_RESOLVE = nb.void(
    nb.uint64[::1], nb.int64, nb.intp[::1], nb.float64[:, ::1], nb.int32[::1],  # keys, ibits,
    nb.boolean[::1], nb.float64[:, :, ::1], nb.intp[::1],  # slot, table, orig, clipped, sub
    nb.int64, nb.float64, nb.float64, nb.boolean,  # width, ox, oy, with_bary
    nb.int32[::1], nb.float32[:, ::1], nb.float32[::1],  # out: tri, bary, depth
)


@nb.njit(_RESOLVE, **_OPTIONS)
def resolve(keys, ibits, slot, table, orig, clipped, sub_bary, sub_index, width, ox, oy,
            with_bary, tri_out, bary_out, depth_out):
    """Every pixel's original triangle, perspective-correct weights (``with_bary``; else
    ``bary_out`` is not touched) and clip w (-1, 0, +inf where its key is ``EMPTY``):
    q_i = table[i] x + table[3 + i] y + table[6 + i] (at least 0), weights q_i / sum(q),
    w = 1 / sum(q); a clipped piece's weights carried to the original corners through its
    ``sub_bary``."""
    mask = (np.uint64(1) << np.uint64(ibits)) - np.uint64(1)
    q = np.empty(3, np.float64)
    b = np.empty(3, np.float64)
    for p in range(keys.size):
        key = keys[p]
        if key == EMPTY:
            tri_out[p] = -1
            depth_out[p] = np.inf
            if with_bary:
                bary_out[p, 0] = bary_out[p, 1] = bary_out[p, 2] = 0.0
            continue
        s = slot[np.intp(key & mask)]
        x = np.float64(p % width) + ox
        y = np.float64(p // width) + oy
        for i in range(3):
            q[i] = max(table[i, s] * x + table[3 + i, s] * y + table[6 + i, s], 0.0)
        inv = 1.0 / ((q[0] + q[1]) + q[2])
        depth_out[p] = inv
        tri_out[p] = orig[s]
        if not with_bary:
            continue
        if clipped[s]:
            sub = sub_bary[sub_index[s]]
            for i in range(3):
                b[i] = q[i] * inv
            for j in range(3):
                bary_out[p, j] = (b[0] * sub[0, j] + b[1] * sub[1, j]) + b[2] * sub[2, j]
        else:
            for i in range(3):
                bary_out[p, i] = q[i] * inv


@nb.njit(**_OPTIONS)
def _affine(rows, k, corners, t, c):
    """Row ``k`` of the affine map ``rows`` (K, 4) at corner ``c`` of triangle ``t`` of
    ``corners`` (T, 3, 3), in float64: ((r0 x + r1 y) + r2 z) + r3."""
    x = np.float64(corners[t, c, 0])
    y = np.float64(corners[t, c, 1])
    z = np.float64(corners[t, c, 2])
    return ((rows[k, 0] * x + rows[k, 1] * y) + rows[k, 2] * z) + rows[k, 3]


@nb.njit([nb.void(nb.float32[:, :, ::1], nb.float64[:, ::1], nb.float32[:, :, ::1]),
          nb.void(nb.float64[:, :, ::1], nb.float64[:, ::1], nb.float64[:, :, ::1])], **_OPTIONS)
def project(positions, matrix, clip):
    """Clip-space corners ``clip`` (T, 3, 4) of world corners ``positions`` (T, 3, 3) through
    the 4 x 4 ``matrix``: each coordinate summed in float64 in the order x, y, z, w, then
    stored in ``clip``'s type."""
    for t in range(positions.shape[0]):
        for c in range(3):
            for r in range(4):
                clip[t, c, r] = _affine(matrix, r, positions, t, c)


@nb.njit(nb.void(nb.float32[:, :, ::1], nb.float32[:, :, ::1], nb.float32[:, ::1],
                 nb.float64[:, ::1], nb.float32[:, :, ::1], nb.float32[:, :, ::1],
                 nb.float64[:, :, ::1], nb.boolean[::1]), **_OPTIONS)
def place(positions, normals, local, parent, positions_out, normals_out, world_to_object,
          mirrored):
    """One mesh's triangles (T, 3, 3) placed by I instances: ``positions_out`` and unit
    ``normals_out`` (I T, 3, 3), instance by instance, the matrix of instance i being
    ``parent`` (4, 4) times its ``local`` (I, 16) matrix (column-major, as Blender stores
    instance transforms), all in float64; normals through its inverse transpose (from the
    cofactors). Also ``world_to_object`` (I, 4, 4), the inverses (identity for a matrix flat
    to rounding: |det| <= 1e-12 max|m|^3),
    and ``mirrored`` (I,): a negative determinant, whose corners go in reverse order so that
    fronts stay counter-clockwise."""
    m = np.empty((4, 4))
    q = np.empty((3, 3))
    tris = positions.shape[0]
    for i in range(local.shape[0]):
        for r in range(4):
            for c in range(4):
                acc = 0.0
                for k in range(4):
                    acc += parent[r, k] * np.float64(local[i, 4 * c + k])
                m[r, c] = acc
        # cofactors: q = det * inverse transpose of the linear part
        q[0, 0] = m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1]
        q[0, 1] = m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2]
        q[0, 2] = m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0]
        q[1, 0] = m[2, 1] * m[0, 2] - m[2, 2] * m[0, 1]
        q[1, 1] = m[2, 2] * m[0, 0] - m[2, 0] * m[0, 2]
        q[1, 2] = m[2, 0] * m[0, 1] - m[2, 1] * m[0, 0]
        q[2, 0] = m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]
        q[2, 1] = m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]
        q[2, 2] = m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
        det = m[0, 0] * q[0, 0] + m[0, 1] * q[0, 1] + m[0, 2] * q[0, 2]
        size = 0.0
        for r in range(3):
            for c in range(3):
                size = max(size, abs(m[r, c]))
        if not abs(det) > 1e-12 * size * size * size:  # flat, to rounding
            det = 0.0
        mirrored[i] = det < 0.0
        inv = world_to_object[i]
        inv[:, :] = 0.0
        inv[3, 3] = 1.0
        if det != 0.0:
            for r in range(3):
                for c in range(3):
                    q[r, c] /= det
                    inv[c, r] = q[r, c]
            for r in range(3):
                inv[r, 3] = -(inv[r, 0] * m[0, 3] + inv[r, 1] * m[1, 3] + inv[r, 2] * m[2, 3])
        else:  # flat: normals through the matrix itself
            for r in range(3):
                inv[r, r] = 1.0
                for c in range(3):
                    q[r, c] = m[r, c]
        for t in range(tris):
            o = i * tris + t
            for c in range(3):
                d = 2 - c if det < 0.0 else c
                x, y, z = positions[t, c, 0], positions[t, c, 1], positions[t, c, 2]
                a, b, e = normals[t, c, 0], normals[t, c, 1], normals[t, c, 2]
                length = 0.0
                for r in range(3):
                    positions_out[o, d, r] = m[r, 0] * x + m[r, 1] * y + m[r, 2] * z + m[r, 3]
                    v = q[r, 0] * a + q[r, 1] * b + q[r, 2] * e
                    normals_out[o, d, r] = v
                    length += v * v
                scale = 1.0 / max(np.sqrt(length), 1e-20)
                for r in range(3):
                    normals_out[o, d, r] *= scale


KEPT, OUTSIDE, NOT_FINITE = 0, 1, 2


@nb.njit(**_OPTIONS)
def _rejection(corners):
    """Step 1's trivial rejection of one triangle's clip corners (3, 4): NOT_FINITE, OUTSIDE
    (x, y or z above w, or below -w, at all three corners) or KEPT."""
    for c in range(3):
        for k in range(4):
            if not np.isfinite(corners[c, k]):
                return NOT_FINITE
    for k in range(3):
        above = True
        below = True
        for c in range(3):
            w = corners[c, 3]
            above = above and corners[c, k] > w
            below = below and corners[c, k] < -w
        if above or below:
            return OUTSIDE
    return KEPT


_COUNTS = nb.types.UniTuple(nb.int64, 2)


@nb.njit([_COUNTS(nb.float32[:, :, ::1], nb.int64[::1]),
          _COUNTS(nb.float64[:, :, ::1], nb.int64[::1])], **_OPTIONS)
def survivors(clip, orig):
    """Writes to ``orig`` the indices of the triangles of ``clip`` (T, 3, 4) that
    ``_rejection`` keeps; returns their count and the count of triangles with a non-finite
    corner."""
    n = 0
    n_nan = 0
    for t in range(clip.shape[0]):
        code = _rejection(clip[t])
        if code == KEPT:
            orig[n] = t
            n += 1
        elif code == NOT_FINITE:
            n_nan += 1
    return n, n_nan


@nb.njit([_COUNTS(nb.float32[:, :, ::1], nb.int64, nb.int64, nb.float64, nb.float64,
                  nb.int64[::1]),
          _COUNTS(nb.float64[:, :, ::1], nb.int64, nb.int64, nb.float64, nb.float64,
                  nb.int64[::1])], **_OPTIONS)
def sample_survivors(clip, width, height, ox, oy, orig):
    """``survivors`` for one sample offset (ox, oy): also left out, the triangles in front of
    the camera whose window box holds no sample (c + ox, r + oy) by more than 0.01 pixel, a
    margin far beyond the rounding of the clip coordinates and the fixed-point snap (2^-12
    pixel), so that the exact coverage test later sees every triangle that covers a sample.
    Most triangles far smaller than a pixel hold none."""
    n = 0
    n_nan = 0
    for t in range(clip.shape[0]):
        code = _rejection(clip[t])
        if code == NOT_FINITE:
            n_nan += 1
            continue
        if code != KEPT:
            continue
        ahead = True
        x_lo, x_hi, y_lo, y_hi = np.inf, -np.inf, np.inf, -np.inf
        for c in range(3):
            w = np.float64(clip[t, c, 3])
            if not w > 0.0:
                ahead = False
                break
            x = (np.float64(clip[t, c, 0]) / w + 1.0) * 0.5 * width
            y = (1.0 - np.float64(clip[t, c, 1]) / w) * 0.5 * height
            x_lo, x_hi = min(x_lo, x), max(x_hi, x)
            y_lo, y_hi = min(y_lo, y), max(y_hi, y)
        if ahead and (np.ceil(x_lo - 0.01 - ox) > np.floor(x_hi + 0.01 - ox)
                      or np.ceil(y_lo - 0.01 - oy) > np.floor(y_hi + 0.01 - oy)):
            continue
        orig[n] = t
        n += 1
    return n, n_nan


_I3 = nb.int64[:, ::1]
_D3 = nb.float64[:, ::1]


@nb.njit(nb.void(_D3, nb.int64, nb.int64, nb.int64, nb.float64, _I3, _I3, _D3, _D3, _D3, _D3,
                 nb.boolean[::1], nb.int64[::1]), **_OPTIONS)
def window(v, width, height, unit, lim, xi, yi, px, py, zn, inv_w, usable, area2):
    """Step 2's window coordinates of the (clipped) triangles, corners c = 0, 1, 2 of column t
    of ``v`` (12, M) (row 4 c + k: clip coordinate k): float64 ``px``, ``py`` (y down), NDC
    z ``zn`` and 1 / w ``inv_w`` (3, M) (1 where some corner has w <= 0: ``usable`` False),
    fixed-point ``xi``, ``yi`` (3, M) (rounded half to even, clamped to +-``lim``), and twice
    the fixed-point signed area ``area2`` (M,)."""
    half_w, half_h = 0.5 * width, 0.5 * height
    for t in range(v.shape[1]):
        ok = v[3, t] > 0.0 and v[7, t] > 0.0 and v[11, t] > 0.0
        usable[t] = ok
        for c in range(3):
            iw = 1.0 / (v[4 * c + 3, t] if ok else 1.0)
            inv_w[c, t] = iw
            x = (v[4 * c, t] * iw + 1.0) * half_w
            y = (1.0 - v[4 * c + 1, t] * iw) * half_h
            px[c, t], py[c, t] = x, y
            zn[c, t] = v[4 * c + 2, t] * iw
            xi[c, t] = np.int64(np.rint(min(max(x * unit, -lim), lim)))
            yi[c, t] = np.int64(np.rint(min(max(y * unit, -lim), lim)))
        area2[t] = ((xi[1, t] - xi[0, t]) * (yi[2, t] - yi[0, t])
                    - (xi[2, t] - xi[0, t]) * (yi[1, t] - yi[0, t]))


@nb.njit(**_OPTIONS)
def _permute(rows, order):
    """Each row r of ``rows`` (R, N) replaced by rows[r, order] (one row at a time, so that
    the gather stays in cache)."""
    buf = np.empty(rows.shape[1], rows.dtype)
    for r in range(rows.shape[0]):
        for j in range(order.shape[0]):
            buf[j] = rows[r, order[j]]
        for j in range(order.shape[0]):  # (a loop: slice assignment is slow to compile)
            rows[r, j] = buf[j]


@nb.njit(**_OPTIONS)
def _permute_row(row, order):
    """``row`` (N,) replaced by row[order] (``_permute`` of one row: a reshaped view would
    compile numba's shape-error formatting, seconds on a cold cache)."""
    buf = np.empty(row.shape[0], row.dtype)
    for j in range(order.shape[0]):
        buf[j] = row[order[j]]
    for j in range(order.shape[0]):
        row[j] = buf[j]


_EDGES = nb.void(
    nb.int64[::1], nb.int64[::1], _I3, _I3, _D3, _D3, _D3, _D3, nb.int64[::1],  # keep, order;
    # xi, yi, px, py, zn, inv_w (3, M), area2 (M,)
    nb.int64, nb.float64, nb.float64, nb.float64,  # unit, qmax, err_ab, err_c
    _I3, _I3, _I3, _D3, _D3, _D3,  # out: ea, eb, ec, eb_f, ea_abs, half (3, N)
    nb.float64[::1], nb.float64[::1],  # off_lo, off_hi (N,)
    nb.float64[::1], nb.float64[::1], nb.float64[::1], nb.boolean[::1], _D3,  # za, zb, zc, tame,
)  # table (9, N)


@nb.njit(_EDGES, **_OPTIONS)
def edges(keep, order, xi, yi, px, py, zn, inv_w, area2, unit, qmax, err_ab, err_c, ea, eb,
          ec, eb_f, ea_abs, half, off_lo, off_hi, za, zb, zc, tame, table):
    """Step 2's edge functions and step 3's planes of the triangles ``keep`` (N,) (columns of
    ``window``'s output), in scan order: column j for triangle keep[order[j]]; edges in slots (left
    ea > 0, right ea < 0, either), the top-left rule's 1 added to ec; the float64 screen-space
    barycentric planes (divided by w in ``table``: qa_i, qb_i, qc_i of ``raster._Setup``), the
    key-depth plane za, zb, zc and ``tame`` (the corners' key depths inside [0, qmax] by more
    than err_ab (|za| + |zb|) + err_c |zc|); NumPy's order of operations throughout."""
    for j in range(keep.shape[0]):  # in the order of keep, then permuted row by row
        t = keep[j]
        sign = np.int64(1) if area2[t] > 0 else np.int64(-1)
        x0, x1, x2 = xi[0, t], xi[1, t], xi[2, t]
        y0, y1, y2 = yi[0, t], yi[1, t], yi[2, t]
        # edge i runs from corner i + 1 to corner i + 2
        a0, b0, c0 = (y1 - y2) * sign, (x2 - x1) * sign, (x1 * y2 - y1 * x2) * sign
        a1, b1, c1 = (y2 - y0) * sign, (x0 - x2) * sign, (x2 * y0 - y2 * x0) * sign
        a2, b2, c2 = (y0 - y1) * sign, (x1 - x0) * sign, (x0 * y1 - y0 * x1) * sign
        c0 += 1 if a0 > 0 or (a0 == 0 and b0 > 0) else 0  # top-left rule
        c1 += 1 if a1 > 0 or (a1 == 0 and b1 > 0) else 0
        c2 += 1 if a2 > 0 or (a2 == 0 and b2 > 0) else 0
        s0 = 0 if a0 > 0 else (1 if a1 > 0 else (2 if a2 > 0 else 0))  # first ea > 0
        s1 = 0 if a0 < 0 else (1 if a1 < 0 else (2 if a2 < 0 else 0))  # first ea < 0
        for k in range(3):
            e = s0 if k == 0 else (s1 if k == 1 else 3 - s0 - s1)
            if e == 0:
                ek, fk, gk = a0, b0, c0
            elif e == 1:
                ek, fk, gk = a1, b1, c1
            else:
                ek, fk, gk = a2, b2, c2
            ea[k, j], eb[k, j], ec[k, j] = ek, fk, gk
            eb_f[k, j] = np.float64(fk)
            ea_abs[k, j] = NEVER if ek == 0 else np.float64(abs(ek))
            half[k, j] = 0.5 if ek == 0 else 0.0
        off_lo[j] = 0.0 if ea[2, j] >= 0 else -np.inf
        off_hi[j] = -np.inf if ea[2, j] >= 0 else 0.0
        qx, qy = px[0, t], py[0, t]
        e1x, e1y = px[1, t] - qx, py[1, t] - qy
        e2x, e2y = px[2, t] - qx, py[2, t] - qy
        fa = e1x * e2y - e2x * e1y
        inv_a = 1.0 / fa if fa != 0.0 else 0.0
        la1, la2 = e2y * inv_a, -e1y * inv_a
        lb1, lb2 = -e2x * inv_a, e1x * inv_a
        lc1 = -la1 * qx - lb1 * qy
        lc2 = -la2 * qx - lb2 * qy
        la0, lb0, lc0 = -la1 - la2, -lb1 - lb2, 1.0 - lc1 - lc2
        zs0 = (zn[0, t] + 1.0) * (0.5 * qmax)
        zs1 = (zn[1, t] + 1.0) * (0.5 * qmax)
        zs2 = (zn[2, t] + 1.0) * (0.5 * qmax)
        pa = (la0 * zs0 + la1 * zs1) + la2 * zs2
        pb = (lb0 * zs0 + lb1 * zs1) + lb2 * zs2
        pc = (lc0 * zs0 + lc1 * zs1) + lc2 * zs2
        za[j], zb[j], zc[j] = pa, pb, pc
        err = (abs(pa) + abs(pb)) * err_ab + abs(pc) * err_c
        ok = True
        for c in range(3):
            u = (pa * (xi[c, t] / unit) + pb * (yi[c, t] / unit)) + pc
            ok = ok and u - err >= 0.0 and u + err <= qmax
        tame[j] = ok
        w0, w1, w2 = inv_w[0, t], inv_w[1, t], inv_w[2, t]
        table[0, j], table[1, j], table[2, j] = la0 * w0, la1 * w1, la2 * w2
        table[3, j], table[4, j], table[5, j] = lb0 * w0, lb1 * w1, lb2 * w2
        table[6, j], table[7, j], table[8, j] = lc0 * w0, lc1 * w1, lc2 * w2
    _permute(ea, order)
    _permute(eb, order)
    _permute(ec, order)
    _permute(eb_f, order)
    _permute(ea_abs, order)
    _permute(half, order)
    _permute(table, order)
    _permute_row(off_lo, order)
    _permute_row(off_hi, order)
    _permute_row(za, order)
    _permute_row(zb, order)
    _permute_row(zc, order)
    _permute_row(tame, order)


@nb.njit(nb.int64(nb.float32[:, :, ::1], nb.float32, nb.float32, nb.float32, nb.float32,
                  nb.float32[:, :, ::1], nb.int64[::1]), **_OPTIONS)
def tile_survivors(clip, ax, bx, ay, by, out, orig):
    """Re-project ``clip`` (T, 3, 4) so that a tile fills the viewport (x' = x ax + w bx,
    y' = y ay + w by, float32) and keep the triangles ``survivors`` keeps: their corners in
    ``out`` and their indices in ``orig``, in order; returns their count."""
    n = 0
    for t in range(clip.shape[0]):
        corner = out[n]  # written in place, kept when the triangle survives
        for c in range(3):
            w = clip[t, c, 3]
            corner[c, 0] = clip[t, c, 0] * ax + w * bx
            corner[c, 1] = clip[t, c, 1] * ay + w * by
            corner[c, 2] = clip[t, c, 2]
            corner[c, 3] = w
        if _rejection(corner) == KEPT:
            orig[n] = t
            n += 1
    return n


@nb.njit(nb.int64(nb.float32[:, :, ::1], nb.float64[:, ::1], nb.boolean[::1], nb.float32,
                  nb.float32, nb.float32, nb.float32, nb.float32[:, :, ::1], nb.int64[::1]),
         **_OPTIONS)
def project_survivors(positions, matrix, seen, ax, bx, ay, by, out, orig):
    """``project`` then ``tile_survivors`` in one pass, bit for bit: the world corners
    ``positions`` (T, 3, 3) through ``matrix`` (4, 4) (sums in float64, stored as float32),
    re-projected to a tile in float32 and kept as ``tile_survivors`` keeps them (``seen`` (T,)
    False, or empty for all seen: left out); returns the count kept."""
    n = 0
    every = seen.shape[0] == 0
    for t in range(positions.shape[0]):
        if not every and not seen[t]:
            continue
        corner = out[n]
        for c in range(3):
            px = np.float32(_affine(matrix, 0, positions, t, c))
            py = np.float32(_affine(matrix, 1, positions, t, c))
            pz = np.float32(_affine(matrix, 2, positions, t, c))
            w = np.float32(_affine(matrix, 3, positions, t, c))
            corner[c, 0] = px * ax + w * bx
            corner[c, 1] = py * ay + w * by
            corner[c, 2] = pz
            corner[c, 3] = w
        if _rejection(corner) == KEPT:
            orig[n] = t
            n += 1
    return n


_F2 = nb.float32[:, ::1]
_PLANE = nb.float32[:, :]  # any layout: a map, or one channel of a pyramid level


@nb.njit(nb.void(_PLANE, _PLANE, _PLANE, nb.float32[:, :, ::1]), **_OPTIONS)
def reduction(dist, lo_depth, hi_depth, out):
    """One level of a shadow map's reduction pyramid: per 2 x 2 block of the (S, S) planes (an
    odd side's last block is cut by the edge), the least ``dist``, the least ``lo_depth`` and
    the greatest ``hi_depth``: ``out`` (ceil(S / 2), ceil(S / 2), 3). The first level reduces
    a map (dist, depth, depth), each next one the channels of the level before."""
    s = dist.shape[0]
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            lo_d, lo, hi = np.float32(np.inf), np.float32(np.inf), np.float32(-np.inf)
            for r in range(2 * i, min(2 * i + 2, s)):
                for c in range(2 * j, min(2 * j + 2, s)):
                    lo_d = min(lo_d, dist[r, c])
                    lo = min(lo, lo_depth[r, c])
                    hi = max(hi, hi_depth[r, c])
            out[i, j, 0], out[i, j, 1], out[i, j, 2] = lo_d, lo, hi


@nb.njit(**_OPTIONS)
def _row_span(e, sign, y):
    """The window x range (lo, hi) where all three edge functions ``e`` (3, 3), turned by
    ``sign`` to be >= 0 inside, hold on window row y."""
    lo, hi = -np.inf, np.inf
    for i in range(3):  # inside edge i: kx x + m >= 0
        kx = sign * e[i, 0]
        m = sign * (e[i, 1] * y + e[i, 2])
        if kx > 0.0:
            lo = max(lo, -m / kx)
        elif kx < 0.0:
            hi = min(hi, -m / kx)
        elif m < 0.0:
            hi = -np.inf
    return lo, hi


@nb.njit(**_OPTIONS)
def _covered(lo, hi, offset, size):
    """The pixels [start, stop) of a row or column of ``size`` whose sample at ``offset`` (0.5:
    the centre) lies in [lo, hi], reaching ``_REACH`` further; (0, 0) if none (or a NaN)."""
    first = max(np.ceil(lo - offset - _REACH), 0.0)
    last = min(np.floor(hi - offset + _REACH), size - 1.0)
    if not first <= last:
        return np.int64(0), np.int64(0)
    return np.int64(first), np.int64(last) + 1


@nb.njit(**_OPTIONS)
def _span_min(xs, ys, zs, e, out):
    """Draw one triangle of map corners (xs, ys) and values zs (3,) into ``out``: at each
    covered texel centre the value interpolated over the map, kept where it is less than the
    texel's. ``e`` (3, 3): scratch for its edge functions (``_row_span``)."""
    height, width = out.shape
    area = (xs[1] - xs[0]) * (ys[2] - ys[0]) - (xs[2] - xs[0]) * (ys[1] - ys[0])
    if not (area != 0.0 and np.isfinite(area) and np.isfinite(zs[0] + zs[1] + zs[2])):
        return
    r_start, r_stop = _covered(min(ys[0], ys[1], ys[2]), max(ys[0], ys[1], ys[2]), 0.5, height)
    if r_start == r_stop:
        return
    for i in range(3):  # edge i: through corners j and k (their homogeneous (x, y, 1))
        j, k = (i + 1) % 3, (i + 2) % 3
        e[i, 0] = ys[j] - ys[k]
        e[i, 1] = xs[k] - xs[j]
        e[i, 2] = xs[j] * ys[k] - ys[j] * xs[k]
    # the plane z = a x + b y + c0 over the map
    a = ((zs[1] - zs[0]) * (ys[2] - ys[0]) - (zs[2] - zs[0]) * (ys[1] - ys[0])) / area
    b = ((xs[1] - xs[0]) * (zs[2] - zs[0]) - (xs[2] - xs[0]) * (zs[1] - zs[0])) / area
    c0 = zs[0] - a * xs[0] - b * ys[0]
    sign = 1.0 if area > 0.0 else -1.0
    for r in range(r_start, r_stop):
        lo, hi = _row_span(e, sign, r + 0.5)
        c_start, c_stop = _covered(lo, hi, 0.5, width)
        zrow = b * (r + 0.5) + c0
        for col in range(c_start, c_stop):
            z = np.float32(a * (col + 0.5) + zrow)
            if z < out[r, col]:
                out[r, col] = z


@nb.njit([nb.void(nb.float32[:, :, ::1], nb.float64[:, ::1], _F2),
          nb.void(nb.float64[:, :, ::1], nb.float64[:, ::1], _F2)], **_OPTIONS)
def ortho_depths(points, rows, out):
    """An orthographic depth map: into ``out`` (H, W) (filled by the caller, +inf: empty) the
    least depth of the triangles ``points`` (T, 3, 3) at each texel centre. ``rows`` (3, 4)
    give a point's column and row in texels (texel (c, r) centred at (c + 0.5, r + 0.5)) and
    its depth, as affine functions; all in float64, the depth rounded to float32 at the end.
    Each row's covered span comes from the three edges; every edge is inclusive and reaches
    ``_REACH`` texels further (a depth map needs no tie rule, and must have no cracks).
    Triangles of no area in the map, or with a non-finite corner, draw nothing."""
    xs, ys, zs = np.empty(3), np.empty(3), np.empty(3)
    e = np.empty((3, 3))
    for t in range(points.shape[0]):
        for c in range(3):
            xs[c] = _affine(rows, 0, points, t, c)
            ys[c] = _affine(rows, 1, points, t, c)
            zs[c] = _affine(rows, 2, points, t, c)
        _span_min(xs, ys, zs, e, out)


@nb.njit(**_OPTIONS)
def _near_polygon(corners, dist, poly):
    """The part of one triangle in front of a plane (Sutherland and Hodgman 1974): its
    ``corners`` (3, K) float64 and their signed distances ``dist`` (3,) to the plane (>= 0 in
    front) -> ``poly`` (4, K), every component interpolated; returns its corner count (0
    when a corner is not finite or all lie behind the plane)."""
    count = 0
    if not (np.isfinite(corners.sum()) and dist.max() >= 0.0):
        return count
    for c in range(3):
        d = (c + 1) % 3
        if dist[c] >= 0.0:
            for k in range(corners.shape[1]):  # (a loop: a row assignment compiles numba's
                poly[count, k] = corners[c, k]  # shape-error formatting, seconds)
            count += 1
        if (dist[c] >= 0.0) != (dist[d] >= 0.0):
            f = dist[c] / (dist[c] - dist[d])
            for k in range(corners.shape[1]):
                poly[count, k] = corners[c, k] + f * (corners[d, k] - corners[c, k])
            count += 1
    return count


@nb.njit(**_OPTIONS)
def _window_edges(poly, fan, w_at, width, height, v, e):
    """Corners 0, fan + 1, fan + 2 of a clipped polygon of clip coordinates (x, y at 0, 1; w
    at ``w_at``) as window-space homogeneous corners ``v`` (3, 3) (x w, y w, w; y down) and
    their edge functions ``e`` (3, 3), edge i the plane through the eye and corners j, k
    (Olano and Greer 1997); returns the determinant and the corners' least and greatest
    window y."""
    lo_r, hi_r = np.inf, -np.inf
    for c in range(3):
        q = 0 if c == 0 else fan + c
        w = poly[q, w_at]
        if not w > 0.0:
            w = 1e-300  # on the near plane at the eye: a point at infinity
        v[c, 0] = (poly[q, 0] + w) * (0.5 * width)
        v[c, 1] = (w - poly[q, 1]) * (0.5 * height)
        v[c, 2] = w
        lo_r = min(lo_r, v[c, 1] / w)
        hi_r = max(hi_r, v[c, 1] / w)
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        e[i, 0] = v[j, 1] * v[k, 2] - v[j, 2] * v[k, 1]
        e[i, 1] = v[j, 2] * v[k, 0] - v[j, 0] * v[k, 2]
        e[i, 2] = v[j, 0] * v[k, 1] - v[j, 1] * v[k, 0]
    return v[0, 0] * e[0, 0] + v[0, 1] * e[0, 1] + v[0, 2] * e[0, 2], lo_r, hi_r


@nb.njit(**_OPTIONS)
def _inverse_w(e, det):
    """The sign that turns the edge functions ``e`` (3, 3) of ``_window_edges`` to be >= 0
    inside, and the plane 1 / w = a x + b y + c0 over the window: (sign, a, b, c0)."""
    sign = 1.0 if det > 0.0 else -1.0
    a = (e[0, 0] + e[1, 0] + e[2, 0]) / det
    b = (e[0, 1] + e[1, 1] + e[2, 1]) / det
    c0 = (e[0, 2] + e[1, 2] + e[2, 2]) / det
    return sign, a, b, c0


@nb.njit([nb.void(nb.float32[:, :, ::1], nb.float64[:, ::1], nb.float64, _F2),
          nb.void(nb.float64[:, :, ::1], nb.float64[:, ::1], nb.float64, _F2)], **_OPTIONS)
def perspective_depths(points, rows, near, out):
    """A perspective depth map: into ``out`` (H, W) (filled by the caller, +inf: empty) the
    least clip w (depth along the view axis) of the triangles ``points`` (T, 3, 3) at each
    texel centre; ``rows`` (3, 4) are the projection's clip x, y and w rows, texel (c, r)
    centred at ndc ((c + 0.5) / W * 2 - 1, 1 - (r + 0.5) / H * 2). Triangles are clipped to
    w >= ``near`` (Sutherland and Hodgman 1974) and drawn with homogeneous edge functions
    (Olano and Greer 1997, "Triangle scan conversion using 2D homogeneous coordinates": no
    division by a corner's w, which may be tiny), whose sum interpolates 1 / w; every edge
    inclusive, as ``ortho_depths``."""
    height, width = out.shape
    clip = np.empty((3, 3))
    dist = np.empty(3)
    poly = np.empty((4, 3))
    v = np.empty((3, 3))
    e = np.empty((3, 3))
    for t in range(points.shape[0]):
        for c in range(3):
            for k in range(3):
                clip[c, k] = _affine(rows, k, points, t, c)
            dist[c] = clip[c, 2] - near
        count = _near_polygon(clip, dist, poly)
        for fan in range(count - 2):
            det, lo_r, hi_r = _window_edges(poly, fan, 2, width, height, v, e)
            if not (det != 0.0 and np.isfinite(det)):
                continue
            sign, a, b, c0 = _inverse_w(e, det)
            r_start, r_stop = _covered(lo_r, hi_r, 0.5, height)
            for r in range(r_start, r_stop):
                lo, hi = _row_span(e, sign, r + 0.5)
                c_start, c_stop = _covered(lo, hi, 0.5, width)
                zrow = b * (r + 0.5) + c0
                for col in range(c_start, c_stop):
                    inv_w = a * (col + 0.5) + zrow
                    if not inv_w > 0.0:  # (extrapolated past a sliver's edge)
                        continue
                    depth = np.float32(1.0 / inv_w)
                    if depth < out[r, col]:
                        out[r, col] = depth


_NEAREST = nb.void(
    nb.float32[:, :, ::1], nb.boolean[::1], nb.boolean,  # clip (T, 3, 4), cull (T,), culling
    nb.float64[:, ::1], nb.float64,  # sample offsets (S, 2), far w
    nb.int32[:, :, ::1], nb.float32[:, :, :, ::1], nb.float32[:, :, ::1],  # tri, bary, depth
)


@nb.njit(_NEAREST, **_OPTIONS)
def nearest(clip, cull, culling, offsets, far, tri_out, bary_out, depth_out):
    """The nearest triangle of every pixel's samples through a perspective projection, drawn
    straight from the clip-space corners ``clip`` (T, 3, 4) (OpenGL: near plane z = -w), as
    ``raster.rasterize``'s set-up and scan do for any projection: per sample s into
    ``tri_out`` (S, H, W) (-1: none), perspective-correct corner weights ``bary_out``
    (S, H, W, 3) and clip w ``depth_out`` (S, H, W) (+inf: none); sample s of pixel (r, c)
    lies at window (c + ox, r + oy), (ox, oy) = ``offsets[s]``. Each triangle is clipped to
    the near plane (Sutherland and Hodgman 1974) once for all samples and walked row by row
    with homogeneous edge functions (Olano and Greer 1997), inclusive and reaching ``_REACH``
    pixels further (no cracks along shared edges); the least w wins, ties go to the lower
    triangle; fragments beyond ``far`` (w) are dropped; with ``culling``, triangles whose back
    faces the camera (clockwise with y up) and ``cull`` are skipped. Triangles with a
    non-finite corner, or of no area, draw nothing."""
    samples, height, width = tri_out.shape
    corners = np.empty((3, 4))
    dist = np.empty(3)
    poly = np.empty((4, 4))
    v = np.empty((3, 3))
    e = np.empty((3, 3))
    best = np.full((samples, height, width), np.inf)
    tri_out[:, :, :] = -1
    for t in range(clip.shape[0]):
        for c in range(3):
            for k in range(4):
                corners[c, k] = clip[t, c, k]
            dist[c] = corners[c, 2] + corners[c, 3]  # the near plane: z + w >= 0
        count = _near_polygon(corners, dist, poly)
        for fan in range(count - 2):
            det, lo_r, hi_r = _window_edges(poly, fan, 3, width, height, v, e)
            if not (det != 0.0 and np.isfinite(det)):
                continue
            if culling and cull[t] and det > 0.0:  # clockwise with y up: its back
                continue
            sign, a, b, c0 = _inverse_w(e, det)
            for smp in range(samples):
                ox, oy = offsets[smp, 0], offsets[smp, 1]
                r_start, r_stop = _covered(lo_r, hi_r, oy, height)
                for r in range(r_start, r_stop):
                    y = r + oy
                    lo, hi = _row_span(e, sign, y)
                    c_start, c_stop = _covered(lo, hi, ox, width)
                    zrow = b * y + c0
                    for col in range(c_start, c_stop):
                        inv_w = a * (col + ox) + zrow
                        if not inv_w > 0.0:
                            continue
                        depth = 1.0 / inv_w
                        if depth <= far and depth < best[smp, r, col]:
                            best[smp, r, col] = depth
                            tri_out[smp, r, col] = t
    for smp in range(samples):  # the original triangle's weights at the winners' samples
        ox, oy = offsets[smp, 0], offsets[smp, 1]
        for r in range(height):
            for col in range(width):
                t = tri_out[smp, r, col]
                depth_out[smp, r, col] = best[smp, r, col]
                if t < 0:
                    for i in range(3):
                        bary_out[smp, r, col, i] = 0.0
                    continue
                for c in range(3):
                    w = np.float64(clip[t, c, 3])
                    v[c, 0] = (np.float64(clip[t, c, 0]) + w) * (0.5 * width) - (col + ox) * w
                    v[c, 1] = (w - np.float64(clip[t, c, 1])) * (0.5 * height) - (r + oy) * w
                    v[c, 2] = w
                total = 0.0
                for i in range(3):  # E_i at the sample (the origin now): (V_j x V_k)_z
                    j, k = (i + 1) % 3, (i + 2) % 3
                    e[i, 2] = v[j, 0] * v[k, 1] - v[j, 1] * v[k, 0]
                    total += e[i, 2]
                for i in range(3):
                    bary_out[smp, r, col, i] = e[i, 2] / total if total != 0.0 else 1.0 / 3.0


@nb.njit(nb.void(nb.int32[:, ::1], nb.float32[:, :, ::1], nb.float64[:, ::1], _F2), **_OPTIONS)
def corner_sum(tri, bary, values, out):
    """Per pixel of ``tri`` (H, W) (-1: none, +inf in ``out``), its triangle's corner
    ``values`` (T, 3) float64 weighted by ``bary`` (H, W, 3), summed in float64 in corner
    order and rounded to float32 into ``out`` (H, W) (e.g. a sun map's depth)."""
    for i in range(tri.shape[0]):
        for j in range(tri.shape[1]):
            t = tri[i, j]
            if t < 0:
                out[i, j] = np.float32(np.inf)
            else:
                out[i, j] = ((np.float64(bary[i, j, 0]) * values[t, 0]
                              + np.float64(bary[i, j, 1]) * values[t, 1])
                             + np.float64(bary[i, j, 2]) * values[t, 2])




@nb.njit([nb.void(nb.float32[:, :, ::1], nb.float64[:, ::1], nb.float64[:, ::1]),
          nb.void(nb.float64[:, :, ::1], nb.float64[:, ::1], nb.float64[:, ::1])], **_OPTIONS)
def extent(points, rows, out):
    """The least and greatest value ``out`` (R, 2) of each affine function ``rows`` (R, 4)
    (r . (x, y, z, 1), in float64) over the finite corners of triangles ``points`` (T, 3, 3)
    ((inf, -inf) when there are none): the extent of a scene along R directions, in one pass."""
    for r in range(rows.shape[0]):
        out[r, 0], out[r, 1] = np.inf, -np.inf
    for t in range(points.shape[0]):
        for c in range(3):
            x, y, z = np.float64(points[t, c, 0]), np.float64(points[t, c, 1]), \
                np.float64(points[t, c, 2])
            if not (np.isfinite(x) and np.isfinite(y) and np.isfinite(z)):
                continue
            for r in range(rows.shape[0]):
                v = rows[r, 0] * x + rows[r, 1] * y + rows[r, 2] * z + rows[r, 3]
                out[r, 0] = min(out[r, 0], v)
                out[r, 1] = max(out[r, 1], v)


@nb.njit([nb.types.UniTuple(nb.float64, 2)(nb.float32[:, :, ::1], nb.float64[::1]),
          nb.types.UniTuple(nb.float64, 2)(nb.float64[:, :, ::1], nb.float64[::1])],
         **_OPTIONS)
def distances(points, origin):
    """(least distance from ``origin`` (3,) to the planes of triangles ``points`` (T, 3, 3),
    greatest distance to a corner), metres, over finite values; (inf, 0) for none."""
    near, far = np.inf, 0.0
    for t in range(points.shape[0]):
        ax, ay, az = (np.float64(points[t, 0, 0]), np.float64(points[t, 0, 1]),
                      np.float64(points[t, 0, 2]))
        ux, uy, uz = (np.float64(points[t, 1, 0]) - ax, np.float64(points[t, 1, 1]) - ay,
                      np.float64(points[t, 1, 2]) - az)
        vx, vy, vz = (np.float64(points[t, 2, 0]) - ax, np.float64(points[t, 2, 1]) - ay,
                      np.float64(points[t, 2, 2]) - az)
        nx, ny, nz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
        length = np.sqrt(nx * nx + ny * ny + nz * nz)
        d = abs(nx * (origin[0] - ax) + ny * (origin[1] - ay) + nz * (origin[2] - az)) / length
        if np.isfinite(d):
            near = min(near, d)
        for c in range(3):
            dx = np.float64(points[t, c, 0]) - origin[0]
            dy = np.float64(points[t, c, 1]) - origin[1]
            dz = np.float64(points[t, c, 2]) - origin[2]
            e = np.sqrt(dx * dx + dy * dy + dz * dz)
            if np.isfinite(e):
                far = max(far, e)
    return near, far


@nb.njit(**_OPTIONS)
def _plane_distance(v, plane, near):
    """Signed distance-like value of vertex v (x, y, w, depth) to one plane of the box
    |x| <= w, |y| <= w, depth >= near: 0 w + x, 1 w - x, 2 w + y, 3 w - y, 4 depth - near;
    inside where >= 0."""
    if plane == 0:
        return v[2] + v[0]
    if plane == 1:
        return v[2] - v[0]
    if plane == 2:
        return v[2] + v[1]
    if plane == 3:
        return v[2] - v[1]
    return v[3] - near


@nb.njit(**_OPTIONS)
def _clip_polygon(src, count, dst, plane, near):
    """Sutherland-Hodgman: the polygon ``src[:count]`` (rows x, y, w, depth) cut by one plane
    (``_plane_distance``) into ``dst``; returns the new count."""
    out = 0
    for i in range(count):
        j = i + 1 if i + 1 < count else 0
        da = _plane_distance(src[i], plane, near)
        db = _plane_distance(src[j], plane, near)
        if da >= 0.0:
            for k in range(4):
                dst[out, k] = src[i, k]
            out += 1
        if (da >= 0.0) != (db >= 0.0):
            t = da / (da - db)
            for k in range(4):
                dst[out, k] = src[i, k] + t * (src[j, k] - src[i, k])
            out += 1
    return out


@nb.njit([nb.types.UniTuple(nb.float64, 2)(nb.float64[:, :, ::1], nb.float64[:, ::1],
                                           nb.float64),
          nb.types.UniTuple(nb.float64, 2)(nb.float32[:, :, ::1], nb.float64[:, ::1],
                                           nb.float64)], **_OPTIONS)
def clipped_depths(points, rows, near):
    """The smallest and largest depth of the parts of triangles ``points`` (T, 3, 3, float32
    or float64)
    inside the region |x| <= w, |y| <= w, depth >= ``near``, where x, y, w and depth are the
    affine functions of a point given by ``rows`` (4, 4) (a camera's clip-space x, y, w and
    view depth: its frustum without the far plane; a sun cascade's square: x and y from its
    centre, w its half side, depth along the light, ``near`` -inf). Each triangle is clipped
    by the five planes (Sutherland and Hodgman 1974). (inf, -inf) when nothing is inside."""
    lo, hi = np.inf, -np.inf
    # a triangle cut by five planes has at most 8 corners; each cut at most doubles a polygon
    # whatever the rounding, so 3 * 2^5 rows always hold it
    a = np.empty((96, 4))
    b = np.empty((96, 4))
    for t in range(points.shape[0]):
        inside = True
        for c in range(3):
            x, y, z = points[t, c, 0], points[t, c, 1], points[t, c, 2]
            for r in range(4):
                a[c, r] = rows[r, 0] * x + rows[r, 1] * y + rows[r, 2] * z + rows[r, 3]
            for plane in range(5):
                inside = inside and _plane_distance(a[c], plane, near) >= 0.0
        if inside:  # most triangles: no clipping
            for c in range(3):
                lo = min(lo, a[c, 3])
                hi = max(hi, a[c, 3])
            continue
        count = np.int64(3)
        for plane in range(5):  # a -> b, b -> a, ..., the last into b
            if plane % 2 == 0:
                count = _clip_polygon(a, count, b, plane, near)
            else:
                count = _clip_polygon(b, count, a, plane, near)
            if count == 0:
                break
        for i in range(count):
            d = b[i, 3]
            if d == d:
                lo = min(lo, d)
                hi = max(hi, d)
    return lo, hi


mark_cached(__name__)  # every kernel above is compiled or loaded
