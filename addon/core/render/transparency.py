"""Stochastic transparency (Blender's "Dithered" render method): per sample and surface a
threshold against the surface's alpha, and the depth-peeled layers a sample sees through
until one is kept (Enderton et al., "Stochastic Transparency", 2010).
"""

from __future__ import annotations

import numpy as np

DITHER_LAYERS = 8  # surfaces a sample may see through; the last one is kept whatever its alpha
_GOLDEN32 = 0x9E3779B9  # the golden ratio's fraction, 32-bit fixed point


def _hash(px, py, layer: int) -> np.ndarray:
    """(N,) uint64 in [0, 2^32): an integer hash of (px, py, layer) (after Jarzynski and
    Olano, "Hash functions for GPU rendering", JCGT 2020)."""
    h = (np.asarray(px, np.uint64) * np.uint64(0x9E3779B1)
         ^ np.asarray(py, np.uint64) * np.uint64(0x85EBCA77)
         ^ np.uint64(layer) * np.uint64(0xC2B2AE3D)) & np.uint64(0xFFFFFFFF)
    for shift, mult in ((15, 0x2C1B3C6D), (12, 0x297A2D39)):
        h ^= h >> np.uint64(shift)
        h = (h * np.uint64(mult)) & np.uint64(0xFFFFFFFF)
    return h ^ (h >> np.uint64(15))


def dither_thresholds(px, py, sample: int, layer: int) -> np.ndarray:
    """(N,) float64 in [0, 1): per pixel (px, py) a hashed rotation of the golden-ratio
    sequence over the samples (so each pixel's samples are stratified), hashed anew per
    layer (``_hash``). In 32-bit fixed point (the golden ratio as 0x9E3779B9 / 2^32) and
    rounded to 24 bits, so that a float32 holds it exactly: the GPU's thresholds
    (``gpu_backend/glsl/dither.glsl``) are the same numbers."""
    h = _hash(px, py, layer)
    turn = (h + np.uint64(sample) * np.uint64(_GOLDEN32)) & np.uint64(0xFFFFFFFF)
    return (turn >> np.uint64(8)).astype(np.float64) / 16777216.0


def _ign(x, y) -> np.ndarray:
    """Interleaved gradient noise (Jimenez, "Next generation post processing in Call of Duty:
    Advanced Warfare", SIGGRAPH 2014) of integer positions, float64 in [0, 1)."""
    return np.mod(52.9829189 * np.mod(0.06711056 * x + 0.00583715 * y, 1.0), 1.0)


def ordered_thresholds(px, py, layer: int) -> np.ndarray:
    """(N,) float64 in [0, 1): the thresholds of texels (px, py) (non-negative integers) for
    depth-peeling layer ``layer``: interleaved gradient noise (``_ign``), so every small block
    of texels holds well spread thresholds and a filter over a few texels sees a fraction
    close to alpha. Layers after the first take the same 16 values of each 4 x 4 block in
    another order, a permutation i -> a i + b (mod 16), a odd, hashed per block and layer:
    each layer stays as well spread, and two layers of alpha a let about (1 - a)^2 through
    (shifting one pattern per layer instead keeps them correlated: two layers of 0.5 let
    0.10 through)."""
    px, py = np.asarray(px, np.int64), np.asarray(py, np.int64)
    if layer == 0:
        return _ign(px, py)
    bx, by = px >> 2, py >> 2
    h = _hash(bx, by, layer).astype(np.int64)
    i = ((px & 3) + 4 * (py & 3)) * ((h & 7) * 2 + 1) + ((h >> 3) & 15)
    return _ign(4 * bx + (i & 3), 4 * by + ((i >> 2) & 3))


def dither(layer0, at, fades, alpha, thresholds, next_layer):
    """Stochastic transparency of one sample position by depth peeling: where the surface's
    alpha does not exceed the pixel's threshold (``dither_thresholds``, say), the pixel
    takes the next surface behind it, up to ``DITHER_LAYERS`` surfaces.

    layer0:     (tri (N,), bary (N, 3) or None, depth (N,)) of the pixels and ``keys`` (K,)
                of the raster they come from; tri, bary and depth are updated in place
    at:         (N,) each pixel's index in ``keys``
    fades:      (T,) bool: triangles whose surface may be transparent
    alpha:      alpha(pixels (M,) int64, tri (M,), bary (M, 3)) -> (M,) alpha at those pixels
    thresholds: thresholds(pixels (M,) int64, layer) -> (M,) in [0, 1)
    next_layer: next_layer(floor (K,) uint64) -> (tri, bary, depth, keys) of the raster again
                with ``behind=floor``
    """
    (tri, bary, depth), keys = layer0[:3], layer0[3]
    pending = np.arange(len(tri))
    for layer in range(DITHER_LAYERS):
        t = tri[pending]
        cand = pending[(t >= 0) & fades[np.maximum(t, 0)]]
        if not len(cand):
            break
        a = alpha(cand, tri[cand], None if bary is None else bary[cand])
        pending = cand[~(a > thresholds(cand, layer))]
        if not len(pending):
            break
        floor = np.full(len(keys), np.iinfo(np.uint64).max, np.uint64)
        floor[at[pending]] = keys[at[pending]]
        tri2, bary2, depth2, keys2 = next_layer(floor)
        tri[pending], depth[pending] = tri2[pending], depth2[pending]
        if bary is not None:
            bary[pending] = bary2[pending]
        keys[at[pending]] = keys2[at[pending]]


