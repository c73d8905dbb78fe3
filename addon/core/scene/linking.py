"""Light and shadow linking (Blender 4.0+, Object > Shading > Light Linking and Shadow Linking):
a light lights only the objects of its receiver collection and is shadowed only by those of
its blocker collection.

As Cycles stores them, a scene holds at most ``SETS`` linking sets of each kind: set 0 holds
every object (the lights without a collection), each other set is one collection. A light names
its set (``Light.receivers``, ``Light.blockers``), a mesh the sets it belongs to as a bit mask
(``MeshBatch.light_sets``, ``MeshBatch.shadow_sets``).
"""

from __future__ import annotations

import numpy as np

SETS = 64  # linking sets of each kind a scene holds, set 0 included (Cycles' LIGHT_LINK_SET_MAX)
EVERY = (1 << SETS) - 1  # the mask of a mesh in every set


def member(name: str, included: set, excluded: set) -> bool:
    """Whether object ``name`` is in a linking collection whose entries are ``included`` and
    ``excluded`` (names), by Blender's rule: only included objects, those alone; only excluded
    ones, every object but those; both, the included less the excluded."""
    if name in excluded:
        return False
    return not included or name in included


def mask(name: str, collections: list[tuple[set, set]]) -> int:
    """The sets object ``name`` belongs to: bit 0, and bit k for ``collections[k - 1]``
    (included, excluded) when ``member``; every bit beyond them set."""
    bits = EVERY & ~((1 << (len(collections) + 1)) - 1) | 1
    for k, (included, excluded) in enumerate(collections, 1):
        if member(name, included, excluded):
            bits |= 1 << k
    return bits


def in_set(masks: np.ndarray, k: int) -> np.ndarray:
    """(N,) bool: which of ``masks`` (N,) uint64 hold set ``k``."""
    return ((masks >> np.uint64(k)) & np.uint64(1)).astype(bool)


def linked(lights) -> tuple[bool, bool]:
    """Whether any of ``lights`` has a receiver set, and whether any has a blocker set."""
    return (any(light.receivers for light in lights), any(light.blockers for light in lights))
