"""Vectorized triangle rasterizer: clip-space triangles -> per-pixel triangle, weights, depth.

The output is the visibility part of a G-buffer: for every pixel, the index of the nearest
triangle, the perspective-correct barycentric weights of its three corners and the view depth.
Materials and shading read attributes through ``interpolate`` (deferred shading).

Method, vectorized over triangles and pixels (Python loops run over clip planes, box-size bins
and chunks only):

1. Trivial rejection of triangles outside one plane of the clip-space frustum, then clipping in
   homogeneous coordinates (Sutherland & Hodgman 1974; Blinn & Newell 1978, "Clipping using
   homogeneous coordinates") against the near plane z = -w and against a guard band far outside
   the screen (which keeps window coordinates small enough for exact integer edge functions).
   A clipped triangle becomes one or two triangles whose corners carry their barycentric
   coordinates in the original triangle, so the original corners' attributes interpolate exactly.
   A crossing point is always computed from the inside corner towards the outside one, so two
   triangles sharing an edge get bit-identical new corners.
2. Edge functions (Pineda 1988, "A parallel algorithm for polygon rasterization") on window
   coordinates snapped to a fixed-point grid of 2^-12 pixel (as GPUs do), evaluated exactly in
   int64, with the top-left fill rule of Direct3D/OpenGL: a sample exactly on an edge belongs to
   the triangle whose inward edge normal (A, B) has A > 0, or A == 0 and B > 0 (window y down).
   That equals moving the sample by (eps, eps^2); with exact arithmetic, triangles sharing an
   edge, and fans around a vertex, cover every sample exactly once.
3. Binning: each triangle's pixel bounding box is cut into screen tiles; (triangle, tile) pairs
   whose tile lies outside an edge are dropped, pairs whose tile lies inside all three edges skip
   the per-sample edge test (hierarchical rasterization, Greene 1996; McCormack & McNamara 2000).
   Candidate (triangle, pixel) pairs are expanded with ``np.repeat`` in chunks of bounded size.
4. Depth test with one packed 64-bit key per fragment: quantized z_ndc in the high bits (NDC z is
   affine in window space), the clipped triangle's index in the low bits, resolved per pixel with
   ``np.minimum.at``; ties go to the lower triangle index whatever the tiling or chunking.
5. Perspective-correct barycentrics of the visible fragments only: screen-space weights divided
   by w and renormalized (Heckbert & Moreton 1991, "Interpolation for polygon texture mapping and
   shading"; Olano & Greer 1997, "Triangle scan conversion using 2D homogeneous coordinates").

Conventions: clip space as in OpenGL (x/w, y/w, z/w in [-1, 1]; y up; z = -w is the near plane;
w > 0 in front of the camera). Pixel (r, c) has row 0 at the top; its sample lies at window
coordinates (c + ox, r + oy) from the top-left corner of the image, i.e. at
x_ndc = 2 (c + ox) / width - 1, y_ndc = 1 - 2 (r + oy) / height. Counter-clockwise corners (seen
with y up) face the camera, as in OpenGL and Blender.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Fragments", "coverage", "interpolate", "rasterize"]

_EMPTY = np.uint64(0xFFFF_FFFF_FFFF_FFFF)
_MAX_CANDIDATES = 1 << 21  # (triangle, pixel) candidates expanded at once: ~0.1 GB of temporaries
# Fixed point: window coordinates in units of 2^-S pixel, |x| <= 2^G pixels (guard band), with
# G + S = 29 so that the edge functions A x + B y + C and the doubled areas fit in int64.
_FIXED_BITS = 29


@dataclass
class Fragments:
    """The nearest fragment of every pixel.

    tri:   (H, W) int32 index of the original triangle, -1 where nothing covers the pixel
    bary:  (H, W, 3) float32 perspective-correct weights of that triangle's corners, 0 where empty
    depth: (H, W) float32 clip-space w of the fragment (view-space distance along the camera
           axis, scene units; 1 for an orthographic projection), +inf where empty
    skipped_degenerate: triangles skipped because they have zero area in window space (after
                        snapping to the 2^-12 pixel grid) or no point with w > 0 in the frustum
    skipped_nan:        triangles skipped because a coordinate is NaN or infinite
    """

    tri: np.ndarray
    bary: np.ndarray
    depth: np.ndarray
    skipped_degenerate: int = 0
    skipped_nan: int = 0

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the image."""
        return self.tri.shape


