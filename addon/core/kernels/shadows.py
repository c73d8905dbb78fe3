"""Shadow filtering kernel: one set of disc taps compared with a shadow map around every point.

The filter, its receiver-plane depth, clamp and bias are ``shadows``'s (module docstring and
``shadows._Frame``); this kernel is the loop over taps that ``shadows._taps`` runs, in float32
with the operations of the NumPy it replaced in the same order, so the results are the same;
``shadows._tap_pairs``, the NumPy path of small queries, is the reference a test holds it to
(tests/core/test_shadows.py: a point's visibility is the same queried alone or among 30000).
"""

from __future__ import annotations

import numba as nb
import numpy as np

_OPTIONS = {"cache": True, "nogil": True}
_V = nb.float32[::1]

_TAPS = nb.void(
    nb.float32[::1], nb.int64, nb.boolean, nb.intp[::1],  # flat depth, res, persp, base
    _V, _V, _V, _V, _V, _V,  # ac, bc, ar, br, cx, ry
    _V, _V, _V, _V, _V, _V, _V,  # B, C, A, K, bias, lo, hi
    nb.float32[:, ::1], nb.boolean, nb.boolean, nb.boolean, nb.float32,  # disc, measure, check,
    nb.uint8[::1], _V, nb.boolean[:, ::1],  # fast, neg; count, acc, outside (taps, n)
)


@nb.njit(_TAPS, **_OPTIONS)
def taps(flat, res, persp, base, ac, bc, ar, br, cx, ry, slope_b, slope_c, plane_a, plane_k,
         bias, lo, hi, disc, measure, check, fast, neg, count, acc, outside):
    """Count the blocked taps of every point (``count`` (n,), added to) and, with ``measure``,
    sum their blocker measure (``acc``); taps that leave their point's map (``check``) count
    as unblocked here and are flagged in ``outside`` (taps, n) for the exact path."""
    fres = np.float32(res)
    float_index = res * res <= 1 << 24  # row * res + col exact in float32
    size = flat.size
    for k in range(disc.shape[0]):
        a, b = disc[k, 0], disc[k, 1]
        for j in range(ac.shape[0]):
            colf = np.floor((ac[j] * a + cx[j]) + bc[j] * b)
            rowf = np.floor((ar[j] * a + ry[j]) + br[j] * b)
            if float_index:
                index = np.intp(rowf * fres + colf)
            else:
                index = np.intp(rowf) * res + np.intp(colf)
            index = (index + base[j]) % size  # taps outside the map are redone by the caller
            stored = flat[index]
            t = (colf * slope_b[j] + plane_a[j]) + rowf * slope_c[j]
            tmp = stored + bias[j]
            if fast and not measure:  # no clamp, no guard: stored + bias < K / t
                if persp:
                    blocked = tmp * t > plane_k[j]  # t < 0
                else:
                    blocked = tmp < t
            else:
                if persp:
                    if not fast:
                        t = t if t <= neg or t != t else neg
                    t = plane_k[j] / t
                if not fast:
                    t = t if t >= lo[j] or t != t else lo[j]
                    t = t if t <= hi[j] or t != t else hi[j]
                blocked = tmp < t
            if check and (min(colf, rowf) < 0.0 or max(colf, rowf) >= fres):
                blocked = False
                outside[k, j] = True
            if blocked:
                count[j] += np.uint8(1)
            if measure:
                if persp:  # ratio kept finite: blocked taps have t > bias > 0
                    t = t if t >= bias[j] or t != t else bias[j]
                    m = (stored if stored <= t or stored != stored else t) / t
                else:
                    m = t - (stored if stored <= t or stored != stored else t)
                acc[j] += m * np.float32(1.0 if blocked else 0.0)
