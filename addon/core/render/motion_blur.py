"""Motion blur with the samples the engine already takes: each anti-aliasing sample sees the
scene at its own time of the shutter, and their average is the streaked image (the
accumulation buffer, Haeberli and Akeley 1990), as depth of field takes a lens point per
sample (``depth_of_field``).

The shutter is sampled at S positions (``MeshBatch.motion``, ``Camera.motion``: evenly spaced
from the shutter's opening to its closing, Cycles' motion steps), linearly in between. A
sample's time follows the Halton sequence in base 5 (independent of the pixel filter's R2
positions and the lens's bases 2 and 3), through the inverse of the shutter curve's integral
(Render > Motion Blur > Shutter Curve) where it is not flat. All pixels share a sample's time,
so a streak of L pixels shows the samples' images apart until there are about L of them;
through a rolling shutter (Cycles' Rolling Shutter), each band of rows has its own
(``rolling``, ``band_rows``): the frame's tiles are then bands of rows.

A sample is shaded in the scene as it is at the middle of its time's share of the shutter,
one of ``SHUTTER_TIMES`` even shares (``shares``): the moving triangles' corners and normals
there (``moved_normals``), the camera there, and the shadow maps they cast there
(``pipeline.prepare``), so a moving object's shadow streaks as the object does, with that
many images of it blended, and never falls on the object from another time.
"""

from __future__ import annotations

import numpy as np

from ..scene import Camera
from . import projection
from .depth_of_field import halton

_BASE = 5
SHUTTER_TIMES = 16  # shares of the shutter a sample is shaded at the middle of


def shutter_times(sample: np.ndarray, curve: tuple[float, ...] = ()) -> np.ndarray:
    """(N,) times in [0, 1] (0: the shutter opens, 1: it closes) of sample numbers ``sample``
    (N,): uniform over the shutter, or distributed as ``curve`` (its openness at evenly spaced
    times, K >= 2 values; Cycles' shutter curve) when given."""
    u = halton(np.asarray(sample, np.int64) + 1, _BASE)
    if len(curve) < 2:
        return u
    weight = np.maximum(np.asarray(curve, np.float64), 0.0)
    if not weight.any():
        return u
    h = 1.0 / (len(weight) - 1)
    # the openness is piecewise linear, its integral piecewise quadratic: at the knots, then
    # solved within the segment a u falls in, a s + (b - a) s^2 / (2 h) = r
    cdf = np.concatenate([[0.0], np.cumsum((weight[1:] + weight[:-1]) / 2.0 * h)])
    r = u * cdf[-1]
    i = np.clip(np.searchsorted(cdf, r, side="right") - 1, 0, len(weight) - 2)
    a, b = weight[i], weight[i + 1]
    r = r - cdf[i]
    slope = (b - a) / h
    flat = np.abs(slope) < 1e-9
    root = np.sqrt(np.maximum(a * a + 2.0 * slope * r, 0.0))
    s = np.where(flat, r / np.where(a > 0.0, a, 1.0),
                 (root - a) / np.where(flat, 1.0, slope))
    return np.clip((i + np.clip(s / h, 0.0, 1.0)) * h, 0.0, 1.0)


def rolling(times: np.ndarray, row: float, height: int, duration: float) -> np.ndarray:
    """(N,) shutter times in [0, 1] of samples at ``times`` (N,) on pixel row ``row`` (top-left
    origin, fractional for a band's middle) of a frame ``height`` rows tall, through a rolling
    shutter that reads the rows from top to bottom, each open for ``duration`` of the shutter
    (Cycles' Rolling Shutter Top-Bottom and its Duration, kernel/camera/camera.h: the row's
    time (row + 1) / height, the sample's time spread about it by ``duration``)."""
    row_time = (row + 1.0) / height
    t = (np.asarray(times, np.float64) - 0.5) * duration + (row_time - 0.5) * (1.0 - duration)
    return np.clip(t + 0.5, 0.0, 1.0)


def band_rows(reach: int, height: int, duration: float) -> int:
    """Rows that may share a rolling shutter's time (their middle row's, ``rolling``): those
    over which a point moves at most half a pixel, so that no row's time moves it by more
    than a quarter pixel; at least 1. ``reach``: the pixels a point moves from where the
    frame's own time draws it at most (``reach``), twice that over the whole shutter."""
    per_row = 2.0 * reach * (1.0 - duration) / height  # pixels moved from a row to the next
    return max(1, int(0.5 / per_row)) if per_row > 0.0 else height


def at_time(steps: np.ndarray, t: float) -> np.ndarray:
    """``steps`` (S, ...) at shutter time ``t`` in [0, 1], linear between the S steps."""
    s = len(steps)
    u = min(max(float(t), 0.0), 1.0) * (s - 1)
    i = min(int(np.floor(u)), s - 2)
    f = u - i
    return steps[i] * (1.0 - f) + steps[i + 1] * f


