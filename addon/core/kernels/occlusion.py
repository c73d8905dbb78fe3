"""Ground-truth-based ambient occlusion (``core.formulas.occlusion``), pixel by pixel, then
filtered.

For each pixel of a tile, ``SLICES`` planes through the view vector, each searched on both sides
in the frame's view-space depths for the highest horizon within the radius, and the cosine-
weighted visible arc between the two horizons integrated in closed form (Jimenez et al. 2016,
"Practical real-time strategies for accurate indirect occlusion", eq. 10 with the projected
normal). The slices' angles follow the pixel's place in a 4 x 4 pattern (``PATTERN``), so that a
4 x 4 block holds ``16 * SLICES`` evenly spread angles, and ``blur`` averages each 4 x 4 block
over the pixels on the same surface: the paper's spatial distribution of slices and its
bilateral filter. Float32 buffers, float64 arithmetic. Tested against brute-force integrals
through the pipeline (``tests/core/test_occlusion.py``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from . import mark_cached

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}

SLICES = 2  # per pixel; a 4 x 4 block holds 16 times as many
STEPS = 8
MIN_SPAN = 4.0  # pixels: a radius that covers fewer finds nothing
HALF_PI = 0.5 * math.pi
# The 4 x 4 pattern's order of the 16 angle offsets (a Bayer matrix: neighbours far apart) and,
# transposed, of the 16 step offsets
PATTERN = np.array([[0, 8, 2, 10], [12, 4, 14, 6], [3, 11, 1, 9], [15, 7, 13, 5]], np.int64)


@nb.njit(nb.float64(nb.float64, nb.float64, nb.float64, nb.float64), **_OPTIONS)
def _arc(plen, gamma, c2, c1):
    """The cosine-weighted visible arc of one slice between the horizons of cosines c2 (the
    slice's positive side) and c1, for the normal projected at angle ``gamma``, length
    ``plen`` (Jimenez et al. 2016, eq. 10)."""
    h2 = math.acos(min(max(c2, -1.0), 1.0))
    h1 = -math.acos(min(max(c1, -1.0), 1.0))
    h1 = gamma + max(h1 - gamma, -HALF_PI)
    h2 = gamma + min(h2 - gamma, HALF_PI)
    cg, sg = math.cos(gamma), math.sin(gamma)
    return plen * (0.25 * (-math.cos(2.0 * h1 - gamma) + cg + 2.0 * h1 * sg)
                   + 0.25 * (-math.cos(2.0 * h2 - gamma) + cg + 2.0 * h2 * sg))


@nb.njit(nb.types.UniTuple(nb.float64, 3)(nb.float32[:, ::1], nb.float64[::1], nb.int64,
                                           nb.int64), **_OPTIONS)
def _position(depth, rec, qx, qy):
    """View-space position of buffer pixel (qx, qy)'s centre (``gtao``'s ``rec``)."""
    z = np.float64(depth[qy, qx])
    return ((rec[0] * qx + rec[1]) * z + rec[2] * qx + rec[3],
            (rec[4] * qy + rec[5]) * z + rec[6] * qy + rec[7], z)


@nb.njit(nb.types.UniTuple(nb.float64, 3)(nb.float32[:, :, ::1], nb.int64, nb.int64,
                                           nb.float64, nb.float64, nb.float64, nb.boolean),
         **_OPTIONS)
def _normal(normals, i, j, px, py, pz, ortho):
    """The normal at ``normals[i, j]`` of the surface at view-space (px, py, pz), turned
    towards the camera."""
    nx, ny, nz = (np.float64(normals[i, j, 0]), np.float64(normals[i, j, 1]),
                  np.float64(normals[i, j, 2]))
    away = nz < 0.0 if ortho else nx * px + ny * py + nz * pz > 0.0
    return (-nx, -ny, -nz) if away else (nx, ny, nz)


@nb.njit(nb.void(nb.float32[:, ::1], nb.float32[:, :, ::1], nb.int64, nb.int64,
                 nb.float64[::1], nb.float64[::1], nb.int64, nb.int64, nb.float32[:, ::1]),
         **_OPTIONS)
def gtao(depth, normals, rx, ry, rec, params, fx, fy, out):
    """Ambient occlusion (1 = open) of the pixels of a region of the buffer into ``out``.

    depth:   (H, W) view-space z at the buffer's pixel centres (camera looks along -z, y up),
             NaN where nothing was drawn
    normals: (h, w, 3) unit view-space normals of the region's pixels, either side
    rx, ry:  the region's origin in the buffer, pixels
    rec:     (8,) the view-space position of buffer pixel (qx, qy)'s centre at depth z:
             x = (rec0 qx + rec1) z + rec2 qx + rec3,  y = (rec4 qy + rec5) z + rec6 qy + rec7
    params:  (radius m, pixels per metre at depth 1 (perspective) or at any depth (ortho),
              orthographic 0/1, the widest search in pixels)
    fx, fy:  the buffer's origin in the frame, pixels (the 4 x 4 pattern is the frame's)
    out:     (h, w) float32
    """
    bh, bw = depth.shape[0], depth.shape[1]
    radius, scale, ortho, reach = params[0], params[1], params[2] > 0.5, params[3]
    r2 = radius * radius
    turn = math.pi / SLICES
    cs, ss = math.cos(turn), math.sin(turn)
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            qx, qy = rx + j, ry + i
            px, py, pz = _position(depth, rec, qx, qy)
            if pz != pz:
                out[i, j] = 1.0
                continue
            nx, ny, nz = _normal(normals, i, j, px, py, pz, ortho)
            if ortho:
                vx, vy, vz = 0.0, 0.0, 1.0
                span = radius * scale
            else:
                d = math.sqrt(px * px + py * py + pz * pz)
                if d <= 1e-9 or pz >= 0.0:
                    out[i, j] = 1.0
                    continue
                vx, vy, vz = -px / d, -py / d, -pz / d
                span = radius * scale / -pz
            span = min(span, reach)
            if span < MIN_SPAN:  # a few pixels: too coarse to tell an occluder from noise
                out[i, j] = 1.0
                continue
            # lifted off its own surface by a pixel's footprint (the raster's steps)
            lift = span / max(radius * scale, 1e-12) if ortho else -pz / scale
            px, py, pz = px + nx * lift, py + ny * lift, pz + nz * lift
            sx, sy = qx + 0.5, qy + 0.5
            cell_x, cell_y = (qx + fx) & 3, (qy + fy) & 3
            jitter = (PATTERN[cell_y, cell_x] + 0.5) / 16.0
            step_jitter = (PATTERN[cell_x, cell_y] + 0.5) / 16.0
            dx, dy = math.cos(jitter * turn), math.sin(jitter * turn)  # screen, y down
            total = 0.0
            for s in range(SLICES):
                if s > 0:
                    dx, dy = dx * cs - dy * ss, dx * ss + dy * cs
                # the slice's direction in view space, made orthogonal to the view vector
                k = dx * vx - dy * vy
                tx, ty, tz = dx - k * vx, -dy - k * vy, -k * vz
                tl = math.sqrt(tx * tx + ty * ty + tz * tz)
                if tl < 1e-9:
                    continue
                tx, ty, tz = tx / tl, ty / tl, tz / tl
                # the normal projected into the slice (spanned by v and t)
                an, at = nx * vx + ny * vy + nz * vz, nx * tx + ny * ty + nz * tz
                plen = math.sqrt(an * an + at * at)
                if plen < 1e-9:
                    continue
                c1 = c2 = -1.0
                for side in range(2):
                    sign = 1.0 if side == 0 else -1.0
                    best = -1.0
                    for step in range(STEPS):
                        t = (step + step_jitter) / STEPS * span + 0.5
                        ax = int(math.floor(sx + sign * dx * t))
                        ay = int(math.floor(sy + sign * dy * t))
                        if ax < 0 or ay < 0 or ax >= bw or ay >= bh:
                            break
                        wx, wy, wz = _position(depth, rec, ax, ay)
                        if wz != wz:
                            continue
                        wx, wy, wz = wx - px, wy - py, wz - pz
                        d2 = wx * wx + wy * wy + wz * wz
                        if d2 < 1e-18 or d2 > r2:
                            continue
                        c = (wx * vx + wy * vy + wz * vz) / math.sqrt(d2)
                        if c > best:
                            best = c
                    if side == 0:
                        c2 = best
                    else:
                        c1 = best
                total += _arc(plen, math.atan2(at, an), c2, c1)
            out[i, j] = min(max(total / SLICES, 0.0), 1.0)


@nb.njit(nb.void(nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[:, :, ::1], nb.int64,
                 nb.int64, nb.float64[::1], nb.float64, nb.float32[:, ::1]), **_OPTIONS)
def blur(ao, depth, normals, rx, ry, rec, tolerance, out):
    """Each pixel's mean of ``gtao``'s values in the 4 x 4 block around it (rows and columns
    -2 to +1), over the pixels on its own surface: normals within 37 degrees and closer to
    its tangent plane than ``tolerance`` times its depth (perspective) or than ``tolerance``
    (orthographic: ``rec0`` and ``rec4`` are 0).

    ao, normals: (h + 4, w + 4) and (h + 4, w + 4, 3) of the region at (rx, ry) in the buffer
    depth, rec:  as ``gtao``;  out: (h, w) float32
    """
    perspective = rec[0] != 0.0
    ortho = not perspective
    for i in range(out.shape[0]):
        for j in range(out.shape[1]):
            ci, cj = i + 2, j + 2
            px, py, pz = _position(depth, rec, rx + cj, ry + ci)
            if pz != pz:
                out[i, j] = ao[ci, cj]
                continue
            nx, ny, nz = _normal(normals, ci, cj, px, py, pz, ortho)
            limit = tolerance * (-pz if perspective else 1.0)
            total, weight = 0.0, 0.0
            for a in range(i, i + 4):
                for b in range(j, j + 4):
                    qx, qy, qz = _position(depth, rec, rx + b, ry + a)
                    if qz != qz:
                        continue
                    mx, my, mz = _normal(normals, a, b, qx, qy, qz, ortho)
                    if nx * mx + ny * my + nz * mz < 0.8:
                        continue
                    if abs((qx - px) * nx + (qy - py) * ny + (qz - pz) * nz) > limit:
                        continue
                    total += ao[a, b]
                    weight += 1.0
            out[i, j] = total / weight if weight > 0.0 else ao[ci, cj]


mark_cached(__name__)  # every kernel above is compiled or loaded
