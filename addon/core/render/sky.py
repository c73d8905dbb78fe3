"""The world as a light that must be seen: how much of the sky's light reaches a point.

Probe light carries its own occlusion (a capture sees the walls), but the world's light, the
fallback where no probe reaches, does not: a wall just outside a volume's box would be lit as
if it stood outdoors. Here the sky is a dome of ``directions`` distant lights, each the cell of
the sphere around one of ``dome`` directions (a Fibonacci sphere: cells of equal solid angle
4 pi / K), with a shadow map each (``shadows``: a sun's, fitted to the camera's view in a frame
and to every caster in a capture), filtered with PCSS as a sun whose angular diameter spans the
cell, so that neighbouring cells' shadows blend into one soft sky shadow, but never wider than
``MAX_FILTER`` (a wider filter would reach past the walls of a room and see the sky outside).
The visible fraction of the world's light at a point of normal n is

    V(p, n) = sum_k  L_k max(0, n . w_k) v_k(p)  /  sum_k  L_k max(0, n . w_k),

L_k the world's radiance (luminance) towards w_k (its SH, ``sh.basis``), v_k the shadow map's
visibility; the world's SH irradiance at the point is scaled by it (``probes.indirect``). An
open scene keeps its sky (V = 1 where nothing stands over the point), a closed room gets sky
only through its openings, the ground under an object darkens. This is ambient occlusion from a
distant environment (obscurances: Zhukov, Iones, Kronin, "An ambient light illumination model",
Eurographics Rendering Workshop 1998) evaluated with one shadow map per direction, weighted by
the world's radiance so that a bright zenith counts for more than a dark horizon.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..formulas import sh
from ..scene import Light
from . import shadow_filter

__all__ = ["Sky", "dome", "dome_lights", "radiance_weights", "upsampled", "visibility"]

MAX_FILTER = 0.25  # metres: the dome's widest shadow filter (``shadows.ShadowMap``)
LOOKUP_ROWS = 135  # rows of a frame's grid of points where the dome is looked up (``stride``)
SAME_NORMAL = 0.95  # cosine: a neighbour's visibility is used across no sharper bend
SAME_PLANE = 0.2  # a neighbour's tangent plane passes within this share of its distance
ENOUGH = 0.5  # share of the bilinear weight on the point's surface that is blended


def dome(count: int) -> np.ndarray:
    """(count, 3) float64 unit directions towards the sky, a Fibonacci sphere: every
    direction stands for a cell of solid angle 4 pi / count (none for count 0)."""
    return sh.fibonacci_directions(count)


def cell_angle(count: int) -> float:
    """Angular diameter, radians, of the cap of solid angle 4 pi / count (one cell)."""
    return float(2.0 * np.arccos(np.clip(1.0 - 2.0 / count, -1.0, 1.0)))


def dome_lights(count: int) -> list[Light]:
    """The dome as ``count`` sun lights (shadow casting, of the cell's angular diameter),
    shining from each ``dome`` direction; their colour is unused."""
    if count <= 0:
        return []
    angle = cell_angle(count)
    return [Light("SUN", np.ones(3, np.float32), direction=-d, radius=angle, name=f"sky {k}")
            for k, d in enumerate(dome(count))]


def radiance_weights(world_sh: np.ndarray, count: int) -> np.ndarray:
    """(count,) float32 L_k >= 0: the luminance of the world's radiance (SH ``world_sh``
    (9, 3)) towards each ``dome`` direction. A direction of weight 0 sends no light, so its
    shadow map is never built."""
    return sh.radiance_luminance(world_sh, dome(count)).astype(np.float32)


@dataclass
class Sky:
    """The dome's shadow maps (``dome_lights``, in order; None where nothing casts, or
    towards a direction the world sends no light from)."""

    maps: list

    @property
    def directions(self) -> np.ndarray:
        """(K, 3) float64 unit directions towards the sky."""
        return dome(len(self.maps))


def visibility(sky: Sky, world_sh: np.ndarray, points: np.ndarray, normals: np.ndarray,
               geo: np.ndarray, poll: Callable[[], None] | None = None) -> np.ndarray:
    """(N,) float32 in [0, 1]: the fraction of the world's light (SH ``world_sh`` (9, 3) of its
    radiance) that reaches points (N, 3) of unit shading ``normals`` and geometric normals
    ``geo`` (N, 3); 1 where the world sends no light towards the normal's hemisphere.
    ``poll`` is called before each map (it may raise to stop)."""
    n = len(points)
    if not sky.maps or not n:
        return np.ones(n, np.float32)
    dirs = sky.directions
    weight_k = radiance_weights(world_sh, len(dirs))
    nx, ny, nz = np.asarray(normals, np.float32).T.copy()  # contiguous rows
    total = np.zeros(n, np.float32)
    seen = np.zeros(n, np.float32)
    for k, (dx, dy, dz) in enumerate(dirs.astype(np.float32)):
        if poll is not None:
            poll()
        w = np.maximum(nx * dx + ny * dy + nz * dz, 0.0) * weight_k[k]
        total += w
        where = w > 0.0
        smap = sky.maps[k]
        if smap is None or not where.any():
            seen += w
            continue
        seen += w * shadow_filter.shadow_visibility(smap, points, geo, where=where, jitter=False)
    out = np.ones(n, np.float32)
    lit = total > 1e-12
    out[lit] = np.clip(seen[lit] / total[lit], 0.0, 1.0)
    return out


def stride(height: int) -> int:
    """Pixels between the points where the dome is looked up in a frame ``height`` pixels high
    (``upsampled``): a grid of about ``LOOKUP_ROWS`` rows whatever the resolution, since the
    dome's shadows are as soft on the screen (4 pixels at 540 rows)."""
    return max(1, round(height / LOOKUP_ROWS))