def shares(times: np.ndarray, count: int) -> np.ndarray:
    """(N,) int: the share of the shutter (of ``count`` even ones) each of ``times`` (N,) in
    [0, 1] falls in; share k is shaded at its middle, ``share_time``."""
    return np.minimum((np.asarray(times, np.float64) * count).astype(np.int64), count - 1)


def share_time(k: int, count: int) -> float:
    """The shutter time in [0, 1] share ``k`` of ``count`` is shaded at (its middle)."""
    return (k + 0.5) / count


def moved_normals(corners: np.ndarray, normals: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """(S, R, 3, 3) float32 unit corner normals of R triangles at the shutter's S steps: their
    ``normals`` (R, 3, 3) at the frame's own time carried by the linear map that takes each
    triangle's edges and face normal there (``corners`` (R, 3, 3)) to those at each step
    (``steps`` (S, R, 3, 3)), through its inverse transpose. Exact for a rigid motion and a
    uniform scale (for other deformations the face's own normal is); a triangle without area
    keeps its normals."""
    def frame_of(q):  # (..., 3, 3): columns the two edges and the normal scaled as an edge
        e1, e2 = q[..., 1, :] - q[..., 0, :], q[..., 2, :] - q[..., 0, :]
        c = np.cross(e1, e2)
        area = np.linalg.norm(c, axis=-1, keepdims=True)
        c = c / np.sqrt(np.maximum(area, 1e-30))
        return np.stack([e1, e2, c], -1), area[..., 0]

    here, area = frame_of(np.asarray(corners, np.float64))
    there, area_t = frame_of(np.asarray(steps, np.float64))
    flat = (area < 1e-20)[None] | (area_t < 1e-20)
    safe = np.where(flat[..., None, None], np.eye(3), here[None])
    # M = there @ here^-1 takes the frame to the step; normals go by M^-T = there^-T @ here^T
    to = np.where(flat[..., None, None], np.eye(3), there)
    m_inv_t = np.linalg.solve(np.swapaxes(to, -1, -2), np.swapaxes(safe, -1, -2))
    moved = np.einsum("srij,rcj->srci", m_inv_t, np.asarray(normals, np.float64))
    moved = np.where(flat[..., None, None], np.asarray(normals, np.float64)[None], moved)
    length = np.linalg.norm(moved, axis=-1, keepdims=True)
    return (moved / np.where(length > 0.0, length, 1.0)).astype(np.float32)


def view_at(camera: Camera, t: float) -> np.ndarray:
    """(4, 4) float64 world_to_camera of ``camera`` at shutter time ``t``."""
    if camera.motion is None:
        return np.asarray(camera.world_to_camera, np.float64)
    return at_time(np.asarray(camera.motion, np.float64), t)


def reach(camera: Camera, positions: np.ndarray, moving: np.ndarray | None,
          motion: np.ndarray | None) -> int:
    """Pixels by which a sample's time may move a point of the triangles ``positions``
    (T, 3, 3) from where the frame's own time draws it (the widest streak, rounded up, at
    most the frame's size): the margin a tile's triangles are gathered with. ``moving``,
    ``motion``: ``Frame.motion_row`` and ``Frame.motion``. 0 when nothing moves."""
    if camera.motion is None and motion is None:
        return 0
    rows = (np.arange(len(positions)) if camera.motion is not None
            else np.flatnonzero(moving >= 0))  # a still camera: the moving triangles alone
    here = np.asarray(positions[rows], np.float32)
    where = None if motion is None else moving[rows]
    proj = np.asarray(camera.projection, np.float64)
    steps = len(camera.motion) if camera.motion is not None else len(motion)
    base = _pixels(camera, projection.project(here, proj @ camera.world_to_camera, np.float64))
    widest = 0.0
    for k in range(steps):
        moved = here
        if where is not None:
            moved = here.copy()
            moved[where >= 0] = motion[k][where[where >= 0]]
        seen = _pixels(camera, projection.project(moved, proj @ view_at(camera, k / (steps - 1)),
                                                  np.float64))
        both = np.isfinite(base).all(-1) & np.isfinite(seen).all(-1)
        if both.any():
            widest = max(widest, float(np.abs(seen[both] - base[both]).max()))
    return int(np.ceil(min(widest, max(camera.width, camera.height)))) + 1


def _pixels(camera: Camera, clip: np.ndarray) -> np.ndarray:
    """(T, 3, 2) pixel positions of clip coordinates (T, 3, 4); NaN behind the camera."""
    w = clip[..., 3:4]
    ahead = w > 1e-6
    ndc = np.where(ahead, clip[..., :2] / np.where(ahead, w, 1.0), np.nan)
    return ndc * np.array([camera.width / 2.0, camera.height / 2.0])
