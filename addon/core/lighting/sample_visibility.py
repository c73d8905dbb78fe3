"""Which samples of an irradiance volume see a shaded point: depth moments and Chebyshev's bound.

A volume's sample stores, per direction, the mean and the mean square of the distance to the
surfaces around it (its depth moments), averaged over a lobe around that direction. A point at
distance r from the sample in direction w is taken to be seen from it with the probability
that Chebyshev's one-sided inequality bounds:

    P(depth >= r) <= var / (var + (r - mean)^2),   var = mean_square - mean^2,   r > mean

and 1 when r <= mean. The look-up weighs each of its eight samples by the cube of that bound,
which sharpens the fall to 0 behind a wall (Majercik et al. 2019, section 4.3; EEVEE Legacy's
irradiance grid "visibility" used the same test). A sample outside a room's wall sees the wall
nearer than the point inside, so it gives the point no light: the leak that the normal bias and
the facing weight otherwise hide by moving the point and blending away samples behind it.

References
----------
- Z. Majercik, J.-P. Guertin, D. Nowrouzezahrai, M. McGuire, "Dynamic Diffuse Global
  Illumination with Ray-Traced Irradiance Fields", JCGT 8(2), 2019.
- W. Donnelly, A. Lauritzen, "Variance Shadow Maps", I3D 2006 (the bound on a depth test).
"""

from __future__ import annotations

import functools

import numpy as np

from ..formulas import cubemap

__all__ = ["CAPTURE_MAX", "LOBE_POWER", "SIZE", "VARIANCE_FLOOR", "chebyshev", "max_distance",
           "moments"]

SIZE = 8
"""Cube face side of the stored moments, texels."""
CAPTURE_MAX = 32
"""Captures larger than this are averaged down to it before the lobes (their moments, 2 x 2
texels at a time: a lobe of 10 degrees spans several texels of a 32 texel face)."""
LOBE_POWER = 50.0
"""The moments are averaged over max(0, cos)^LOBE_POWER around each texel's direction (a lobe
of about 10 degrees half width at half maximum; the 2019 paper's depth exponent)."""
VARIANCE_FLOOR = 1e-4
"""The smallest variance the bound uses, in squared sample spacings: a flat wall whose depth
varies nothing within the lobe still fades over a hundredth of a spacing."""


def max_distance(local_to_world: np.ndarray, resolution) -> float:
    """The distance the moments are clamped at, metres: 1.5 times the longest cell diagonal,
    beyond a point inside the box and the eight samples around it (at most one diagonal apart,
    plus its biases). A point farther from a sample (in the influence band beyond the box) is
    tested at this distance."""
    scale = np.linalg.norm(np.asarray(local_to_world, np.float64)[:3, :3], axis=0)
    cell = 2.0 * scale / np.maximum(np.asarray(resolution, np.float64), 1.0)
    return float(1.5 * np.linalg.norm(cell))


@functools.lru_cache(maxsize=4)
def _lobes(capture_size: int, size: int, power: float) -> np.ndarray:
    """(6 size^2, 6 capture_size^2) float32: row i holds the lobe weights of texel i of the
    moments' cube over the capture's texels (cos^power times solid angle), summing to 1."""
    out_dirs = cubemap.texel_directions64(size).reshape(-1, 3)
    in_dirs = cubemap.texel_directions64(capture_size).reshape(-1, 3)
    solid = np.broadcast_to(cubemap.texel_solid_angles(capture_size),
                            (6, capture_size, capture_size)).reshape(-1)
    w = np.maximum(out_dirs @ in_dirs.T, 0.0) ** power * solid
    return (w / w.sum(axis=1, keepdims=True)).astype(np.float32)


def moments(distances: np.ndarray, far: float, size: int = SIZE,
            power: float = LOBE_POWER) -> np.ndarray:
    """The depth moments of one sample from the ray lengths of its capture.

    distances: (6, S, S) metres along each texel centre's ray to the first surface, inf where
               none (``capture.Surfaces.distances``); beyond ``CAPTURE_MAX`` texels, averaged
               down to it first
    far:       distances are clamped to this (``max_distance``), metres
    returns:   (6, size, size, 2) float32: mean and mean square of the clamped distance over
               the lobe around each texel's direction
    """
    d = np.minimum(np.asarray(distances, np.float64), far)
    both = np.stack([d, d * d], axis=-1)
    while both.shape[1] > CAPTURE_MAX and both.shape[1] % 2 == 0:
        s = both.shape[1] // 2
        both = both.reshape(6, s, 2, s, 2, 2).mean(axis=(2, 4))
    lobes = _lobes(both.shape[1], size, float(power))
    return (lobes @ both.reshape(-1, 2).astype(np.float32)).reshape(6, size, size, 2)


def chebyshev(r: np.ndarray, mean: np.ndarray, mean_square: np.ndarray,
              floor: float) -> np.ndarray:
    """The weight of a sample for points at distance ``r`` (metres) from it, given the moments
    towards them: 1 where r <= mean, else the cube of Chebyshev's bound var / (var +
    (r - mean)^2), var = max(mean_square - mean^2, ``floor``) (metres squared)."""
    r, mean = np.asarray(r, np.float64), np.asarray(mean, np.float64)
    var = np.maximum(np.asarray(mean_square, np.float64) - mean * mean, floor)
    bound = var / (var + (r - mean) ** 2)
    return np.where(r <= mean, 1.0, bound ** 3)
