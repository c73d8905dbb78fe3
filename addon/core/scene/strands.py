"""Geometry Blender has beyond meshes, as triangles the renderer draws: hair curves as tubes,
point clouds as spheres (Cycles renders both as round surfaces).

- A curve is the polyline through its points (Blender's Catmull-Rom or Bezier evaluation is not
  followed: hair has many points), a tube of ``TUBE_SIDES`` sides around it whose radius follows
  the points' radii. A regular n-gon of circumradius R seen from a random direction is on
  average n R sin(pi / n) 2 / pi wide; R is chosen so that this is 2 r, the round tube's width,
  so that hair covers as much of the image as Cycles' tubes do. The corner normals point away
  from the curve, so the tube shades round.
- A point is an icosahedron whose area equals the sphere's (so that, convex, it covers the same
  share of the image on average: a quarter of the area), its corner normals the sphere's.

Both take float32 object-space data and give ``MeshBatch``-ready arrays.
"""

from __future__ import annotations

import numpy as np

TUBE_SIDES = 3  # 6 triangles per segment: hair in millions of segments stays in memory
_TUBE_SCALE = np.pi / (TUBE_SIDES * np.sin(np.pi / TUBE_SIDES))  # circumradius / radius


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-20)


def curve_frames(points: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per point of curves ``points`` (P, 3) cut by ``offsets`` (C + 1,): unit tangents
    (P, 3) and a unit vector across each (P, 3), carried along every curve without twist
    (parallel transport: each across the previous one made perpendicular to the tangent)."""
    p = np.asarray(points, np.float64)
    start = np.asarray(offsets[:-1], np.int64)
    count = np.diff(offsets).astype(np.int64)
    last = start + count - 1
    ahead = np.minimum(np.arange(len(p)) + 1, np.repeat(last, count))
    behind = np.maximum(np.arange(len(p)) - 1, np.repeat(start, count))
    tangent = _unit(p[ahead] - p[behind])
    across = np.empty_like(tangent)
    t0 = tangent[start]
    ref = np.where(np.abs(t0[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    across[start] = _unit(np.cross(t0, ref))
    for k in range(1, int(count.max(initial=1))):
        live = count > k
        at = start[live] + k
        prev = across[at - 1]
        t = tangent[at]
        a = prev - t * np.einsum("nk,nk->n", prev, t)[:, None]
        bad = np.linalg.norm(a, axis=1) < 1e-9  # a kink back on itself: any perpendicular
        if bad.any():
            ref = np.where(np.abs(t[bad, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
            a[bad] = np.cross(t[bad], ref)
        across[at] = _unit(a)
    return tangent, across


def tubes(points: np.ndarray, radii: np.ndarray, offsets: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Tubes around curves.

    points:  (P, 3) float32 the curves' points, object space, metres
    radii:   (P,) float32 radius at each point, metres
    offsets: (C + 1,) int: curve c is points offsets[c] to offsets[c + 1]
    returns: positions (T, 3, 3), corner normals (T, 3, 3) float32, and (T,) int32 the curve
             of each triangle; T = 2 TUBE_SIDES (P - C) (curves of one point give none)
    """
    offsets = np.asarray(offsets, np.int64)
    tangent, across = curve_frames(points, offsets)
    other = np.cross(tangent, across)
    angle = 2.0 * np.pi * np.arange(TUBE_SIDES) / TUBE_SIDES
    # (P, S, 3) the ring's outward directions and corners
    out = (np.cos(angle)[None, :, None] * across[:, None, :]
           + np.sin(angle)[None, :, None] * other[:, None, :])
    ring = (np.asarray(points, np.float64)[:, None, :]
            + out * (np.asarray(radii, np.float64) * _TUBE_SCALE)[:, None, None])
    count = np.diff(offsets)
    first = np.repeat(offsets[:-1], np.maximum(count - 1, 0))
    k = np.arange(len(first)) - np.repeat(np.cumsum(np.maximum(count - 1, 0))
                                          - np.maximum(count - 1, 0), np.maximum(count - 1, 0))
    a = first + k  # each segment's first point
    b = a + 1
    s0 = np.arange(TUBE_SIDES)
    s1 = (s0 + 1) % TUBE_SIDES
    # per segment and side two triangles, counter-clockwise seen from outside:
    # (a s0, b s1, b s0) and (a s0, a s1, b s1)
    pa, pb = ring[a], ring[b]  # (G, S, 3)
    na, nb = out[a], out[b]
    tri = np.stack([np.stack([pa[:, s0], pb[:, s1], pb[:, s0]], 2),
                    np.stack([pa[:, s0], pa[:, s1], pb[:, s1]], 2)], 2)  # (G, S, 2, 3, 3)
    nrm = np.stack([np.stack([na[:, s0], nb[:, s1], nb[:, s0]], 2),
                    np.stack([na[:, s0], na[:, s1], nb[:, s1]], 2)], 2)
    curve = np.repeat(np.repeat(np.arange(len(count), dtype=np.int32), np.maximum(count - 1, 0)),
                      2 * TUBE_SIDES)
    return (tri.reshape(-1, 3, 3).astype(np.float32), nrm.reshape(-1, 3, 3).astype(np.float32),
            curve)


def _icosahedron() -> tuple[np.ndarray, np.ndarray]:
    g = (1.0 + 5.0 ** 0.5) / 2.0
    v = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
                  [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]],
                 np.float64)
    v /= np.linalg.norm(v[0])
    f = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]])
    return v, f


_ICO_V, _ICO_F = _icosahedron()
# the unit-circumradius icosahedron's area is 5 sqrt(3) a^2 (a its edge): scaled to 4 pi
_ICO_SCALE = float(np.sqrt(4.0 * np.pi / (5.0 * np.sqrt(3.0)
                                        * np.sum((_ICO_V[0] - _ICO_V[11]) ** 2))))


def spheres(points: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Spheres at ``points`` (N, 3) of ``radii`` (N,) (float32, metres): positions and corner
    normals (20 N, 3, 3) float32, counter-clockwise seen from outside."""
    corners = _ICO_V[_ICO_F]  # (20, 3, 3) unit directions
    pos = (np.asarray(points, np.float64)[:, None, None, :]
           + corners[None] * (np.asarray(radii, np.float64) * _ICO_SCALE)[:, None, None, None])
    nrm = np.broadcast_to(corners[None], pos.shape)
    return pos.reshape(-1, 3, 3).astype(np.float32), nrm.reshape(-1, 3, 3).astype(np.float32)