BLEND_LAYERS = 8  # blended surfaces composited per sample; the surface behind the last is drawn
#                   as if opaque (``blend``)
PEELS = 4 * BLEND_LAYERS + DITHER_LAYERS  # layers a stack may peel in all (some only to skip
#                                           them: dithered, or an object's farther layers)


def cut_warning(cut: int) -> str:
    """The warning of ``cut`` pixel samples whose blended stack was cut (``blend``)."""
    return (f"{cut} pixel samples see more than {BLEND_LAYERS} blended surfaces in a row: "
            "the surface behind the last is drawn opaque")


def blend(layer0, at, start, blends, dithers, alpha, thresholds, next_layer, *, rank=None,
          solo=None):
    """Blended transparency (Blender's "Blended" render method) of one sample position:
    behind each pixel of ``start`` the blended surfaces are peeled front to back, up to
    ``BLEND_LAYERS``, and composited "over" the first surface that is not blended (Porter and
    Duff, "Compositing Digital Images", 1984): surface i of alpha a_i weighs a_i prod_{j<i}
    (1 - a_j), the surface or background behind them all prod_j (1 - a_j). A dithered surface
    met on the way is peeled or kept as ``dither`` peels it (thresholds of layer
    ``DITHER_LAYERS`` + k); one more blended surface than ``BLEND_LAYERS`` ends the stack, and
    so does running out of peels (``PEELS``: then what is left shows the world, and the pixel
    counts as cut).

    layer0:  (tri (N,), bary (N, 3), depth (N,), keys (K,)) of the pixels, as ``dither`` (not
             changed)
    at:      (N,) each pixel's index in ``keys``;  start: (M,) pixels whose surface is blended
    blends, dithers: (T,) bool: blended triangles, and the dithered ones (``dither``'s fades)
    alpha, thresholds, next_layer: as ``dither``'s
    rank:    (T,) int64 or None: composite in the order of these ranks (EEVEE's, by object
             origin) instead of the layers' depths
    solo:    (T,) int64 or None: an object number per triangle whose surface shows once, its
             nearest layer (EEVEE's Transparency Overlap off), -1 where all layers show
    returns: surfaces (pixels (P,), tri (P,), bary (P, 3), weight (P,) float32) to shade, the
             background's share (pixels (B,), weight (B,) float32) and the number of pixels
             whose stack had more blended layers than ``BLEND_LAYERS``
    """
    tri, bary, depth, keys = (a.copy() for a in layer0)
    m, layers = len(start), BLEND_LAYERS
    a = np.zeros((layers, m), np.float64)
    order = np.full((layers, m), np.iinfo(np.int64).max, np.int64)
    lt = np.full((layers, m), -1, np.int64)
    lb = np.zeros((layers, m, 3), np.float32)
    count = np.zeros(m, np.int64)
    end_tri = np.full(m, -1, np.int64)
    end_bary = np.zeros((m, 3), np.float32)
    deep = 0
    pending = np.arange(m)
    for layer in range(PEELS):
        px = start[pending]
        t = tri[px]
        t0 = np.maximum(t, 0)
        take = (t >= 0) & blends[t0]
        peel = np.zeros(len(t), bool)
        if solo is not None:
            s = solo[t0]
            peel = take & (s >= 0) & (np.where(lt[:, pending] >= 0, solo[np.maximum(
                lt[:, pending], 0)], -1) == s).any(0)
            take &= ~peel
        thin = (t >= 0) & dithers[t0] & ~take & ~peel
        if thin.any():
            k = np.flatnonzero(thin)
            peel[k] = ~(alpha(px[k], t[k], bary[px[k]])
                        > thresholds(px[k], DITHER_LAYERS + layer))
        full = take & (count[pending] >= layers)
        deep += int(full.sum())
        take &= ~full
        if take.any():
            k = pending[take]
            j = count[k]
            a[j, k] = np.clip(alpha(px[take], t[take], bary[px[take]]), 0.0, 1.0)
            order[j, k] = j if rank is None else rank[t[take]]
            lt[j, k], lb[j, k] = t[take], bary[px[take]]
            count[k] += 1
        peel |= take
        ends = ~peel
        end_tri[pending[ends]], end_bary[pending[ends]] = t[ends], bary[px[ends]]
        pending = pending[~ends]
        if not len(pending):
            break
        floor = np.full(len(keys), np.iinfo(np.uint64).max, np.uint64)
        floor[at[start[pending]]] = keys[at[start[pending]]]
        tri2, bary2, depth2, keys2 = next_layer(floor)
        px = start[pending]
        tri[px], bary[px], depth[px] = tri2[px], bary2[px], depth2[px]
        keys[at[px]] = keys2[at[px]]
    else:  # out of peels: the world behind what is left
        deep += len(pending)
    # "over", front to back in ``order``: each layer's share is its alpha times what the
    # layers before it let through
    sort = np.argsort(order, axis=0, kind="stable")
    a_sorted = np.take_along_axis(a, sort, 0)
    through = np.cumprod(1.0 - a_sorted, axis=0)
    share = np.empty_like(a)
    np.put_along_axis(share, sort, a_sorted * np.vstack([np.ones((1, m)), through[:-1]]), 0)
    rest = through[-1]
    j, k = np.nonzero(lt >= 0)
    ended = end_tri >= 0
    surfaces = (np.concatenate([start[k], start[ended]]),
                np.concatenate([lt[j, k], end_tri[ended]]).astype(np.int32),
                np.concatenate([lb[j, k], end_bary[ended]]),
                np.concatenate([share[j, k], rest[ended]]).astype(np.float32))
    return surfaces, (start[~ended], rest[~ended].astype(np.float32)), deep
