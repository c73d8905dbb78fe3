"""Ground-truth-based ambient occlusion (``core.occlusion``), point by point.

For each shaded point, ``SLICES`` planes through the view vector, each searched on both sides in
the frame's view-space positions for the highest horizon within the radius, and the cosine-
weighted visible arc between the two horizons integrated in closed form (Jimenez et al. 2016,
"Practical real-time strategies for accurate indirect occlusion", eq. 10 with the projected
normal). Held to ``occlusion.reference`` (the same search in NumPy). Float32 buffers, float64
arithmetic.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}

SLICES = 8
STEPS = 8
MIN_SPAN = 4.0  # pixels: a radius that covers fewer finds nothing
HALF_PI = 0.5 * math.pi


@nb.njit(nb.float64(nb.float64, nb.float64), **_OPTIONS)
def _hash(x, y):
    """A white-noise value in [0, 1) of a pixel's coordinates (deterministic)."""
    h = math.sin(x * 12.9898 + y * 78.233) * 43758.5453
    return h - math.floor(h)


@nb.njit(nb.void(nb.float32[:, :, ::1], nb.float32[:, ::1], nb.float32[:, ::1],
                 nb.float32[:, ::1], nb.float64[::1], nb.float32[::1]), **_OPTIONS)
def gtao(view, points, normals, pixels, params, out):
    """Ambient occlusion (1 = open) of N points into ``out`` (N,).

    view:    (H, W, 3) view-space positions at the buffer's pixel centres (camera looks
             along -z, y up), NaN where nothing was drawn
    points:  (N, 3) view-space positions of the points;  normals: (N, 3) unit view-space normals
    pixels:  (N, 2) the points' positions in the buffer, pixels (x right, y down, centres at +0.5)
    params:  (radius m, pixels per metre at depth 1 (perspective) or at any depth (ortho),
              orthographic 0/1, the widest search in pixels)
    """
    h, w = view.shape[0], view.shape[1]
    radius, scale, ortho, reach = params[0], params[1], params[2] > 0.5, params[3]
    for i in range(points.shape[0]):
        px, py, pz = np.float64(points[i, 0]), np.float64(points[i, 1]), np.float64(points[i, 2])
        nx, ny, nz = np.float64(normals[i, 0]), np.float64(normals[i, 1]), np.float64(normals[i, 2])
        if ortho:
            vx, vy, vz = 0.0, 0.0, 1.0
            span = radius * scale
        else:
            d = math.sqrt(px * px + py * py + pz * pz)
            if d <= 1e-9 or pz >= 0.0:
                out[i] = 1.0
                continue
            vx, vy, vz = -px / d, -py / d, -pz / d
            span = radius * scale / -pz
        span = min(span, reach)
        if span < MIN_SPAN:  # a few pixels: too coarse to tell an occluder from noise
            out[i] = 1.0
            continue
        # lifted off its own surface by a pixel's footprint: the buffer holds the surface at
        # pixel centres, the point lies anywhere in its pixel
        lift = span / max(radius * scale, 1e-12) if ortho else -pz / scale
        px, py, pz = px + nx * lift, py + ny * lift, pz + nz * lift
        sx, sy = np.float64(pixels[i, 0]), np.float64(pixels[i, 1])
        jitter = _hash(math.floor(sx), math.floor(sy))
        step_jitter = _hash(math.floor(sy) + 17.0, math.floor(sx) + 31.0)
        total = 0.0
        for s in range(SLICES):
            phi = (s + jitter) * math.pi / SLICES
            dx, dy = math.cos(phi), math.sin(phi)  # screen direction, y down
            # the slice's direction in view space, made orthogonal to the view vector
            tx, ty, tz = dx, -dy, 0.0
            k = tx * vx + ty * vy + tz * vz
            tx, ty, tz = tx - k * vx, ty - k * vy, tz - k * vz
            tl = math.sqrt(tx * tx + ty * ty + tz * tz)
            if tl < 1e-9:
                continue
            tx, ty, tz = tx / tl, ty / tl, tz / tl
            # the normal projected into the slice (spanned by v and t)
            an, at = nx * vx + ny * vy + nz * vz, nx * tx + ny * ty + nz * tz
            plen = math.sqrt(an * an + at * at)
            if plen < 1e-9:
                continue
            gamma = math.atan2(at, an)
            horizons = np.empty(2)
            for side in range(2):
                sign = 1.0 if side == 0 else -1.0
                best = -1.0
                for j in range(STEPS):
                    t = (j + step_jitter) / STEPS * span + 0.5
                    qx = int(math.floor(sx + sign * dx * t))
                    qy = int(math.floor(sy + sign * dy * t))
                    if qx < 0 or qy < 0 or qx >= w or qy >= h:
                        break
                    wx = np.float64(view[qy, qx, 0]) - px
                    if wx != wx:
                        continue
                    wy = np.float64(view[qy, qx, 1]) - py
                    wz = np.float64(view[qy, qx, 2]) - pz
                    dist = math.sqrt(wx * wx + wy * wy + wz * wz)
                    if dist < 1e-9 or dist > radius:
                        continue
                    c = (wx * vx + wy * vy + wz * vz) / dist
                    if c > best:
                        best = c
                horizons[side] = best
            h2 = math.acos(min(max(horizons[0], -1.0), 1.0))
            h1 = -math.acos(min(max(horizons[1], -1.0), 1.0))
            h1 = gamma + max(h1 - gamma, -HALF_PI)
            h2 = gamma + min(h2 - gamma, HALF_PI)
            cg, sg = math.cos(gamma), math.sin(gamma)
            arc = 0.25 * (-math.cos(2.0 * h1 - gamma) + cg + 2.0 * h1 * sg) \
                + 0.25 * (-math.cos(2.0 * h2 - gamma) + cg + 2.0 * h2 * sg)
            total += plen * arc
        out[i] = min(max(total / SLICES, 0.0), 1.0)