def coverage(frags: Fragments) -> np.ndarray:
    """(H, W) bool: True where a triangle covers the pixel's sample."""
    return frags.tri >= 0


def _empty_fragments(height: int, width: int, degenerate: int = 0, nan: int = 0) -> Fragments:
    return Fragments(
        tri=np.full((height, width), -1, np.int32),
        bary=np.zeros((height, width, 3), np.float32),
        depth=np.full((height, width), np.inf, np.float32),
        skipped_degenerate=degenerate,
        skipped_nan=nan,
    )


def _rotate(a: np.ndarray, first: np.ndarray) -> np.ndarray:
    """Rotate the corners of (N, 3, K) ``a`` cyclically so that corner ``first`` (N,) is first."""
    idx = (first[:, None] + np.arange(3)) % 3
    return np.take_along_axis(a, idx[:, :, None], axis=1)


def _lerp(inside: np.ndarray, outside: np.ndarray, d_in: np.ndarray, d_out: np.ndarray):
    """Point where the segment inside -> outside (N, K) crosses d = 0 (d_in >= 0 > d_out)."""
    t = d_in / (d_in - d_out)
    return inside + t[:, None] * (outside - inside)


def _clip(verts: np.ndarray, orig: np.ndarray, planes) -> tuple[np.ndarray, np.ndarray]:
    """Clip triangles against half-spaces s * v[axis] + k * w >= 0 of homogeneous clip space.

    verts:   (N, 3, 7) float64 corners: clip x, y, z, w, then barycentrics in the original triangle
    orig:    (N,) int64 original triangle index
    planes:  sequence of (axis, s, k)
    returns: (M, 3, 7) corners and (M,) original indices, sorted by original index
    """
    clipped = False
    for axis, s, k in planes:
        d = s * verts[:, :, axis] + k * verts[:, :, 3]
        inside = d >= 0.0
        n_in = inside.sum(axis=1)
        if np.all(n_in == 3):
            continue
        clipped = True
        parts_v = [verts[n_in == 3]]
        parts_o = [orig[n_in == 3]]
        one = n_in == 1  # (a, b, c), a inside: keep (a, a->b, a->c), same winding
        if one.any():
            v = _rotate(verts[one], np.argmax(inside[one], axis=1))
            dd = _rotate(d[one][:, :, None], np.argmax(inside[one], axis=1))[:, :, 0]
            a, b, c = v[:, 0], v[:, 1], v[:, 2]
            ab = _lerp(a, b, dd[:, 0], dd[:, 1])
            ac = _lerp(a, c, dd[:, 0], dd[:, 2])
            parts_v.append(np.stack([a, ab, ac], axis=1))
            parts_o.append(orig[one])
        two = n_in == 2  # (o, a, b), o outside: quad (a, b, b->o, a->o) as two triangles
        if two.any():
            v = _rotate(verts[two], np.argmin(inside[two], axis=1))
            dd = _rotate(d[two][:, :, None], np.argmin(inside[two], axis=1))[:, :, 0]
            o, a, b = v[:, 0], v[:, 1], v[:, 2]
            bo = _lerp(b, o, dd[:, 2], dd[:, 0])
            ao = _lerp(a, o, dd[:, 1], dd[:, 0])
            parts_v += [np.stack([a, b, bo], axis=1), np.stack([a, bo, ao], axis=1)]
            parts_o += [orig[two], orig[two]]
        verts = np.concatenate(parts_v)
        orig = np.concatenate(parts_o)
    if clipped:
        order = np.argsort(orig, kind="stable")
        verts, orig = verts[order], orig[order]
    return verts, orig


@dataclass
class _Setup:
    """Per clipped triangle set-up (N,); edge i is the one opposite corner i.

    Edge functions in fixed-point units, exact in int64, with the fill rule folded into the
    constant: a sample is inside iff E_i = ea_i x + eb_i y + ec_i > 0 for i = 0, 1, 2 (a top-left
    edge has 1 added to ec_i, so that E_i == 0 counts as inside there).
    """

    ea: np.ndarray  # (3, N) int64
    eb: np.ndarray
    ec: np.ndarray
    za: np.ndarray  # (N,) float64 key depth u = za x + zb y + zc, x and y in pixels, with
    zb: np.ndarray  # u = (z_ndc + 1) / 2 * qmax (affine in window space)
    zc: np.ndarray


