"""The probes of the world alone: its cube of radiance, that cube's SH and prefiltered chains,
kept per world. Every probe falls back on them, and a scene without probes is lit by them.
"""

from __future__ import annotations

import numpy as np

from ..formulas import cubemap, prefilter, sh
from ..scene import World
from ..system.cache import Cache
from .probes import Probes

__all__ = ["filtered", "world_cube", "world_key", "world_probes"]


def world_cube(world: World, size: int) -> np.ndarray:
    """(6, size, size, 3) float32 radiance of the world: its colour, or its Environment Texture
    (Blender's equirectangular mapping and Mapping rotation) times strength, resampled without
    aliasing by ``cubemap.equirect_to_cube``."""
    if world.texture is None:
        return np.broadcast_to(np.asarray(world.color, np.float32)[:3],
                               (6, size, size, 3)).copy()
    cube = cubemap.equirect_to_cube(world.texture.linear(0)[..., :3], size,
                                    rotation=world.rotation)
    return (cube * np.float32(world.strength)).astype(np.float32)


def filtered(cube: np.ndarray) -> tuple[np.ndarray, dict[str, list[np.ndarray]]]:
    """SH (9, 3) and both prefiltered chains {"bo2": cosine power, "bo1": angular Gaussian} of
    a captured cube (6, S, S, 3)."""
    size = cube.shape[1]
    coeffs = sh.project(cubemap.texel_directions(size).reshape(-1, 3), cube.reshape(-1, 3),
                        np.broadcast_to(cubemap.texel_solid_angles(size),
                                        (6, size, size)).reshape(-1))
    chains = {"bo2": prefilter.prefilter_cosine_power(cube),
              "bo1": prefilter.prefilter_angular_gaussian(cube)}
    return np.asarray(coeffs, np.float32), chains


def world_key(world: World, size: int) -> tuple:
    """A key that changes whenever the world's probe would (its texture by content)."""
    digest = world.texture.digest if world.texture is not None else None
    return (digest, np.asarray(world.color, np.float32).tobytes(), float(world.strength),
            np.asarray(world.rotation, np.float64).tobytes(), int(size))


# world_key -> (SH, chains): the scene's world and a few studio lights switched between
_worlds = Cache("world probes", kept=4)


def world_probes(world: World, size: int = 64) -> Probes:
    """Probes of the world alone, the fallback of every probe (SH (9, 3) and both chains of
    its ``size`` cube), computed once per world (the last few worlds are kept)."""
    world_sh, world_mips = _worlds.get_or_make(world_key(world, size),
                                               lambda: filtered(world_cube(world, size)))
    color = None if world.texture is not None else np.asarray(world.color, np.float32)[:3]
    return Probes(world_sh=world_sh, world_mips=world_mips, world_color=color)
