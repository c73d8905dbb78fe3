"""Vectorized triangle rasterizer: clip-space triangles -> per-pixel triangle, weights, depth.

The output is the visibility part of a G-buffer: for every pixel, the index of the nearest
triangle, the perspective-correct barycentric weights of its three corners and the view depth.
Materials and shading read attributes through ``interpolate`` (deferred shading).

Method (compiled in ``kernels/raster.py``, apart from step 1's clipping and the scan order's
sort, which stay in NumPy):

1. Trivial rejection of triangles outside one plane of the clip-space frustum (per-corner
   outcodes), then clipping in homogeneous coordinates (Sutherland & Hodgman 1974; Blinn &
   Newell 1978, "Clipping using homogeneous coordinates") against the near plane z = -w and
   against a guard band far outside the screen (which keeps window coordinates small enough for
   exact integer edge functions). A clipped triangle becomes one or two triangles whose corners
   carry their barycentric coordinates in the original triangle, so the original corners'
   attributes interpolate exactly. A crossing point is always computed from the inside corner
   towards the outside one, so two triangles sharing an edge get bit-identical new corners.
2. Edge functions (Pineda 1988, "A parallel algorithm for polygon rasterization") on window
   coordinates snapped to a fixed-point grid of 2^-12 pixel (as GPUs do), exact in int64, with
   the top-left fill rule of Direct3D/OpenGL: a sample exactly on an edge belongs to the
   triangle whose inward edge normal (A, B) has A > 0, or A == 0 and B > 0 (window y down).
   That equals moving the sample by (eps, eps^2); with exact arithmetic, triangles sharing an
   edge, and fans around a vertex, cover every sample exactly once.
3. Scan conversion by spans. On sample row r, an edge with A != 0 bounds the covered columns
   on one side: c >= floor(m / A) + 1 if A > 0, c <= -floor(m / -A) - 1 if A < 0, with
   m = floor(-E(0, r) / 2^S) an integer (nested floor divisions) and E(0, r) the edge function
   at the row's sample of column 0. For images under 2^20 pixels a side, |m| < 2^53 and
   |A| <= 2^30 + 2^(S+1) are exact in float64, and the correctly rounded quotient m / |A| has
   the exact floor while it is under 2^23 (a non-integer quotient lies at least 1 / |A| below
   the next integer, more than half its ulp); beyond, rounding (monotonic) keeps it beyond the
   image. So the spans equal the per-sample edge tests exactly (larger images divide in int64).
   ``kernels.raster.scan`` walks every triangle's rows (its box's, rounded up to a few bins;
   triangles sorted by them and by box top for locality) and the columns of every span.
4. Depth test with one packed 64-bit key per fragment: quantized z_ndc in the high bits (NDC z is
   affine in window space), the clipped triangle's index in the low bits, the smallest kept per
   pixel; ties go to the lower triangle index whatever the scan order. A
   triangle whose key depth provably stays inside [0, qmax] at its corners skips the far-plane
   test and the clamp.
5. Perspective-correct barycentrics of the visible fragments only: screen-space weights divided
   by w and renormalized (Heckbert & Moreton 1991, "Interpolation for polygon texture mapping and
   shading"; Olano & Greer 1997, "Triangle scan conversion using 2D homogeneous coordinates"):
   ``kernels.raster.resolve``.

Steps 1 and 2 and the grouping do not depend on the sample offset: their result for the last
input (compared bit for bit) is kept, so that the samples of one image or tile set it up once.

``nearest`` draws a perspective view without any set-up, for views whose triangles are drawn
once or a few times (a tile's samples, a probe's faces): each triangle clipped to the near
plane and walked row by row with homogeneous edge functions in float64 (Olano & Greer 1997),
1/w interpolated, every edge inclusive by 1e-7 pixel (no cracks whatever the rounding), the
least w kept. Its fragments are ``rasterize``'s but within about 2^-12 pixel of an edge
(``rasterize`` snaps corners and samples to that grid; here a sample on a shared edge goes to
the nearer, or lower, of the triangles on both sides) and for triangles of no area once
snapped, which ``rasterize`` skips; it has no keys for depth peeling.

Conventions: clip space as in OpenGL (x/w, y/w, z/w in [-1, 1]; y up; z = -w is the near plane;
w > 0 in front of the camera). Pixel (r, c) has row 0 at the top; its sample lies at window
coordinates (c + ox, r + oy) from the top-left corner of the image, i.e. at
x_ndc = 2 (c + ox) / width - 1, y_ndc = 1 - 2 (r + oy) / height. Counter-clockwise corners (seen
with y up) face the camera, as in OpenGL and Blender.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from . import projection
from .clipping import clip_triangles

__all__ = ["Fragments", "coverage", "interpolate", "nearest", "rasterize"]

# Fixed point: window coordinates in units of 2^-S pixel, |x| <= 2^G pixels (guard band), with
# G + S = 29 so that the edge functions A x + B y + C and the doubled areas fit in int64.
_FIXED_BITS = 29
_FLOAT_SPANS = 1 << 20  # images under this side get their spans in float64 (exact: see step 3)
_KEEP_BYTES = 1 << 28  # largest set-up kept for the next call


@dataclass
class Fragments:
    """The nearest fragment of every pixel.

    tri:   (H, W) int32 index of the original triangle, -1 where nothing covers the pixel
    bary:  (H, W, 3) float32 perspective-correct weights of that triangle's corners, 0 where empty
           (None when ``rasterize`` was asked for no weights)
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
    keys: np.ndarray | None = None  # (H * W,) uint64 resolve keys: ``rasterize``'s ``behind``

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the image."""
        return self.tri.shape


def coverage(frags: Fragments) -> np.ndarray:
    """(H, W) bool: True where a triangle covers the pixel's sample."""
    return frags.tri >= 0