def _bin_size(n: np.ndarray) -> np.ndarray:
    """Round box sides (P,) >= 1 up to 1..8, 12, 16, 24, 32, 48, ... (few bins, < 34% padding)."""
    p2 = np.left_shift(1, np.ceil(np.log2(np.maximum(n, 1))).astype(np.int64))
    return np.where(n <= 8, n, np.where(n <= 3 * p2 // 4, 3 * p2 // 4, p2))


def _scan(keybuf, s, pairs, test_edges, width, offset, unit, ibits, qmax, max_candidates):
    """Test the samples of (triangle, tile) pairs and depth-resolve them into ``keybuf``.

    Pairs are grouped by their box size rounded up (``_bin_size``); one group is expanded by
    broadcasting to (P, bh, bw) and masked to the real boxes.

    keybuf: (H * W,) uint64 packed (quantized depth, clipped triangle index); the minimum wins
    pairs:  (sid, col0, row0, box width, box height), each (P,) int64: the pair's pixel box
    offset: (ox, oy, oxi, oyi) sample offset in pixels and in fixed-point units; unit = 2^S
    """
    sid_p, c0_p, r0_p, bw_p, bh_p = pairs
    if sid_p.size == 0:
        return
    ox, oy, oxi, oyi = offset
    shift = np.uint64(ibits)
    pw, ph = _bin_size(bw_p), _bin_size(bh_p)
    group = ph * (int(pw.max()) + 1) + pw
    order = np.argsort(group, kind="stable")
    for grp in np.split(order, np.flatnonzero(np.diff(group[order])) + 1):
        bw, bh = int(pw[grp[0]]), int(ph[grp[0]])
        step = max(1, max_candidates // (bw * bh))
        dx, dy = np.arange(bw), np.arange(bh)[:, None]
        for lo in range(0, grp.size, step):
            g = grp[lo : lo + step]
            sid = sid_p[g][:, None, None]
            col = c0_p[g][:, None, None] + dx  # (P, 1, bw)
            row = r0_p[g][:, None, None] + dy  # (P, bh, 1)
            mask = None
            if bw > bw_p[g].min() or bh > bh_p[g].min():
                mask = (dx < bw_p[g][:, None, None]) & (dy < bh_p[g][:, None, None])
            if test_edges:
                xs, ys = col * unit + oxi, row * unit + oyi
                for i in range(3):
                    e = s.ea[i][sid] * xs + (s.eb[i][sid] * ys + s.ec[i][sid])
                    mask = e > 0 if mask is None else mask & (e > 0)
                del e
            u = s.za[sid] * (col + ox) + s.zb[sid] * (row + oy)
            u += s.zc[sid]
            front = u <= qmax  # far plane z_ndc <= 1 (also drops NaN)
            mask = front if mask is None else mask & front
            np.maximum(u, 0.0, out=u)  # z_ndc >= -1 up to rounding
            with np.errstate(invalid="ignore"):  # values past the far plane are masked out
                key = u.astype(np.uint64)
            key <<= shift
            key |= sid.astype(np.uint64)
            pix = row * width + col
            del u, front
            if mask.all():
                np.minimum.at(keybuf, pix.reshape(-1), key.reshape(-1))
            else:
                np.minimum.at(keybuf, pix[mask], key[mask])


@dataclass
class _Interp:
    """Per clipped triangle (N,) float64 interpolation set-up, x and y in pixels.

    q_i = qa_i x + qb_i y + qc_i is the screen-space barycentric of corner i divided by its clip
    w (affine in window space: Olano & Greer 1997); the perspective-correct weight of corner i
    is q_i / sum(q) and the fragment's clip w is 1 / sum(q).
    """

    qa: np.ndarray  # (3, N)
    qb: np.ndarray
    qc: np.ndarray
    orig: np.ndarray  # (N,) int32 original triangle
    sub_bary: np.ndarray  # (N, 3, 3) corners' weights in the original triangle
    clipped: np.ndarray  # (N,) bool: sub_bary is not the identity


def _resolve(ip: _Interp, sid, xs, ys, tri_out, bary_out, depth_out, where) -> None:
    """Write original triangle, perspective-correct weights and clip w of samples (n,).

    sid: (n,) clipped triangle; xs, ys: (n,) float64 sample positions, pixels;
    tri_out (M,), bary_out (M, 3), depth_out (M,): flat outputs written at ``where``.
    """
    q = []
    for i in range(3):
        qi = ip.qa[i][sid] * xs
        qi += ip.qb[i][sid] * ys
        qi += ip.qc[i][sid]
        np.maximum(qi, 0.0, out=qi)  # inside the snapped triangle, just outside in float64
        q.append(qi)
    inv_q = q[0] + q[1]
    inv_q += q[2]
    np.divide(1.0, inv_q, out=inv_q)
    depth_out[where] = inv_q
    tri_out[where] = ip.orig[sid]
    cl = np.flatnonzero(ip.clipped[sid])
    if cl.size == 0:
        for i in range(3):
            q[i] *= inv_q
            bary_out[where, i] = q[i]
        return
    bary = np.stack(q, axis=1)
    bary *= inv_q[:, None]
    bary[cl] = np.einsum("nk,nkj->nj", bary[cl], ip.sub_bary[sid[cl]])
    bary_out[where] = bary


def rasterize(
    clip,
    width: int,
    height: int,
    *,
    cull=None,
    sample_offset=(0.5, 0.5),
    tile: int = 64,
    max_candidates: int = _MAX_CANDIDATES,
) -> Fragments:
    """Rasterize triangles into the nearest fragment per pixel (one sample per pixel).

    clip:          (T, 3, 4) float clip-space corner positions (OpenGL convention, see module doc)
    width, height: image size in pixels
    cull:          None, or (T,) bool: True where the triangle's back face (clockwise corners in
                   window space with y up) is culled
    sample_offset: (ox, oy) sample position inside the pixel, in pixels from its top-left corner;
                   call several times with different offsets for supersampling
    tile:          side of the square screen tiles used for binning, pixels
    max_candidates: upper bound on the (triangle, pixel) candidates expanded at once
    returns:       Fragments; triangles with NaN/inf corners or zero window-space area are skipped
                   and counted, triangles outside the frustum are dropped silently, and
                   fragments beyond the far plane (z/w > 1) are dropped
    """
    width, height = int(width), int(height)
    tile = max(1, int(tile))
    max_candidates = max(1, int(max_candidates))
    clip = np.asarray(clip)
    if clip.ndim != 3 or clip.shape[1:] != (3, 4):
        raise ValueError(f"clip must have shape (T, 3, 4), got {clip.shape}")
    n_tri = clip.shape[0]
    if cull is not None:
        cull = np.asarray(cull, dtype=bool)
        if cull.shape != (n_tri,):
            raise ValueError(f"cull must have shape ({n_tri},), got {cull.shape}")
    if width <= 0 or height <= 0 or n_tri == 0:
        return _empty_fragments(max(height, 0), max(width, 0))
    guard_bits = max(17, max(width, height).bit_length() + 1)
    sub_bits = _FIXED_BITS - guard_bits
    unit = 1 << sub_bits
    ox, oy = (float(o) for o in sample_offset)
    oxi, oyi = round(ox * unit), round(oy * unit)

    # 1. Reject non-finite and out-of-frustum triangles; clip against near plane and guard band.
    v = clip.astype(np.float64)
    finite = np.isfinite(v).all(axis=(1, 2))
    n_nan = int(n_tri - np.count_nonzero(finite))
    x, y, z, w = v[..., 0], v[..., 1], v[..., 2], v[..., 3]
    with np.errstate(invalid="ignore"):
        outside = (
            (x > w).all(1)
            | (x < -w).all(1)
            | (y > w).all(1)
            | (y < -w).all(1)
            | (z > w).all(1)
            | (z < -w).all(1)
        )
    orig = np.flatnonzero(finite & ~outside)
    if orig.size == 0:
        return _empty_fragments(height, width, 0, n_nan)
    verts = np.concatenate([v[orig], np.broadcast_to(np.eye(3), (orig.size, 3, 3))], axis=2)
    del v, x, y, z, w, outside
    gx = 2.0 * 2.0**guard_bits / width - 1.0  # |x_ndc| <= gx keeps |x_window| <= 2^guard_bits
    gy = 2.0 * 2.0**guard_bits / height - 1.0
    planes = [(2, 1.0, 1.0), (0, -1.0, gx), (0, 1.0, gx), (1, -1.0, gy), (1, 1.0, gy)]
    verts, orig = _clip(verts, orig, planes)

    # 2. Window coordinates (y down): float64 for interpolation, fixed point for coverage.
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        usable = (verts[:, :, 3] > 0.0).all(1)
        inv_w = 1.0 / np.where(usable[:, None], verts[:, :, 3], 1.0)
        px = (verts[:, :, 0] * inv_w + 1.0) * (0.5 * width)
        py = (1.0 - verts[:, :, 1] * inv_w) * (0.5 * height)
        zn = verts[:, :, 2] * inv_w
    lim = float(2 ** (guard_bits + sub_bits) + unit)
    xi = np.rint(np.clip(px * unit, -lim, lim)).astype(np.int64)
    yi = np.rint(np.clip(py * unit, -lim, lim)).astype(np.int64)
    area2 = (xi[:, 1] - xi[:, 0]) * (yi[:, 2] - yi[:, 0]) - (xi[:, 2] - xi[:, 0]) * (
        yi[:, 1] - yi[:, 0]
    )
    ok = usable & (area2 != 0)
    bad = np.unique(orig[~ok])
    n_degenerate = int(np.setdiff1d(bad, orig[ok], assume_unique=True).size)
    if cull is not None:
        ok &= ~(cull[orig] & (area2 > 0))  # window y is down: area2 > 0 is clockwise with y up
    keep = np.flatnonzero(ok)
    if keep.size == 0:
        return _empty_fragments(height, width, n_degenerate, n_nan)
    verts, orig, inv_w, px, py, zn = (a[keep] for a in (verts, orig, inv_w, px, py, zn))
    xi, yi, area2 = xi[keep], yi[keep], area2[keep]
    n_sub = len(orig)
    ibits = max(1, (n_sub - 1).bit_length())
    qmax = float(2 ** min(52, 63 - ibits) - 1)

    sign = np.where(area2 > 0, 1, -1)[None, :]
    p1, p2 = [1, 2, 0], [2, 0, 1]  # edge i runs from corner i+1 to corner i+2
    ea = (yi[:, p1] - yi[:, p2]).T * sign
    eb = (xi[:, p2] - xi[:, p1]).T * sign
    ec = (xi[:, p1] * yi[:, p2] - yi[:, p1] * xi[:, p2]).T * sign
    ec += (ea > 0) | ((ea == 0) & (eb > 0))  # top-left rule: E == 0 is inside on these edges
    # float64 screen-space barycentrics l_i = la_i x + lb_i y + lc_i, from corner 0
    e1x, e1y = px[:, 1] - px[:, 0], py[:, 1] - py[:, 0]
    e2x, e2y = px[:, 2] - px[:, 0], py[:, 2] - py[:, 0]
    fa = e1x * e2y - e2x * e1y
    inv_a = np.divide(1.0, fa, out=np.zeros_like(fa), where=fa != 0.0)
    la = np.stack([np.zeros_like(fa), e2y * inv_a, -e1y * inv_a])
    lb = np.stack([np.zeros_like(fa), -e2x * inv_a, e1x * inv_a])
    lc = -la * px[:, 0] - lb * py[:, 0]
    la[0], lb[0], lc[0] = -la[1] - la[2], -lb[1] - lb[2], 1.0 - lc[1] - lc[2]
    zs = (zn.T + 1.0) * (0.5 * qmax)
    setup = _Setup(
        ea=np.ascontiguousarray(ea),
        eb=np.ascontiguousarray(eb),
        ec=np.ascontiguousarray(ec),
        za=(la * zs).sum(0),
        zb=(lb * zs).sum(0),
        zc=(lc * zs).sum(0),
    )

    # 3. Pixel boxes, cut into (triangle, tile) pairs; classify pairs against the edges, exactly.
    c0 = np.clip(-((oxi - xi.min(1)) // unit), 0, width)
    c1 = np.clip((xi.max(1) - oxi) // unit, -1, width - 1)
    r0 = np.clip(-((oyi - yi.min(1)) // unit), 0, height)
    r1 = np.clip((yi.max(1) - oyi) // unit, -1, height - 1)
    tx0, ty0 = c0 // tile, r0 // tile
    ntx = np.maximum(c1 // tile - tx0 + 1, 0)
    npair = ntx * np.maximum(r1 // tile - ty0 + 1, 0)
    npair[(c0 > c1) | (r0 > r1)] = 0
    sid = np.repeat(np.arange(n_sub, dtype=np.int64), npair)
    k = np.arange(sid.size, dtype=np.int64) - np.repeat(np.cumsum(npair) - npair, npair)
    tyy = ty0[sid] + k // ntx[sid]
    txx = tx0[sid] + k % ntx[sid]
    del k
    pc0 = np.maximum(c0[sid], txx * tile)
    pc1 = np.minimum(c1[sid], txx * tile + tile - 1)
    pr0 = np.maximum(r0[sid], tyy * tile)
    pr1 = np.minimum(r1[sid], tyy * tile + tile - 1)
    xlo, xhi = pc0 * unit + oxi, pc1 * unit + oxi
    ylo, yhi = pr0 * unit + oyi, pr1 * unit + oyi
    reject = np.zeros(sid.size, bool)
    full = np.ones(sid.size, bool)
    for i in range(3):
        a, b, c = setup.ea[i][sid], setup.eb[i][sid], setup.ec[i][sid]
        reject |= a * np.where(a > 0, xhi, xlo) + b * np.where(b > 0, yhi, ylo) + c <= 0
        full &= a * np.where(a > 0, xlo, xhi) + b * np.where(b > 0, ylo, yhi) + c > 0
    del xlo, xhi, ylo, yhi
    order = np.argsort(tyy * (width // tile + 1) + txx, kind="stable")  # tile order: locality
    order = order[~reject[order]]
    bw, bh = pc1 - pc0 + 1, pr1 - pr0 + 1

    # 4. Expand samples, test edges where needed, resolve depth with a packed key.
    keybuf = np.full(height * width, _EMPTY, np.uint64)
    for sel, test in ((order[full[order]], False), (order[~full[order]], True)):
        pairs = (sid[sel], pc0[sel], pr0[sel], bw[sel], bh[sel])
        _scan(
            keybuf, setup, pairs, test, width, (ox, oy, oxi, oyi), unit, ibits, qmax, max_candidates
        )
    del sid, txx, tyy, pc0, pc1, pr0, pr1, reject, full, order, bw, bh

    # 5. Perspective-correct barycentrics of the visible fragments, in blocks of pixels.
    frags = _empty_fragments(height, width, n_degenerate, n_nan)
    sub_bary = verts[:, :, 4:]  # (N, 3 corners, 3 weights of the original corners)
    interp = _Interp(
        qa=la * inv_w.T,
        qb=lb * inv_w.T,
        qc=lc * inv_w.T,
        orig=orig.astype(np.int32),
        sub_bary=sub_bary,
        clipped=~np.all(sub_bary == np.eye(3), axis=(1, 2)),
    )
    tri_f = frags.tri.reshape(-1)
    bary_f = frags.bary.reshape(-1, 3)
    depth_f = frags.depth.reshape(-1)
    idx_mask = np.uint64((1 << ibits) - 1)
    for lo in range(0, height * width, max_candidates):
        blk = keybuf[lo : lo + max_candidates]
        hit = np.flatnonzero(blk != _EMPTY)
        if hit.size == 0:
            continue
        s_id = (blk[hit] & idx_mask).astype(np.intp)
        hit += lo
        row, col = np.divmod(hit, width)
        where = slice(lo, lo + blk.size) if hit.size == blk.size else hit  # full block: slices
        _resolve(interp, s_id, col + ox, row + oy, tri_f, bary_f, depth_f, where)
    return frags


def interpolate(frags: Fragments, attr, *, block: int = 1 << 20) -> np.ndarray:
    """Perspective-correct interpolation of per-corner attributes at every pixel.

    frags:   output of ``rasterize``
    attr:    (T, 3, C) or (T, 3) attribute of each corner of each original triangle
    block:   pixels processed at once (bounds the temporaries)
    returns: (H, W, C) or (H, W) float32, zeros where no triangle covers the pixel
    """
    attr = np.asarray(attr)
    scalar = attr.ndim == 2
    if scalar:
        attr = attr[:, :, None]
    if attr.ndim != 3 or attr.shape[1] != 3:
        raise ValueError(f"attr must have shape (T, 3, C) or (T, 3), got {attr.shape}")
    if attr.dtype != np.float64:
        attr = attr.astype(np.float32, copy=False)
    h, w = frags.tri.shape
    out = np.zeros((h * w, attr.shape[2]), np.float32)
    tri = frags.tri.reshape(-1)
    bary = frags.bary.reshape(-1, 3)
    hit = np.flatnonzero(tri >= 0)
    for lo in range(0, hit.size, block):
        i = hit[lo : lo + block]
        t = tri[i]
        b = bary[i].astype(attr.dtype, copy=False)
        acc = b[:, 0:1] * attr[t, 0]
        acc += b[:, 1:2] * attr[t, 1]
        acc += b[:, 2:3] * attr[t, 2]
        out[i] = acc
    out = out.reshape(h, w, attr.shape[2])
    return out[:, :, 0] if scalar else out