def upsampled(evaluate: Callable[[np.ndarray], np.ndarray], x: np.ndarray, y: np.ndarray,
              points: np.ndarray, normals: np.ndarray, stride: int) -> np.ndarray:
    """(N,) float32: ``evaluate`` (indices (M,) -> (M,) values) at every point, looked up at
    the points of every ``stride``-th pixel across and down only, and blended bilinearly from
    those of the four around a point that lie on its surface (normals within ``SAME_NORMAL``,
    the point within ``SAME_PLANE`` of each one's tangent plane, relative to their distance)
    elsewhere: joint bilateral upsampling (Kopf et al., "Joint bilateral upsampling", SIGGRAPH
    2007). Where less than ``ENOUGH`` of the weight is on its surface (along edges), the same
    again on a grid twice as fine, down to a look-up at every point. The dome's
    visibility is smooth over a surface (its cells' penumbrae span ``MAX_FILTER``), so it is
    looked up at about 1 / stride^2 of the points.

    x, y:    (N,) window positions of the points, pixels
    points:  (N, 3) world positions; normals (N, 3) unit normals
    """
    n = len(x)
    out = np.zeros(n, np.float32)  # (rows not yet evaluated are read, and masked, below)
    if stride <= 1 or n == 0:
        out[:] = evaluate(np.arange(n))
        return out
    half = stride // 2
    xi, yi = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    anchor = ((xi - half) % stride == 0) & ((yi - half) % stride == 0)
    ia = np.flatnonzero(anchor)
    rest = np.flatnonzero(~anchor)
    if not len(ia):
        out[:] = evaluate(np.arange(n))
        return out
    out[ia] = evaluate(ia)
    cx, cy = (xi[ia] - half) // stride, (yi[ia] - half) // stride
    x0, y0 = cx.min(), cy.min()
    table = np.full((cy.max() - y0 + 1, cx.max() - x0 + 1), -1, np.int64)
    table[cy - y0, cx - x0] = ia
    fx = (xi[rest] - half) / stride - x0
    fy = (yi[rest] - half) / stride - y0
    c0x, c0y = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
    tx, ty = (fx - c0x).astype(np.float32), (fy - c0y).astype(np.float32)
    p, nrm = points[rest], normals[rest]
    total = np.zeros(len(rest), np.float32)
    value = np.zeros(len(rest), np.float32)
    for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1)):
        w = (tx if dx else 1.0 - tx) * (ty if dy else 1.0 - ty)
        gx, gy = c0x + dx, c0y + dy
        inside = (gx >= 0) & (gy >= 0) & (gx < table.shape[1]) & (gy < table.shape[0])
        k = np.full(len(rest), -1, np.int64)
        k[inside] = table[gy[inside], gx[inside]]
        q = np.maximum(k, 0)
        step = p - points[q]
        ok = (k >= 0) & (np.einsum("nc,nc->n", nrm, normals[q]) >= SAME_NORMAL) & (
            np.abs(np.einsum("nc,nc->n", step, normals[q]))
            <= SAME_PLANE * np.linalg.norm(step, axis=1))
        total += np.where(ok, w, 0.0)
        value += np.where(ok, w * out[q], 0.0)
    exact = total < ENOUGH
    blend = rest[~exact]
    out[blend] = value[~exact] / total[~exact]
    if exact.any():  # along edges: the same on a grid twice as fine, down to every point
        again = rest[exact]
        out[again] = upsampled(lambda j: evaluate(again[j]), x[again], y[again],
                               points[again], normals[again], stride // 2)
    return out
