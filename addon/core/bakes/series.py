"""The bounces a bake does not compute, estimated from the ones it did.

Each bounce adds the light of one more bounce; in a closed box of albedo rho the increments
shrink by rho each time, and in a room by about its mean albedo times the share of light that
stays in. The last increment d_n continues as a geometric series of the ratio r = d_n / d_(n-1)
of the last two increments, summed over the whole bake per channel: the tail d_n r / (1 - r)
(as a progressive radiosity's ambient term: Cohen, Chen, Wallace and Greenberg 1988, "A
progressive refinement approach to fast radiosity image generation"). Used by the probe bake
(``bake``) and the lightmap bake (``lightmap_bake``).
"""

from __future__ import annotations

import numpy as np

MAX_RATIO = 0.9  # r at most: the tail at most 9 times the last increment


def tail_factor(last: np.ndarray, before: np.ndarray) -> np.ndarray:
    """r / (1 - r) per channel, r = last / before clipped to [0, ``MAX_RATIO``] (0 where
    ``before`` is not positive): ``last`` and ``before`` (C,) the sums of the last two
    increments, float64."""
    last, before = np.asarray(last, np.float64), np.asarray(before, np.float64)
    ratio = np.clip(np.where(before > 0.0, last / np.where(before > 0.0, before, 1.0), 0.0),
                    0.0, MAX_RATIO)
    return ratio / (1.0 - ratio)
