"""Lightmap kernels (``core.lighting.lightmap``): texels of a UV layout, a BVH of the scene's
triangles, rays through it, and the hemisphere gather of every texel.

- ``texels``: each texel of a lightmap gets the triangle and barycentric weights of the first
  of a grid of sub-texel positions (the centre first) that falls inside a triangle of its UV
  layout; ``coverage`` counts the triangles over each texel centre (overlapping charts).
- ``build_bvh``: a bounding-volume hierarchy split by the surface area heuristic, leaves of
  at most ``LEAF`` triangles (more only where no split separates them).
- ``trace``: the nearest hit of each ray (Moeller and Trumbore 1997, "Fast, minimum storage
  ray-triangle intersection", in float64).
- ``gather``: the irradiance of each texel from cosine-distributed rays (Hammersley points
  rotated per texel): E = pi / N sum L(hit) (Monte Carlo with the pdf cos / pi), the
  radiance at a hit being read from the lightmaps (bilinear, by the hit's lightmap UV), from
  the triangle's corners (objects without a lightmap) or from the world (a miss).

The NumPy references that tests hold these to are in ``tests/core/test_lightmap.py``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from . import mark_cached
from .indirect import sample_chain
from .shading import triangle_normal

_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy"}

LEAF = 4
BINS = 16
STACK = 64
EMPTY = -1
# sub-texel positions tried in turn by ``texels``: the centre, then a 4 x 4 grid
SUBSAMPLES = np.array([[0.5, 0.5]] + [[(i + 0.5) / 4, (j + 0.5) / 4]
                                      for j in range(4) for i in range(4)], np.float64)


@nb.njit(**_OPTIONS)
def _corners(uv, t, width, height):
    """Triangle ``t`` of ``uv`` (T, 3, 2) in texels (x right, y down): its corners, twice its
    signed area and the texel columns and rows its box covers, clamped to the image (none
    when its area is below 1e-12 or not finite)."""
    x0, y0 = uv[t, 0, 0] * width, (1.0 - uv[t, 0, 1]) * height
    x1, y1 = uv[t, 1, 0] * width, (1.0 - uv[t, 1, 1]) * height
    x2, y2 = uv[t, 2, 0] * width, (1.0 - uv[t, 2, 1]) * height
    area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    if not abs(area) > 1e-12:
        return x0, y0, x1, y1, x2, y2, area, 0, -1, 0, -1
    lo_x = max(int(math.floor(min(x0, x1, x2))), 0)
    hi_x = min(int(math.floor(max(x0, x1, x2))), width - 1)
    lo_y = max(int(math.floor(min(y0, y1, y2))), 0)
    hi_y = min(int(math.floor(max(y0, y1, y2))), height - 1)
    return x0, y0, x1, y1, x2, y2, area, lo_x, hi_x, lo_y, hi_y


@nb.njit(inline="always", **_OPTIONS)
def _weights(x0, y0, x1, y1, x2, y2, area, px, py):
    """Barycentric weights of the point (px, py) in a triangle of twice the signed ``area``
    (``_corners``); all >= 0 inside."""
    w0 = ((x1 - px) * (y2 - py) - (x2 - px) * (y1 - py)) / area
    w1 = ((x2 - px) * (y0 - py) - (x0 - px) * (y2 - py)) / area
    return w0, w1, 1.0 - w0 - w1


@nb.njit(nb.void(nb.float32[:, :, ::1], nb.int64, nb.int64, nb.float64[:, ::1],
                 nb.int32[::1], nb.float32[:, ::1]), **_OPTIONS)
def texels(uv, width, height, subsamples, tri, bary):
    """Fill ``tri`` (H W,) int32 (-1 where no triangle covers) and ``bary`` (H W, 3) of a
    lightmap of ``width`` x ``height`` texels (row 0 at v = 1) from the triangles' UVs
    ``uv`` (T, 3, 2): per texel the first sub-texel position of ``subsamples`` (S, 2) (from
    the texel's top-left corner, texels) inside a triangle."""
    best = np.full(width * height, np.int64(subsamples.shape[0]))
    for t in range(uv.shape[0]):
        x0, y0, x1, y1, x2, y2, area, lo_x, hi_x, lo_y, hi_y = _corners(uv, t, width, height)
        for r in range(lo_y, hi_y + 1):
            for c in range(lo_x, hi_x + 1):
                at = r * width + c
                for k in range(min(best[at], subsamples.shape[0])):
                    px, py = c + subsamples[k, 0], r + subsamples[k, 1]
                    w0, w1, w2 = _weights(x0, y0, x1, y1, x2, y2, area, px, py)
                    if w0 >= 0.0 and w1 >= 0.0 and w2 >= 0.0:
                        best[at] = k
                        tri[at] = t
                        bary[at, 0], bary[at, 1], bary[at, 2] = w0, w1, w2
                        break


@nb.njit(nb.void(nb.float32[:, :, ::1], nb.int64, nb.int64, nb.int32[::1]), **_OPTIONS)
def coverage(uv, width, height, count):
    """Add to ``count`` (H W,) the number of triangles of ``uv`` (T, 3, 2) whose interior
    (a margin of 1e-4 texel in) holds each texel centre."""
    for t in range(uv.shape[0]):
        x0, y0, x1, y1, x2, y2, area, lo_x, hi_x, lo_y, hi_y = _corners(uv, t, width, height)
        l0 = math.hypot(x2 - x1, y2 - y1)  # the edges' lengths, texels
        l1 = math.hypot(x0 - x2, y0 - y2)
        l2 = math.hypot(x1 - x0, y1 - y0)
        h = abs(area)
        for r in range(lo_y, hi_y + 1):
            for c in range(lo_x, hi_x + 1):
                px, py = c + 0.5, r + 0.5
                e0, e1, e2 = _weights(x0, y0, x1, y1, x2, y2, area, px, py)
                # a weight times |area| / its edge's length: the distance to that edge
                if e0 * h / max(l0, 1e-12) > 1e-4 and e1 * h / max(l1, 1e-12) > 1e-4 and \
                        e2 * h / max(l2, 1e-12) > 1e-4:
                    count[r * width + c] += 1


@nb.njit(nb.int64(nb.float32[:, :, ::1], nb.int32[::1], nb.float32[:, ::1], nb.int32[:, ::1]),
         **_OPTIONS)
def build_bvh(tris, order, bounds, links):
    """Build a BVH of ``tris`` (T, 3, 3): ``order`` (T,) the triangles in leaf order,
    ``bounds`` (2 T, 6) node boxes (min xyz, max xyz), ``links`` (2 T, 4) per node: left and
    right child (-1 in a leaf), first index into ``order`` and count (0 in an inner node).
    Each node is split where the surface area heuristic over ``BINS`` bins of the centroids
    along each axis is lowest (Wald 2007, "On fast construction of SAH-based bounding volume
    hierarchies"). Node 0 is the root; returns the number of nodes."""
    n = tris.shape[0]
    cent = np.empty((n, 3), np.float32)
    tlo = np.empty((n, 3), np.float32)
    thi = np.empty((n, 3), np.float32)
    for t in range(n):
        order[t] = t
        for k in range(3):
            a, b, c = tris[t, 0, k], tris[t, 1, k], tris[t, 2, k]
            tlo[t, k] = min(a, b, c)
            thi[t, k] = max(a, b, c)
            cent[t, k] = np.float32(0.5) * (tlo[t, k] + thi[t, k])
    stack = np.empty((128, 3), np.int64)  # node, start, end
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, n
    top = 1
    nodes = 1
    bin_lo = np.empty((BINS, 3))
    bin_hi = np.empty((BINS, 3))
    bin_n = np.empty(BINS, np.int64)
    right_area = np.empty(BINS)
    right_n = np.empty(BINS, np.int64)
    while top > 0:
        top -= 1
        node, start, end = stack[top, 0], stack[top, 1], stack[top, 2]
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        clo = np.full(3, np.inf)
        chi = np.full(3, -np.inf)
        for i in range(start, end):
            t = order[i]
            for k in range(3):
                lo[k] = min(lo[k], tlo[t, k])
                hi[k] = max(hi[k], thi[t, k])
                clo[k] = min(clo[k], cent[t, k])
                chi[k] = max(chi[k], cent[t, k])
        for k in range(3):
            bounds[node, k], bounds[node, 3 + k] = lo[k], hi[k]
        count = end - start
        best_cost, best_axis, best_split = np.inf, -1, 0
        if count > LEAF and top < 126:
            for axis in range(3):
                extent = chi[axis] - clo[axis]
                if not extent > 0.0:
                    continue
                scale = BINS / extent
                bin_lo[:] = np.inf
                bin_hi[:] = -np.inf
                bin_n[:] = 0
                for i in range(start, end):
                    t = order[i]
                    b = min(int((cent[t, axis] - clo[axis]) * scale), BINS - 1)
                    bin_n[b] += 1
                    for k in range(3):
                        bin_lo[b, k] = min(bin_lo[b, k], tlo[t, k])
                        bin_hi[b, k] = max(bin_hi[b, k], thi[t, k])
                # areas and counts of the bins right of each plane, then sweep from the left
                rlo = np.full(3, np.inf)
                rhi = np.full(3, -np.inf)
                rn = 0
                for b in range(BINS - 1, 0, -1):
                    rn += bin_n[b]
                    for k in range(3):
                        rlo[k] = min(rlo[k], bin_lo[b, k])
                        rhi[k] = max(rhi[k], bin_hi[b, k])
                    dx, dy, dz = rhi[0] - rlo[0], rhi[1] - rlo[1], rhi[2] - rlo[2]
                    right_area[b] = (dx * dy + dy * dz + dz * dx) if rn else 0.0
                    right_n[b] = rn
                llo = np.full(3, np.inf)
                lhi = np.full(3, -np.inf)
                ln = 0
                for b in range(BINS - 1):
                    ln += bin_n[b]
                    for k in range(3):
                        llo[k] = min(llo[k], bin_lo[b, k])
                        lhi[k] = max(lhi[k], bin_hi[b, k])
                    if ln == 0 or right_n[b + 1] == 0:
                        continue
                    dx, dy, dz = lhi[0] - llo[0], lhi[1] - llo[1], lhi[2] - llo[2]
                    cost = (dx * dy + dy * dz + dz * dx) * ln + right_area[b + 1] * right_n[b + 1]
                    if cost < best_cost:
                        best_cost, best_axis, best_split = cost, axis, b + 1
        if best_axis < 0:
            links[node, 0], links[node, 1] = -1, -1
            links[node, 2], links[node, 3] = start, count
            continue
        scale = BINS / (chi[best_axis] - clo[best_axis])
        i, j = start, end - 1
        while i <= j:  # partition: the bins left of the split first
            t = order[i]
            if min(int((cent[t, best_axis] - clo[best_axis]) * scale), BINS - 1) < best_split:
                i += 1
            else:
                order[i], order[j] = order[j], order[i]
                j -= 1
        mid = i
        left, right = nodes, nodes + 1
        nodes += 2
        links[node, 0], links[node, 1], links[node, 2], links[node, 3] = left, right, start, 0
        stack[top, 0], stack[top, 1], stack[top, 2] = right, mid, end
        stack[top + 1, 0], stack[top + 1, 1], stack[top + 1, 2] = left, start, mid
        top += 2
    return nodes


@nb.njit(**_OPTIONS)
def _box(bounds, node, ox, oy, oz, ix, iy, iz, tmax):
    """Entry distance of a ray (origin o, inverse direction i) into a node's box, or inf."""
    t0 = (bounds[node, 0] - ox) * ix
    t1 = (bounds[node, 3] - ox) * ix
    near, far = min(t0, t1), max(t0, t1)
    t0 = (bounds[node, 1] - oy) * iy
    t1 = (bounds[node, 4] - oy) * iy
    near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    t0 = (bounds[node, 2] - oz) * iz
    t1 = (bounds[node, 5] - oz) * iz
    near, far = max(near, min(t0, t1)), min(far, max(t0, t1))
    if far >= max(near, 0.0) and near <= tmax:
        return near
    return np.inf


@nb.njit(**_OPTIONS)
def _nearest(tris, order, bounds, links, stack, ox, oy, oz, dx, dy, dz, tmax):
    """The nearest hit of one ray (float64): (triangle or -1, t, u, v) with the hit at
    (1 - u - v) corner 0 + u corner 1 + v corner 2."""
    ix = 1.0 / dx if dx != 0.0 else 1e30
    iy = 1.0 / dy if dy != 0.0 else 1e30
    iz = 1.0 / dz if dz != 0.0 else 1e30
    best, bt, bu, bv = -1, tmax, 0.0, 0.0
    if _box(bounds, np.int64(0), ox, oy, oz, ix, iy, iz, bt) == np.inf:
        return best, bt, bu, bv
    stack[0] = 0
    top = 1
    while top > 0:
        top -= 1
        node = stack[top]
        if links[node, 0] < 0:
            for i in range(links[node, 2], links[node, 2] + links[node, 3]):
                t = order[i]
                ax, ay, az = tris[t, 0, 0], tris[t, 0, 1], tris[t, 0, 2]
                e1x, e1y, e1z = tris[t, 1, 0] - ax, tris[t, 1, 1] - ay, tris[t, 1, 2] - az
                e2x, e2y, e2z = tris[t, 2, 0] - ax, tris[t, 2, 1] - ay, tris[t, 2, 2] - az
                px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
                det = e1x * px + e1y * py + e1z * pz
                if abs(det) < 1e-14:
                    continue
                inv = 1.0 / det
                sx, sy, sz = ox - ax, oy - ay, oz - az
                u = (sx * px + sy * py + sz * pz) * inv
                if u < 0.0 or u > 1.0:
                    continue
                qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
                v = (dx * qx + dy * qy + dz * qz) * inv
                if v < 0.0 or u + v > 1.0:
                    continue
                tt = (e2x * qx + e2y * qy + e2z * qz) * inv
                if tt > 0.0 and tt < bt:
                    best, bt, bu, bv = t, tt, u, v
            continue
        a, b = np.int64(links[node, 0]), np.int64(links[node, 1])
        ta = _box(bounds, a, ox, oy, oz, ix, iy, iz, bt)
        tb = _box(bounds, b, ox, oy, oz, ix, iy, iz, bt)
        if ta > tb:
            a, b, ta, tb = b, a, tb, ta
        if tb != np.inf and top < STACK:
            stack[top] = b
            top += 1
        if ta != np.inf and top < STACK:
            stack[top] = a
            top += 1
    return best, bt, bu, bv


@nb.njit(nb.void(nb.float32[:, :, ::1], nb.int32[::1], nb.float32[:, ::1], nb.int32[:, ::1],
                 nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[::1], nb.int32[::1],
                 nb.float32[:, ::1]), **_OPTIONS)
def trace(tris, order, bounds, links, origins, directions, tmax, tri, hit):
    """Nearest hits of rays ``origins``, ``directions`` (N, 3) within ``tmax`` (N,): the
    triangle ``tri`` (N,) (-1: none) and ``hit`` (N, 3): t, u, v (``_nearest``)."""
    stack = np.empty(STACK, np.int64)
    for i in range(origins.shape[0]):
        t, d, u, v = _nearest(tris, order, bounds, links, stack, np.float64(origins[i, 0]),
                              np.float64(origins[i, 1]), np.float64(origins[i, 2]),
                              np.float64(directions[i, 0]), np.float64(directions[i, 1]),
                              np.float64(directions[i, 2]), np.float64(tmax[i]))
        tri[i] = t
        hit[i, 0], hit[i, 1], hit[i, 2] = d, u, v


@nb.njit(**_OPTIONS)
def _texel_value(radiance, base, width, height, u, v, c):
    """Bilinear look-up of channel c in a lightmap (row 0 at v = 1) at ``base`` of the flat
    (texels, 3) array ``radiance``, clamped to the edges."""
    fx = u * width - 0.5
    fy = (1.0 - v) * height - 0.5
    x0 = min(max(math.floor(fx), 0.0), width - 1.0)
    y0 = min(max(math.floor(fy), 0.0), height - 1.0)
    tx = min(max(fx - x0, 0.0), 1.0)
    ty = min(max(fy - y0, 0.0), 1.0)
    xi, yi = int(x0), int(y0)
    xj, yj = min(xi + 1, width - 1), min(yi + 1, height - 1)
    a = radiance[base + yi * width + xi, c] * (1.0 - tx) + radiance[base + yi * width + xj, c] * tx
    b = radiance[base + yj * width + xi, c] * (1.0 - tx) + radiance[base + yj * width + xj, c] * tx
    return a * (1.0 - ty) + b * ty


_GATHER = nb.void(
    nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[::1], nb.int64,
    nb.float64,
    # the BVH
    nb.float32[:, :, ::1], nb.int32[::1], nb.float32[:, ::1], nb.int32[:, ::1],
    # per triangle: lightmap (-1: none), lightmap UVs (T, 3, 2), corner radiance (T, 3, 3)
    nb.int32[::1], nb.float32[:, :, ::1], nb.float32[:, :, ::1],
    # lightmaps: base texel, width, height (L,) each, radiance (texels, 3)
    nb.int64[::1], nb.int64[::1], nb.int64[::1], nb.float32[:, ::1],
    # the world: one padded cube (``kernels.indirect`` chains), its size; colour if size 0
    nb.float32[::1], nb.int64, nb.float32[::1], nb.float64[:, :, ::1],
    # out: irradiance (N, 3), L1 SH of the radiance (N, 4, 3), share of back-face hits (N,),
    # the variance of the irradiance's luminance (N,)
    nb.float32[:, ::1], nb.float32[:, :, ::1], nb.float32[::1], nb.float32[::1])


@nb.njit(_GATHER, **_OPTIONS)
def gather(points, normals, geo, offsets, rays, reach, tris, order, bounds, links, tri_map, tri_uv,
           corner_radiance, map_base, map_width, map_height, radiance, world, world_size,
           world_color, faces, irradiance, sh, back, variance):
    """The light reaching each texel (``points``, unit ``normals`` and geometric normals
    ``geo`` (N, 3)) from ``rays`` cosine-distributed rays about the normal: irradiance
    (N, 3), W/m^2, the L1 SH (Y00, Y1-1, Y10, Y11) of the radiance over the hemisphere
    (N, 4, 3), estimated with weights 1 / cos clamped at 10, and the share of rays that met a
    back face (their radiance counts as 0). Each ray starts ``offsets`` (N,) m from its point
    along ``geo`` and is ``reach`` m long.
    """
    stack = np.empty(STACK, np.int64)
    chain_off = np.zeros((1, 1), np.int64)
    chain_size = np.full((1, 1), world_size, np.int64)
    levels = np.ones(1, np.int64)
    s = np.empty(3, np.float32)
    acc = np.empty(3)
    sh_acc = np.empty((4, 3))
    c0 = 0.5 / math.sqrt(math.pi)
    c1 = math.sqrt(3.0 / (4.0 * math.pi))
    golden = 0.6180339887498949
    for i in range(points.shape[0]):
        nx, ny, nz = np.float64(normals[i, 0]), np.float64(normals[i, 1]), np.float64(normals[i, 2])
        gx, gy, gz = np.float64(geo[i, 0]), np.float64(geo[i, 1]), np.float64(geo[i, 2])
        # a frame about the normal
        if abs(nz) < 0.999:
            tx, ty, tz = -ny, nx, 0.0
        else:
            tx, ty, tz = 0.0, -nz, ny
        ln = math.sqrt(tx * tx + ty * ty + tz * tz)
        tx, ty, tz = tx / ln, ty / ln, tz / ln
        bx, by, bz = ny * tz - nz * ty, nz * tx - nx * tz, nx * ty - ny * tx
        offset = np.float64(offsets[i])
        ox = points[i, 0] + offset * gx
        oy = points[i, 1] + offset * gy
        oz = points[i, 2] + offset * gz
        h = math.sin(ox * 12.9898 + oy * 78.233 + oz * 37.719) * 43758.5453
        rot = h - math.floor(h)
        acc[:] = 0.0
        sh_acc[:] = 0.0
        backs = 0
        square = 0.0
        for k in range(rays):
            u1 = (k + 0.5) / rays
            u2 = (k * golden + rot) % 1.0
            r = math.sqrt(u1)
            phi = 2.0 * math.pi * u2
            lx, ly = r * math.cos(phi), r * math.sin(phi)
            lz = math.sqrt(max(0.0, 1.0 - u1))
            dx = lx * tx + ly * bx + lz * nx
            dy = lx * ty + ly * by + lz * ny
            dz = lx * tz + ly * bz + lz * nz
            if dx * gx + dy * gy + dz * gz <= 0.0:  # under the surface: mirrored above it
                dn = dx * gx + dy * gy + dz * gz
                dx, dy, dz = dx - 2.0 * dn * gx, dy - 2.0 * dn * gy, dz - 2.0 * dn * gz
            t, d, hu, hv = _nearest(tris, order, bounds, links, stack, ox, oy, oz, dx, dy, dz,
                                    reach)
            if t >= 0:
                fx, fy, fz = triangle_normal(tris, t)
                if fx * dx + fy * dy + fz * dz > 0.0:
                    backs += 1
                    continue
                w0 = 1.0 - hu - hv
                m = tri_map[t]
                if m >= 0:
                    u = w0 * tri_uv[t, 0, 0] + hu * tri_uv[t, 1, 0] + hv * tri_uv[t, 2, 0]
                    v = w0 * tri_uv[t, 0, 1] + hu * tri_uv[t, 1, 1] + hv * tri_uv[t, 2, 1]
                    for c in range(3):
                        s[c] = _texel_value(radiance, map_base[m], map_width[m], map_height[m],
                                            u, v, c)
                else:
                    for c in range(3):
                        s[c] = (w0 * corner_radiance[t, 0, c] + hu * corner_radiance[t, 1, c]
                                + hv * corner_radiance[t, 2, c])
            elif world_size > 0:
                sample_chain(world, chain_off, chain_size, levels, np.int64(0), faces,
                             np.float32(dx), np.float32(dy), np.float32(dz), np.float32(1.0), s)
            else:
                for c in range(3):
                    s[c] = world_color[c]
            cos = max(dx * nx + dy * ny + dz * nz, 0.1)
            lum = 0.2126 * s[0] + 0.7152 * s[1] + 0.0722 * s[2]
            square += lum * lum
            for c in range(3):
                acc[c] += s[c]
                sh_acc[0, c] += s[c] * c0 / cos
                sh_acc[1, c] += s[c] * c1 * dy / cos
                sh_acc[2, c] += s[c] * c1 * dz / cos
                sh_acc[3, c] += s[c] * c1 * dx / cos
        scale = math.pi / rays
        for c in range(3):
            irradiance[i, c] = acc[c] * scale
            for j in range(4):
                sh[i, j, c] = sh_acc[j, c] * scale
        back[i] = backs / rays
        mean = (0.2126 * acc[0] + 0.7152 * acc[1] + 0.0722 * acc[2]) / rays
        variance[i] = math.pi * math.pi * max(square / rays - mean * mean, 0.0) / rays


@nb.njit(nb.void(nb.float32[:, ::1], nb.float32[:, ::1], nb.float32[::1], nb.float64[:, ::1],
                 nb.boolean, nb.float32[:, :, ::1], nb.int32[::1], nb.float32[:, ::1],
                 nb.int32[:, ::1], nb.float64, nb.float32[::1]), **_OPTIONS)
def visibility(points, geo, offsets, samples, toward, tris, order, bounds, links, reach, out):
    """The share of a light that reaches each point (``points``, unit face normals ``geo``
    (N, 3)) unblocked by the triangles of the BVH: a shadow ray per light sample above the
    surface (``samples`` (S, 3): unit directions to a distant light, or with ``toward`` points
    on the light), starting ``offsets`` (N,) m above the surface. ``out`` (N,) in [0, 1] (0
    where no sample is above the surface)."""
    stack = np.empty(STACK, np.int64)
    for i in range(points.shape[0]):
        gx, gy, gz = np.float64(geo[i, 0]), np.float64(geo[i, 1]), np.float64(geo[i, 2])
        offset = np.float64(offsets[i])
        ox = points[i, 0] + offset * gx
        oy = points[i, 1] + offset * gy
        oz = points[i, 2] + offset * gz
        free = 0
        above = 0
        for k in range(samples.shape[0]):
            if toward:
                dx, dy, dz = samples[k, 0] - ox, samples[k, 1] - oy, samples[k, 2] - oz
                length = math.sqrt(dx * dx + dy * dy + dz * dz)
                if length <= 0.0:
                    continue
                dx, dy, dz = dx / length, dy / length, dz / length
                tmax = length * (1.0 - 1e-6)
            else:
                dx, dy, dz = samples[k, 0], samples[k, 1], samples[k, 2]
                tmax = reach
            if dx * gx + dy * gy + dz * gz <= 0.0:  # this part of the light is under the surface
                continue
            above += 1
            t, _, _, _ = _nearest(tris, order, bounds, links, stack, ox, oy, oz, dx, dy, dz,
                                  tmax)
            if t < 0:
                free += 1
        out[i] = free / above if above else 0.0


_ATROUS = nb.void(nb.float32[:, :, ::1], nb.int64[:, ::1], nb.float32[:, :, ::1],
                  nb.float32[:, :, ::1], nb.float32[:, ::1], nb.float64[::1], nb.float64,
                  nb.int64, nb.float64, nb.float64, nb.float64, nb.int64, nb.int64,
                  nb.float32[:, :, ::1])


@nb.njit(_ATROUS, **_OPTIONS)
def atrous(image, chart, position, normal, variance, luma, texel, step, sigma_normal,
           sigma_luminance, var_scale, row0, row1, out):
    """One level of ``lightmap.denoise`` (the edge-avoiding a-trous filter) for the rows
    ``row0`` to ``row1`` of ``out`` (H, W, C), from ``image`` (H, W, C): a 5 x 5 B3-spline
    kernel with holes of ``step`` texels, a neighbour counting if it is in the texel's chart
    (``chart`` (H, W), -1 none: copied), weighted by exp(-(plane + bend + shade)): its
    distance to the texel's tangent plane over ``texel`` (``position``, ``normal`` (H, W,
    3)), (1 - n.n') / ``sigma_normal``, and its luminance difference (weights ``luma`` (C,))
    over ``sigma_luminance`` standard deviations (``variance`` (H, W) times ``var_scale``)."""
    h, w, c = image.shape
    kernel = (1.0 / 16.0, 4.0 / 16.0, 6.0 / 16.0, 4.0 / 16.0, 1.0 / 16.0)
    acc = np.empty(c)
    inv_texel = 1.0 / max(texel, 1e-6)
    for y in range(row0, row1):
        for x in range(w):
            ch = chart[y, x]
            if ch < 0:
                for k in range(c):
                    out[y, x, k] = image[y, x, k]
                continue
            lum = 0.0
            for k in range(c):
                lum += luma[k] * image[y, x, k]
            scale = (sigma_luminance * math.sqrt(max(variance[y, x] * var_scale, 0.0))
                     + 1e-6 * (abs(lum) + 1e-6))
            px, py, pz = position[y, x, 0], position[y, x, 1], position[y, x, 2]
            nx, ny, nz = normal[y, x, 0], normal[y, x, 1], normal[y, x, 2]
            acc[:] = 0.0
            total = 0.0
            for a in range(5):
                yy = y + (a - 2) * step
                if yy < 0 or yy >= h:
                    continue
                for b in range(5):
                    xx = x + (b - 2) * step
                    if xx < 0 or xx >= w or chart[yy, xx] != ch:
                        continue
                    plane = abs((position[yy, xx, 0] - px) * nx + (position[yy, xx, 1] - py)
                                * ny + (position[yy, xx, 2] - pz) * nz) * inv_texel
                    bend = (1.0 - (normal[yy, xx, 0] * nx + normal[yy, xx, 1] * ny
                                   + normal[yy, xx, 2] * nz)) / sigma_normal
                    other = 0.0
                    for k in range(c):
                        other += luma[k] * image[yy, xx, k]
                    shade = abs(other - lum) / scale
                    wgt = kernel[a] * kernel[b] * math.exp(-plane - bend - shade)
                    total += wgt
                    for k in range(c):
                        acc[k] += wgt * image[yy, xx, k]
            for k in range(c):
                out[y, x, k] = acc[k] / max(total, 1e-30)


@nb.njit(nb.int64(nb.float32[:, :, ::1], nb.boolean[:, ::1], nb.float32[:, :, ::1],
                  nb.boolean[:, ::1]), **_OPTIONS)
def dilate_pass(image, have, out, grown):
    """One pass of ``lightmap.dilate``: ``out`` and ``grown`` (H, W) are ``image`` (H, W, C)
    and ``have`` with every texel outside ``have`` that has neighbours in it (8-connected)
    set to their mean. Returns how many texels grew."""
    h, w, c = image.shape
    count = 0
    for y in range(h):
        for x in range(w):
            grown[y, x] = have[y, x]
            for k in range(c):
                out[y, x, k] = image[y, x, k]
            if have[y, x]:
                continue
            n = 0
            for dy in range(-1, 2):
                yy = y + dy
                if yy < 0 or yy >= h:
                    continue
                for dx in range(-1, 2):
                    xx = x + dx
                    if xx < 0 or xx >= w or not have[yy, xx]:
                        continue
                    if n == 0:
                        for k in range(c):
                            out[y, x, k] = 0.0
                    n += 1
                    for k in range(c):
                        out[y, x, k] += image[yy, xx, k]
            if n:
                for k in range(c):
                    out[y, x, k] /= n
                grown[y, x] = True
                count += 1
    return count


mark_cached(__name__)  # every kernel above is compiled or loaded
