"""Depth of field with the samples the engine already takes: each anti-aliasing sample sees
the scene from its own point of the camera's aperture (a thin lens, Cycles' model: Camera >
Depth of Field), and their average is the blurred image (the accumulation buffer, Haeberli and
Akeley 1990).

A lens point d = (dx, dy) (camera space, metres) sees a point x of camera space where the
pinhole sees x'' = (x - dx - dx z / s, y - dy - dy z / s, z) (s: the focus distance, z < 0):
the line from d through x meets the focus plane at the point the pinhole projects there. That is
linear, so a sample's clip coordinates are the pinhole's times one 4 x 4 matrix
(``clip_transform``): the frame is projected once, each sample re-projects its tile.

Lens points follow the Halton sequence in bases 2 and 3 (independent of the pixel filter's R2
positions), mapped to the disc or to the regular polygon of ``blades`` sides and rotation
(uniform over its area), the width divided by the anamorphic ratio: Cycles'
``camera_sample_aperture``. All pixels share a sample's lens point, so a blur of radius R
pixels shows the samples' images apart until there are about R^2 of them.
"""

from __future__ import annotations

import numpy as np

from ..scene import Aperture, Camera


def halton(index: np.ndarray, base: int) -> np.ndarray:
    """(N,) float64 in [0, 1): the Halton (van der Corput) sequence in ``base`` at positions
    ``index`` (N,) >= 1."""
    out = np.zeros(len(index))
    f = 1.0
    i = np.asarray(index, np.int64).copy()
    while i.any():
        f /= base
        out += f * (i % base)
        i //= base
    return out


def unit_aperture(samples: np.ndarray, blades: int, rotation: float) -> np.ndarray:
    """(N, 2) points of the unit disc (``blades`` < 3) or of the regular polygon of
    ``blades`` corners on the unit circle, the first at angle ``rotation``, each uniform over
    the area, from (N, 2) numbers in [0, 1)."""
    u, v = samples[:, 0], samples[:, 1]
    if blades < 3:
        r, phi = np.sqrt(u), 2.0 * np.pi * v
        return np.stack([r * np.cos(phi), r * np.sin(phi)], -1)
    corner = np.floor(u * blades)
    u = u * blades - corner  # which triangle (centre, corner k, corner k + 1), then where
    su = np.sqrt(u)  # uniform in the triangle: the weights of its two outer corners
    w1, w2 = su * (1.0 - v), su * v
    t0 = rotation + corner * 2.0 * np.pi / blades
    t1 = t0 + 2.0 * np.pi / blades
    return np.stack([w1 * np.cos(t0) + w2 * np.cos(t1), w1 * np.sin(t0) + w2 * np.sin(t1)], -1)


def lens_points(aperture: Aperture, sample: np.ndarray) -> np.ndarray:
    """(N, 2) lens points (camera space x, y, metres) of sample numbers ``sample`` (N,)."""
    index = np.asarray(sample, np.int64) + 1
    unit = unit_aperture(np.stack([halton(index, 2), halton(index, 3)], -1),
                         int(aperture.blades), float(aperture.rotation))
    unit[:, 0] /= max(float(aperture.ratio), 1e-6)
    return unit * float(aperture.radius)


def clip_transform(camera: Camera, lens: np.ndarray) -> np.ndarray:
    """(4, 4) float64: the clip coordinates lens point ``lens`` (2,) sees, from the pinhole's
    (P S P^-1, S the camera-space map of the module's docstring)."""
    s = float(camera.aperture.focus)
    dx, dy = float(lens[0]), float(lens[1])
    shear = np.eye(4)
    shear[0, 2], shear[0, 3] = -dx / s, -dx
    shear[1, 2], shear[1, 3] = -dy / s, -dy
    proj = np.asarray(camera.projection, np.float64)
    return proj @ shear @ np.linalg.inv(proj)


def eye(camera: Camera, lens: np.ndarray) -> np.ndarray:
    """(3,) world position of lens point ``lens`` (2,)."""
    return (camera.camera_to_world @ np.array([lens[0], lens[1], 0.0, 1.0]))[:3]


def background_shift(camera: Camera, lens: np.ndarray) -> tuple[float, float]:
    """Pixels by which lens point ``lens`` moves what is infinitely far (x right, y down)."""
    proj = np.asarray(camera.projection, np.float64)
    s = float(camera.aperture.focus)
    return (proj[0, 0] * lens[0] / s * camera.width / 2.0,
            -proj[1, 1] * lens[1] / s * camera.height / 2.0)


def reach(camera: Camera, positions: np.ndarray) -> int:
    """Pixels by which a sample may move a point of the triangles ``positions`` (T, 3, 3)
    (the widest blur radius over their depths, rounded up, at most the frame's size): the
    margin a tile's triangles are gathered with. 0 without an aperture."""
    a = camera.aperture
    if a is None or camera.orthographic or not len(positions):
        return 0
    row = np.asarray(camera.world_to_camera, np.float64)[2]
    depth = -(np.asarray(positions, np.float64).reshape(-1, 3) @ row[:3] + row[3])
    proj = np.asarray(camera.projection, np.float64)
    near = proj[2, 3] / (proj[2, 2] - 1.0)
    ahead = depth[depth > near * 0.999]
    if not len(ahead):
        return 0
    z = np.array([max(ahead.min(), near), ahead.max()])
    radius = a.radius * max(1.0, 1.0 / max(a.ratio, 1e-6))
    tangent = radius * np.abs(1.0 / a.focus - 1.0 / z).max()
    pixels = tangent * max(proj[0, 0] * camera.width, proj[1, 1] * camera.height) / 2.0
    return int(np.ceil(min(pixels, max(camera.width, camera.height)))) + 1