def _empty_fragments(height: int, width: int, degenerate: int = 0, nan: int = 0,
                     weights: bool = True) -> Fragments:
    return Fragments(
        tri=np.full((height, width), -1, np.int32),
        bary=np.zeros((height, width, 3), np.float32) if weights else None,
        depth=np.full((height, width), np.inf, np.float32),
        skipped_degenerate=degenerate,
        skipped_nan=nan,
    )


def _bin_size(n: np.ndarray) -> np.ndarray:
    """Round box sides (P,) >= 1 up to 1..8, 12, 16, 24, 32, 48, ... (few bins, < 34% padding)."""
    p2 = np.left_shift(1, np.ceil(np.log2(np.maximum(n, 1))).astype(np.int64))
    return np.where(n <= 8, n, np.where(n <= 3 * p2 // 4, 3 * p2 // 4, p2))


@dataclass
class _Setup:
    """Offset-independent set-up of one input (clip, width, height, cull).

    Per clipped triangle (N,) in scan order: sorted by rows per triangle and by box top.
    ``sid`` is the triangle's index in the
    order of the original triangles (the low bits of its depth keys, so that ties go to the lower
    original index), ``slot`` the inverse permutation.

    Coverage: edge i of a triangle is inside iff E_i = ea_i x + eb_i y + ec_i > 0 in fixed-point
    units (exact in int64; a top-left edge has 1 added to ec_i, so that E_i == 0 counts as inside
    there); edge 0 bounds its spans on the left (ea > 0), edge 1 on the right (ea < 0), edge 2 on
    the left where ea >= 0, else on the right.

    Resolve: ``table`` (9, N) holds qa_i, qb_i, qc_i with q_i = qa_i x + qb_i y + qc_i (x, y in
    pixels) the screen-space barycentric of corner i divided by its clip w (affine in window
    space: Olano & Greer 1997); the perspective-correct weight of corner i is q_i / sum(q) and
    the fragment's clip w is 1 / sum(q).
    """

    n_degenerate: int
    n_nan: int
    n_sub: int = 0
    ibits: int = 1
    qmax: float = 0.0
    sid: np.ndarray | None = None  # (N,) uint64
    slot: np.ndarray | None = None  # (N,) intp
    ea: np.ndarray | None = None  # (3, N) int64
    eb: np.ndarray | None = None
    ec: np.ndarray | None = None
    eb_f: np.ndarray | None = None  # (3, N) float64 eb
    ea_abs: np.ndarray | None = None  # (3, N) float64 |ea|, kernels.raster.NEVER where ea == 0
    half: np.ndarray | None = None  # (3, N) float64 0.5 where ea == 0
    off_lo: np.ndarray | None = None  # (N,) float64 0 where edge 2 bounds on the left, else -inf
    off_hi: np.ndarray | None = None  # (N,) float64 0 where edge 2 bounds on the right, else -inf
    ymin: np.ndarray | None = None  # (N,) int64 top of the fixed-point box
    rows: np.ndarray | None = None  # (N,) int64 rows scanned: its box's, binned
    za: np.ndarray | None = None  # (N,) float64 key depth u = za x + zb y + zc, x and y in
    zb: np.ndarray | None = None  # pixels, u = (z_ndc + 1) / 2 * qmax (affine in window space)
    zc: np.ndarray | None = None
    tame: np.ndarray | None = None  # (N,) bool: every fragment has 0 <= u <= qmax
    all_tame: bool = False
    table: np.ndarray | None = None  # (9, N) float64
    orig: np.ndarray | None = None  # (N,) int32 original triangle
    clipped: np.ndarray | None = None  # (N,) bool: corners not the original ones
    any_clipped: bool = False
    sub_bary: np.ndarray | None = None  # (K, 3, 3) corners' weights in the original triangle
    sub_index: np.ndarray | None = None  # (N,) intp row of sub_bary where clipped




def _take_columns(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """a[:, idx] of (R, M) ``a``, row by row (much faster than a 2-D take)."""
    out = np.empty((a.shape[0], idx.size), a.dtype)
    for r in range(a.shape[0]):
        np.take(a[r], idx, out=out[r], mode="clip")  # (no buffering)
    return out


def _setup(clip: np.ndarray, width: int, height: int, cull, guard_bits: int,
           depth_plane=None, base: int = 0, ibits: int | None = None,
           sample: tuple[int, int] | None = None) -> _Setup:
    """Steps 1 and 2 of the module doc, and the grouping of step 3 (see ``rasterize``).

    base, ibits: the key indices are ``base`` + the piece's index, in ``ibits`` bits (one
                 chunk of a larger input, ``_rasterize_chunks``); by default 0 and as few
                 bits as the pieces need
    sample:      (oxi, oyi, ox, oy) the sample offset, fixed-point and in pixels: triangles
                 whose box holds no sample at that offset are left out (a set-up for that
                 offset only)
    """
    sub_bits = _FIXED_BITS - guard_bits
    unit = 1 << sub_bits
    n_tri = clip.shape[0]

    # 1. Reject non-finite and out-of-frustum triangles; clip against near plane and guard band.
    from ..kernels import raster as kernels

    orig = np.empty(n_tri, np.int64)
    if sample is None:
        count, n_nan = kernels.survivors(clip, orig)
    else:  # and a sample inside their box
        count, n_nan = kernels.sample_survivors(clip, width, height, sample[2], sample[3], orig)
    orig = orig[:count]
    if orig.size == 0:
        return _Setup(0, n_nan)
    # (12, M) float64: row 4 c + k is coordinate k (x, y, z, w) of corner c
    v = np.array(clip.reshape(n_tri, 12).take(orig, axis=0).T, np.float64, order="C")
    gx = 2.0 * 2.0**guard_bits / width - 1.0  # |x_ndc| <= gx keeps |x_window| <= 2^guard_bits
    gy = 2.0 * 2.0**guard_bits / height - 1.0
    planes = [(2, 1.0, 1.0), (0, -1.0, gx), (0, 1.0, gx), (1, -1.0, gy), (1, 1.0, gy)]
    cut = np.zeros((3, orig.size), bool)
    for axis, s, k in planes:
        cut |= ~(s * v[axis::4] + k * v[3::4] >= 0.0)
    cut = np.flatnonzero(cut[0] | cut[1] | cut[2])
    sub_bary = sub_index = None
    if cut.size:  # the same pieces, in the same order, as clipping all triangles
        verts = np.empty((cut.size, 3, 7))
        verts[:, :, :4] = v[:, cut].T.reshape(-1, 3, 4)
        verts[:, :, 4:] = np.eye(3)
        cv, co = clip_triangles(verts, orig[cut], planes)
        whole = np.ones(orig.size, bool)
        whole[cut] = False
        v = np.concatenate([v[:, whole], cv[:, :, :4].reshape(-1, 12).T], axis=1)
        orig = np.concatenate([orig[whole], co])
        sub_index = np.concatenate([np.full(orig.size - co.size, -1, np.intp),
                                    np.arange(co.size, dtype=np.intp)])
        sub_bary = np.ascontiguousarray(cv[:, :, 4:])  # (K, 3 corners, 3 original weights)
        order = np.argsort(orig, kind="stable")
        v, orig, sub_index = _take_columns(v, order), orig[order], sub_index[order]

    # 2. Window coordinates (y down), (3, M): float64 for interpolation, fixed point for coverage.
    m = v.shape[1]
    xi, yi = np.empty((3, m), np.int64), np.empty((3, m), np.int64)
    px, py, zn, inv_w = (np.empty((3, m)) for _ in range(4))
    usable, area2 = np.empty(m, bool), np.empty(m, np.int64)
    kernels.window(np.ascontiguousarray(v), width, height, unit,
                   float(2 ** (guard_bits + sub_bits) + unit), xi, yi, px, py, zn, inv_w, usable,
                   area2)
    del v
    if depth_plane is not None:  # NDC z from 1 / w: exact where float32 z / w is not
        zn[:] = -float(depth_plane[0]) + float(depth_plane[1]) * inv_w
    ok = usable & (area2 != 0)
    n_degenerate = 0
    if not ok.all():
        bad = np.unique(orig[~ok])
        n_degenerate = int(np.setdiff1d(bad, orig[ok], assume_unique=True).size)
    if cull is not None:
        ok &= ~(cull[orig] & (area2 > 0))  # window y is down: area2 > 0 is clockwise with y up
    if sample is not None:  # a sample (c unit + oxi, r unit + oyi) in the snapped box, or none
        for fixed, offset in ((xi, sample[0]), (yi, sample[1])):
            lo = np.minimum(np.minimum(fixed[0], fixed[1]), fixed[2])
            hi = np.maximum(np.maximum(fixed[0], fixed[1]), fixed[2])
            ok &= ((hi - offset) >> sub_bits) >= -((offset - lo) >> sub_bits)
    keep = np.flatnonzero(ok)
    n_sub = keep.size
    if n_sub == 0:
        return _Setup(n_degenerate, n_nan)
    if ibits is None:
        ibits = max(1, (n_sub - 1).bit_length())
    qmax = float(2 ** min(52, 63 - ibits) - 1)

    # 3. Scan order: by rows per triangle (its box's sample rows, rounded up to a bin), then by
    #    box top for locality. ``keep[order]`` are the kept triangles in scan order.
    ymin = np.minimum(np.minimum(yi[0], yi[1]), yi[2]).take(keep)
    ymax = np.maximum(np.maximum(yi[0], yi[1]), yi[2]).take(keep)
    rows = np.minimum(_bin_size(((ymax - ymin) >> sub_bits) + 1), height)
    order = np.argsort(rows * (1 << 32) + (ymin - ymin.min()))
    rows, ymin = rows.take(order), ymin.take(order)
    slot = np.empty(n_sub, np.intp)
    slot[order] = np.arange(n_sub)
    sel = keep.take(order)
    orig = orig.take(sel)
    ea, eb, ec = (np.empty((3, n_sub), np.int64) for _ in range(3))
    eb_f, ea_abs, half = (np.empty((3, n_sub)) for _ in range(3))
    off_lo, off_hi, za, zb, zc = (np.empty(n_sub) for _ in range(5))
    tame = np.empty(n_sub, bool)
    table = np.empty((9, n_sub))
    # u is affine: on the snapped triangle (which holds the covered samples) it lies between its
    # values at the snapped corners. Where those are in [0, qmax] by far more than any rounding
    # of u (at the corners, inside the guard band, and at the samples), the fragments need no
    # far-plane test and no clamp.
    kernels.edges(keep.astype(np.int64), order.astype(np.int64), xi, yi, px, py, zn, inv_w,
                  area2, unit, qmax, 2.0 ** (guard_bits - 38), 2.0**-46, ea, eb, ec, eb_f,
                  ea_abs, half, off_lo, off_hi, za, zb, zc, tame, table)
    if sub_index is None:
        clipped = np.zeros(n_sub, bool)
        sub_bary, sub_index = np.zeros((1, 3, 3)), np.zeros(n_sub, np.intp)
    else:
        sub_index = sub_index[sel]
        clipped = sub_index >= 0
        clipped[clipped] = ~np.all(sub_bary[sub_index[clipped]] == np.eye(3), axis=(1, 2))
    return _Setup(
        n_degenerate=n_degenerate,
        n_nan=n_nan,
        n_sub=n_sub,
        ibits=ibits,
        qmax=qmax,
        sid=order.astype(np.uint64) + np.uint64(base),
        slot=slot,
        ea=ea,
        eb=eb,
        ec=ec,
        eb_f=eb_f,
        ea_abs=ea_abs,
        half=half,
        off_lo=off_lo,
        off_hi=off_hi,
        ymin=ymin,
        rows=rows,
        za=za,
        zb=zb,
        zc=zc,
        tame=tame,
        all_tame=bool(tame.all()),
        table=table,
        orig=orig.astype(np.int32),
        clipped=clipped,
        any_clipped=bool(clipped.any()),
        sub_bary=sub_bary,
        sub_index=sub_index,
    )


# .entry: (clip, cull, width, height, guard_bits, depth_plane, _Setup) of the last input of
# this thread (tiles rendered at once each keep their own)
_last_setup = threading.local()


def _cached_setup(clip: np.ndarray, width: int, height: int, cull, guard_bits: int,
                  depth_plane=None) -> _Setup:
    """``_setup`` of the input, reused while the same input (bit for bit) comes again."""
    last = getattr(_last_setup, "entry", None)
    if (
        last is not None
        and last[2:6] == (width, height, guard_bits, depth_plane)
        and last[0].dtype == clip.dtype
        and last[0].shape == clip.shape
        and (cull is None) == (last[1] is None)
        and (cull is None or np.array_equal(cull, last[1]))
        and np.array_equal(_bits(clip), _bits(last[0]))
    ):
        return last[6]
    setup = _setup(clip, width, height, cull, guard_bits, depth_plane)
    size = clip.nbytes + sum(a.nbytes for a in vars(setup).values() if isinstance(a, np.ndarray))
    if size <= _KEEP_BYTES:  # about 350 bytes per triangle
        copy_cull = None if cull is None else cull.copy()
        _last_setup.entry = (clip.copy(), copy_cull, width, height, guard_bits, depth_plane,
                             setup)
    else:
        _last_setup.entry = None
    return setup


def _bits(a: np.ndarray) -> np.ndarray:
    """The bits of contiguous float32/float64 ``a`` as unsigned integers (NaN == NaN)."""
    return a.view(np.uint32 if a.itemsize == 4 else np.uint64)


def rasterize(
    clip,
    width: int,
    height: int,
    *,
    cull=None,
    sample_offset=(0.5, 0.5),
    weights: bool = True,
    behind=None,
    keep: dict | None = None,
    depth_plane: tuple[float, float] | None = None,
) -> Fragments:
    """Rasterize triangles into the nearest fragment per pixel (one sample per pixel).

    clip:          (T, 3, 4) float clip-space corner positions (OpenGL convention, see module doc)
    width, height: image size in pixels
    cull:          None, or (T,) bool: True where the triangle's back face (clockwise corners in
                   window space with y up) is culled
    sample_offset: (ox, oy) sample position inside the pixel, in pixels from its top-left corner;
                   call several times with different offsets for supersampling (the set-up of
                   the last input, some 350 bytes per triangle up to 256 MB, is kept and reused
                   while the same clip, size and cull come again)
    weights:       False leaves ``Fragments.bary`` None (a depth map needs no weights)
    behind:        None, or (H * W,) uint64 ``Fragments.keys`` of an earlier call with the same
                   clip, size, cull and offset: each pixel then gets the next fragment behind
                   that one (depth peeling; ties in depth go by triangle), and pixels whose
                   key is 0 get the nearest
    keep:          None, or a dict the caller keeps with this very clip, size and cull (not
                   checked): the set-up is stored in it and reused by later calls (a viewport
                   renders each tile again and again, on any thread)
    depth_plane:   (P22, P23) of a perspective projection P (float64): the depth test then
                   uses z/w = -P22 + P23 / w, exact from w, where the float32 clip z holds
                   nothing of it once far/near is large (a 1 mm to 50 km camera)
    returns:       Fragments; triangles with NaN/inf corners or zero window-space area are skipped
                   and counted, triangles outside the frustum are dropped silently, and
                   fragments beyond the far plane (z/w > 1) are dropped
    """
    from ..kernels import raster as kernels

    width, height = int(width), int(height)
    if isinstance(clip, projection.Projection):
        if len(clip) > SETUP_TRIANGLES:
            return _rasterize_chunks(clip, width, height, cull, sample_offset, weights, behind,
                                     depth_plane)
        clip = clip.part(0, len(clip))
    clip = np.asarray(clip)
    if clip.ndim != 3 or clip.shape[1:] != (3, 4):
        raise ValueError(f"clip must have shape (T, 3, 4), got {clip.shape}")
    n_tri = clip.shape[0]
    if n_tri > SETUP_TRIANGLES:
        return _rasterize_chunks(clip, width, height, cull, sample_offset, weights, behind,
                                 depth_plane)
    if cull is not None:
        cull = np.asarray(cull, dtype=bool)
        if cull.shape != (n_tri,):
            raise ValueError(f"cull must have shape ({n_tri},), got {cull.shape}")
    if width <= 0 or height <= 0 or n_tri == 0:
        return _empty_fragments(max(height, 0), max(width, 0), weights=weights)
    if clip.dtype != np.float32:
        clip = clip.astype(np.float64, copy=False)
    clip = np.ascontiguousarray(clip)
    guard_bits = max(17, max(width, height).bit_length() + 1)
    sub_bits = _FIXED_BITS - guard_bits
    unit = 1 << sub_bits
    ox, oy = (float(o) for o in sample_offset)
    oxi, oyi = round(ox * unit), round(oy * unit)

    if keep is None:
        s = _cached_setup(clip, width, height, cull, guard_bits, depth_plane)
    else:
        if "setup" not in keep:
            keep["setup"] = _setup(clip, width, height, cull, guard_bits, depth_plane)
        s = keep["setup"]
    if s.n_sub == 0:
        return _empty_fragments(height, width, s.n_degenerate, s.n_nan, weights)
    keybuf = np.full(height * width, kernels.EMPTY, np.uint64)
    floor = np.zeros(height * width, np.uint64) if behind is None else np.ascontiguousarray(
        behind, np.uint64)
    kernels.scan(s.ea, s.eb, s.ec, s.eb_f, s.ea_abs, s.half, s.off_lo, s.off_hi, s.ymin, s.rows,
                 s.za, s.zb, s.zc, s.tame, s.sid, width, height, sub_bits, oxi, oyi, ox, oy,
                 s.qmax, s.ibits, max(width, height) >= _FLOAT_SPANS, floor, keybuf)
    bary = np.empty((height, width, 3) if weights else (1, 3), np.float32)
    frags = Fragments(
        tri=np.empty((height, width), np.int32),
        bary=bary if weights else None,
        depth=np.empty((height, width), np.float32),
        skipped_degenerate=s.n_degenerate,
        skipped_nan=s.n_nan,
        keys=keybuf,
    )
    kernels.resolve(keybuf, s.ibits, s.slot, s.table, s.orig, s.clipped, s.sub_bary,
                    s.sub_index, width, ox, oy, weights, frags.tri.reshape(-1),
                    bary.reshape(-1, 3), frags.depth.reshape(-1))
    return frags


def nearest(clip: np.ndarray, width: int, height: int, *, cull=None,
            sample_offsets=((0.5, 0.5),), depth_plane: tuple[float, float]) -> list[Fragments]:
    """``rasterize`` of a perspective projection at each of ``sample_offsets`` (S, 2), without
    its set-up (``kernels.raster.nearest``: each triangle clipped and set up once for all the
    samples, walked straight from its clip-space corners; for views whose triangles are drawn
    once, such as a tile's samples): the same fragments but within about 2^-12 pixel of an
    edge and for triangles of no area once snapped (module docstring), and no keys (no depth
    peeling). Arguments as ``rasterize``; ``depth_plane`` gives the far plane. Returns one
    Fragments per offset."""
    from ..kernels import raster as kernels

    width, height = int(width), int(height)
    clip = np.ascontiguousarray(clip, np.float32)
    offsets = np.ascontiguousarray(np.reshape(sample_offsets, (-1, 2)), np.float64)
    p22, p23 = depth_plane
    far = p23 / (1.0 + p22) if 1.0 + p22 < 0.0 else np.inf  # z / w = 1 at w = far
    culling = cull is not None
    cull = (np.ascontiguousarray(cull, bool) if culling else np.zeros(0, bool))
    count = len(offsets)
    tri = np.empty((count, height, width), np.int32)
    bary = np.empty((count, height, width, 3), np.float32)
    depth = np.empty((count, height, width), np.float32)
    kernels.nearest(clip, cull, culling, offsets, float(far), tri, bary, depth)
    return [Fragments(tri=tri[k], bary=bary[k], depth=depth[k]) for k in range(count)]


# Inputs of more triangles than this (whose set-up, some 350 bytes a triangle, could not be
# kept for the next sample) are set up a chunk at a time, for one sample offset each
SETUP_TRIANGLES = _KEEP_BYTES // 350
_MAX_PIECES = 32  # pieces of one triangle clipped by the five planes, one split each at most


def _rasterize_chunks(clip, width, height, cull, sample_offset, weights, behind, depth_plane):
    """``rasterize`` of a large input (an array or a ``projection.Projection``) in chunks of
    ``projection.CHUNK`` triangles, each set up for this sample offset only (triangles whose
    box holds no sample are left out before the costly steps) and scanned into the same keys:
    the key index of a piece of the chunk starting at triangle t0 is ``_MAX_PIECES`` t0 + the
    piece's rank in the chunk (pieces in triangle order), so keys compare (depth, triangle) as
    in one set-up and ``behind`` works across calls. The pixels a chunk wins are resolved with
    its set-up before the next one."""
    from ..kernels import raster as kernels

    n_tri = len(clip)
    if width <= 0 or height <= 0:
        return _empty_fragments(max(height, 0), max(width, 0), weights=weights)
    if cull is not None:
        cull = np.asarray(cull, dtype=bool)
        if cull.shape != (n_tri,):
            raise ValueError(f"cull must have shape ({n_tri},), got {cull.shape}")
    guard_bits = max(17, max(width, height).bit_length() + 1)
    sub_bits = _FIXED_BITS - guard_bits
    unit = 1 << sub_bits
    ox, oy = (float(o) for o in sample_offset)
    oxi, oyi = round(ox * unit), round(oy * unit)
    ibits = (_MAX_PIECES * n_tri).bit_length()
    npx = height * width
    keybuf = np.full(npx, kernels.EMPTY, np.uint64)
    floor = np.zeros(npx, np.uint64) if behind is None else np.ascontiguousarray(behind,
                                                                                   np.uint64)
    tri = np.full(npx, -1, np.int32)
    bary = np.zeros((npx, 3) if weights else (1, 3), np.float32)
    depth = np.full(npx, np.inf, np.float32)
    part_tri, part_depth = np.empty(npx, np.int32), np.empty(npx, np.float32)
    part_bary = np.empty((npx, 3) if weights else (1, 3), np.float32)
    degenerate = nan = 0
    for lo in range(0, n_tri, projection.CHUNK):
        hi = min(lo + projection.CHUNK, n_tri)
        part = clip.part(lo, hi) if isinstance(clip, projection.Projection) else clip[lo:hi]
        part = np.ascontiguousarray(part, np.float32 if part.dtype == np.float32 else np.float64)
        base = _MAX_PIECES * lo
        s = _setup(part, width, height, None if cull is None else cull[lo:hi], guard_bits,
                   depth_plane, base=base, ibits=ibits, sample=(oxi, oyi, ox, oy))
        del part
        degenerate, nan = degenerate + s.n_degenerate, nan + s.n_nan
        if s.n_sub == 0:
            continue
        before = keybuf.copy()
        kernels.scan(s.ea, s.eb, s.ec, s.eb_f, s.ea_abs, s.half, s.off_lo, s.off_hi, s.ymin,
                     s.rows, s.za, s.zb, s.zc, s.tame, s.sid, width, height, sub_bits, oxi, oyi,
                     ox, oy, s.qmax, ibits, max(width, height) >= _FLOAT_SPANS, floor, keybuf)
        won = np.flatnonzero(keybuf != before)
        if not len(won):
            continue
        keys = np.full(npx, kernels.EMPTY, np.uint64)
        keys[won] = keybuf[won] - np.uint64(base)  # the chunk's own piece indices
        kernels.resolve(keys, ibits, s.slot, s.table, s.orig, s.clipped, s.sub_bary,
                        s.sub_index, width, ox, oy, weights, part_tri, part_bary, part_depth)
        tri[won], depth[won] = part_tri[won] + lo, part_depth[won]
        if weights:
            bary[won] = part_bary[won]
    return Fragments(tri.reshape(height, width),
                     bary.reshape(height, width, 3) if weights else None,
                     depth.reshape(height, width), degenerate, nan, keybuf)


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
