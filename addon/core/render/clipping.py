"""Triangles clipped against half-spaces of homogeneous clip space (Sutherland and Hodgman
1974, "Reentrant polygon clipping", on triangles): a triangle with one corner inside becomes one
triangle, with two corners inside a quad of two, keeping the winding and carrying each new
corner's barycentrics in the original triangle.
"""

from __future__ import annotations

import numpy as np

__all__ = ["clip_triangles"]


def _rotate(a: np.ndarray, first: np.ndarray) -> np.ndarray:
    """Rotate the corners of (N, 3, K) ``a`` cyclically so that corner ``first`` (N,) is first."""
    idx = (first[:, None] + np.arange(3)) % 3
    return np.take_along_axis(a, idx[:, :, None], axis=1)


def _lerp(inside: np.ndarray, outside: np.ndarray, d_in: np.ndarray, d_out: np.ndarray):
    """Point where the segment inside -> outside (N, K) crosses d = 0 (d_in >= 0 > d_out)."""
    t = d_in / (d_in - d_out)
    return inside + t[:, None] * (outside - inside)


def clip_triangles(verts: np.ndarray, orig: np.ndarray, planes) -> tuple[np.ndarray, np.ndarray]:
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
